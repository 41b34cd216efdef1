"""Free labels the grasp can trust: the map's surface guard and sticky hits (MapConfig).

OctoMap frees every voxel a ray's line crosses, so a voxel a board fills in part is labelled
free by rays through its empty part (grazing rays over its face, rays beside its edge), and
a few such misses flip a once-hit voxel to free. Depth images are rendered analytically
from boxes here (the wrist camera's 320 x 240 px, 58 deg vertical field of view).
"""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at
from compass_manip.mapping import raycast
from compass_manip.mapping.depth_cues import depth_cues
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState

W, H = 320, 240
FY = (H / 2) / math.tan(math.radians(29.0))
K = np.array([[FY, 0.0, (W - 1) / 2], [0.0, FY, (H - 1) / 2], [0.0, 0.0, 1.0]])
# a 2 cm board whose top face lies 1.6 mm into a voxel row (as cab_shelf0 in scene (1, 2))
BOARD = (np.array([0.2, -0.3, 0.582]), np.array([0.8, 0.3, 0.6016]))
WALL = (np.array([1.0, -1.0, 0.0]), np.array([1.05, 1.0, 1.2]))
BOX = dict(box_min=(0.0, -0.4, 0.3), box_max=(1.1, 0.4, 1.0))
OCTOMAP = dict(surface_guard=False, sticky_hits=0)


def render(T, boxes):
    """z-depth image [m] of axis-aligned boxes seen from T_world_cam (+inf: no return)."""
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    d_cam = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones(u.shape)], -1).reshape(-1, 3)
    d = d_cam @ T[:3, :3].T
    o = T[:3, 3]
    best = np.full(len(d), np.inf)
    for lo, hi in boxes:
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = (lo - o) / d, (hi - o) / d
        t_in, t_out = np.nanmax(np.minimum(a, b), 1), np.nanmin(np.maximum(a, b), 1)
        hit = (t_in <= t_out) & (t_in > 0) & (t_in < best)
        best[hit] = t_in[hit]
    return best.reshape(H, W)


def camera(elevation_deg, distance=0.5, target=(0.5, 0.0, 0.6016)):
    """Looking at target from the -x side, elevation_deg above the board's top face."""
    e = math.radians(elevation_deg)
    t = np.asarray(target)
    return look_at(t + distance * np.array([-math.cos(e), 0.0, math.sin(e)]), t)


def filled(occ, box):
    """Voxels whose cube overlaps the box (the board fills part of them)."""
    c, h = occ.voxel_centers(), occ.resolution / 2
    return np.all((c + h > box[0]) & (c - h < box[1]), axis=-1)


def open_space(occ):
    """Voxels farther than 1.5 voxels from the board and the wall."""
    c, h = occ.voxel_centers(), 1.5 * occ.resolution
    near = np.zeros(occ.shape, bool)
    for lo, hi in (BOARD, WALL):
        near |= np.all((c + h > lo) & (c - h < hi), axis=-1)
    return ~near


@pytest.mark.parametrize("elevation", [5.0, 10.0, 20.0])
def test_a_board_seen_at_grazing_incidence_keeps_every_voxel_it_fills(elevation):
    T = camera(elevation)
    depth = render(T, [BOARD, WALL])
    ours, octo = OccupancyMap(MapConfig(**BOX)), OccupancyMap(MapConfig(**BOX, **OCTOMAP))
    ours.integrate(depth, K, T, 2.0)
    octo.integrate(depth, K, T, 2.0)
    board = filled(ours, BOARD)
    # OctoMap's rule frees hundreds of the voxels the board fills (its top face lies in them)
    assert np.sum(board & (octo.state == VoxelState.FREE)) > 200
    assert not np.any(board & (ours.state == VoxelState.FREE))
    # open space is still freed: all but a few per cent of what OctoMap frees (the rest lies
    # in the shadow of the board's far edge, next to the rays that pass over it)
    op = open_space(ours)
    n_octo = np.sum(op & (octo.state == VoxelState.FREE))
    assert n_octo > 100_000
    assert np.sum(op & (ours.state == VoxelState.FREE)) >= 0.9 * n_octo
    assert not np.any(op & (ours.state == VoxelState.FREE) & (octo.state != VoxelState.FREE))


def test_the_unseen_side_of_an_edge_is_not_freed_by_rays_beside_it():
    # a side wall seen from in front: its outer face (y = -0.432) faces away from the camera;
    # rays passing just outside it cross the voxels its 2 mm fill (cab_right in scene (1, 2))
    side = (np.array([0.384, -0.432, 0.3]), np.array([0.718, -0.412, 0.9]))
    T = look_at(np.array([0.0, -0.4, 0.6]), np.array([0.8, -0.5, 0.6]))
    depth = render(T, [side, WALL])
    box = dict(box_min=(0.0, -0.7, 0.3), box_max=(1.1, 0.2, 1.0))
    ours, octo = OccupancyMap(MapConfig(**box)), OccupancyMap(MapConfig(**box, **OCTOMAP))
    ours.integrate(depth, K, T, 2.0)
    octo.integrate(depth, K, T, 2.0)
    wall = filled(ours, side)
    assert np.sum(wall & (octo.state == VoxelState.FREE)) > 10
    assert not np.any(wall & (ours.state == VoxelState.FREE))


def test_head_on_surfaces_leave_no_unknown_skin():
    # a wall at x = 0.9 seen head-on: the voxel row in front of its voxel row is freed
    wall = (np.array([0.9, -1.0, 0.0]), np.array([1.0, 1.0, 1.2]))
    T = look_at(np.array([0.3, 0.0, 0.65]), np.array([1.0, 0.0, 0.65]))
    occ = OccupancyMap(MapConfig(**BOX))
    occ.integrate(render(T, [wall]), K, T, 2.0)
    i = occ.world_to_voxel(np.array([[0.895, 0.0, 0.65]]))[0]
    assert occ.state[i[0] + 1, i[1], i[2]] == VoxelState.OCCUPIED
    assert np.all(occ.state[i[0], i[1] - 5:i[1] + 6, i[2] - 5:i[2] + 6] == VoxelState.FREE)


@pytest.mark.parametrize("sticky, expect", [(1, VoxelState.OCCUPIED), (0, VoxelState.FREE)])
def test_sticky_hits_keep_a_once_hit_voxel_occupied(sticky, expect):
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.1, 0.1, 0.1), sticky_hits=sticky))
    o = np.array([0.005, 0.005, 0.005])
    occ.integrate_points(np.array([[0.045, 0.005, 0.005]]), o)  # hit voxel (4, 0, 0) once
    for _ in range(6):  # rays through it to a point behind
        occ.integrate_points(np.array([[0.085, 0.005, 0.005]]), o)
    assert occ.state[4, 0, 0] == expect
    assert occ.hits[4, 0, 0] == 1 and occ.hits[8, 0, 0] == 6
    # a voxel first freed and then hit once becomes occupied (sticky) or stays free (OctoMap)
    occ.integrate_points(np.array([[0.025, 0.005, 0.005]]), o)
    assert occ.state[2, 0, 0] == expect
    occ.set_voxels(np.array([[4, 0, 0]]), VoxelState.FREE)  # a forced label is a prior, not a hit
    assert occ.hits[4, 0, 0] == 0 and occ.copy().hits[8, 0, 0] == 6


def test_depth_cues_give_the_plane_normal_spacing_and_shadows():
    T = camera(30.0)
    depth = render(T, [BOARD, WALL])
    cues = depth_cues(depth.astype(np.float32), K[0, 0], K[1, 1], K[0, 2], K[1, 2],
                              np.ascontiguousarray(T[:3, :3]), 1, 0.005, 0.0087)
    assert cues.shape == (W * H, 6)
    on_top = np.isfinite(depth.ravel())
    pts, kind = raycast.backproject(depth.astype(np.float32), K[0, 0], K[1, 1], K[0, 2], K[1, 2],
                                    np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]), 1)
    top = on_top & (np.abs(pts[:, 2] - 0.6016) < 1e-6) & (np.abs(pts[:, 0] - 0.5) < 0.2)
    n = cues[top, :3]
    assert np.allclose(np.abs(n[:, 2]), 1.0, atol=1e-3)  # the top face's normal is vertical
    # spacing along the face: the pixel footprint stretched by 1 / sin(incidence)
    r = np.linalg.norm(pts[top] - T[:3, 3], axis=1)
    assert np.all(cues[top, 3] > 0.9 * r / FY) and np.median(cues[top, 3]) < 4 * np.median(r) / FY
    # shadows only on rays beside the board's far edge (they end on the wall behind it)
    shadowed = cues[:, 4] < np.inf
    assert shadowed.any() and not np.any(shadowed & top)
    assert np.all(pts[shadowed & (kind == raycast.KIND_POINT), 0] > 0.99)  # all on the wall
    assert np.all(cues[shadowed, 5] > cues[shadowed, 4])


def test_map_config_checks_the_new_settings():
    with pytest.raises(CompassInputError, match="sticky_hits"):
        MapConfig(sticky_hits=-1)
    with pytest.raises(CompassInputError, match="sticky_hits"):
        MapConfig(sticky_hits=True)
    with pytest.raises(CompassInputError, match="surface_guard"):
        MapConfig(surface_guard="yes")
