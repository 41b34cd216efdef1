"""Frontier voxels and clusters on hand-built maps."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.mapping.frontiers import FrontierConfig, find_frontiers, frontier_mask
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState

U, F, O = VoxelState.UNKNOWN, VoxelState.FREE, VoxelState.OCCUPIED


def grid_map():
    """10^3 voxels of 1 cm from the origin: x < 5 free, x >= 5 unknown, an occupied wall
    at x = 5 for y < 5, and a free two-voxel pocket at (8, 2, 2..3)."""
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.1, 0.1, 0.1)))
    occ.state[:5] = F
    occ.state[5, :5] = O
    occ.state[8, 2, 2:4] = F
    return occ


def brute_force_mask(state):
    n = np.array(state.shape)
    out = np.zeros(state.shape, bool)
    for idx in np.argwhere(state == F):
        for off in np.vstack([np.eye(3, dtype=int), -np.eye(3, dtype=int)]):
            nb = idx + off
            if np.all(nb >= 0) and np.all(nb < n) and state[tuple(nb)] == U:
                out[tuple(idx)] = True
    return out


def test_mask_matches_definition():
    occ = grid_map()
    mask = frontier_mask(occ.state)
    expect = np.zeros(occ.shape, bool)
    expect[4, 5:] = True
    expect[8, 2, 2:4] = True
    assert np.array_equal(mask, expect)
    rng = np.random.default_rng(0)
    state = rng.choice(np.array([0, 1, 2], np.uint8), size=(7, 6, 5), p=[0.4, 0.45, 0.15])
    assert np.array_equal(frontier_mask(state), brute_force_mask(state))


def test_clusters_centroid_size_direction():
    occ = grid_map()
    clusters = find_frontiers(occ, FrontierConfig(min_cluster_size=3))
    assert len(clusters) == 1
    c = clusters[0]
    assert c.size == 50
    assert np.allclose(c.centroid_world, [0.045, 0.075, 0.05])
    assert np.allclose(c.direction, [1.0, 0.0, 0.0])
    assert sorted(map(tuple, c.voxels.tolist())) == [(4, j, k) for j in range(5, 10) for k in range(10)]
    both = find_frontiers(occ, FrontierConfig(min_cluster_size=1))
    assert [x.size for x in both] == [50, 2]
    pocket = both[1]
    assert np.allclose(pocket.centroid_world, [0.085, 0.025, 0.03])
    # the pocket's directions cancel (+z and -z); the most frequent unknown offset is +x
    assert np.allclose(pocket.direction, [1.0, 0.0, 0.0])


def test_connectivity_and_direction_of_a_diagonal_frontier():
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.06, 0.06, 0.03)))
    occ.state[:] = O
    occ.state[1, 1, 1] = F
    occ.state[2, 2, 1] = F  # touches (1, 1, 1) only diagonally
    occ.state[1, 2, 1] = U  # unknown +y of the first, -x of the second
    c26 = find_frontiers(occ, FrontierConfig(min_cluster_size=1, connectivity=26))
    c6 = find_frontiers(occ, FrontierConfig(min_cluster_size=1, connectivity=6))
    assert [c.size for c in c26] == [2] and [c.size for c in c6] == [1, 1]
    assert np.allclose(c26[0].direction, np.array([-1.0, 1.0, 0.0]) / np.sqrt(2))
    assert find_frontiers(OccupancyMap(occ.config)) == ()
    with pytest.raises(CompassInputError, match="connectivity"):
        FrontierConfig(connectivity=8)


@pytest.mark.parametrize("connectivity", [6, 18, 26])
def test_clusters_match_scipy_connected_components(connectivity):
    from scipy import ndimage

    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.2, 0.15, 0.12)))
    rng = np.random.default_rng(connectivity)
    occ.state[:] = rng.choice(np.array([0, 1, 2], np.uint8), size=occ.shape, p=[0.5, 0.4, 0.1])
    mask = frontier_mask(occ.state)
    rank = {6: 1, 18: 2, 26: 3}[connectivity]
    labels, n = ndimage.label(mask, structure=ndimage.generate_binary_structure(3, rank))
    clusters = find_frontiers(occ, FrontierConfig(min_cluster_size=1, connectivity=connectivity))
    assert len(clusters) == n
    expect = sorted(tuple(sorted(map(tuple, np.argwhere(labels == k).tolist()))) for k in range(1, n + 1))
    got = sorted(tuple(sorted(map(tuple, c.voxels.tolist()))) for c in clusters)
    assert got == expect
