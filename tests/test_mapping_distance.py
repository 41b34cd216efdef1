"""Distance field of unsafe space against brute force; safe carve-outs; lookups."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.mapping.distance import (
    DistanceField,
    DistanceFieldConfig,
    Interpolation,
    unsafe_mask,
)
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState


def random_map(seed=0):
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.12, 0.10, 0.08)))
    rng = np.random.default_rng(seed)
    occ.state[:] = rng.choice(np.array([0, 1, 2], np.uint8), size=occ.shape, p=[0.03, 0.95, 0.02])
    return occ


def brute_force(unsafe, res, outside_is_unsafe):
    if outside_is_unsafe:
        unsafe = np.pad(unsafe, 1, constant_values=True)
    obst = np.argwhere(unsafe)
    cells = np.argwhere(np.ones(unsafe.shape, bool))
    d = np.sqrt(((cells[:, None, :] - obst[None, :, :]) ** 2).sum(-1)).min(axis=1) * res
    d = d.reshape(unsafe.shape)
    return d[1:-1, 1:-1, 1:-1] if outside_is_unsafe else d


@pytest.mark.parametrize("outside_is_unsafe", [True, False])
def test_field_matches_brute_force(outside_is_unsafe):
    occ = random_map()
    cfg = DistanceFieldConfig(outside_is_unsafe=outside_is_unsafe)
    field = DistanceField.from_map(occ, cfg)
    expect = brute_force(occ.state != VoxelState.FREE, occ.resolution, outside_is_unsafe)
    assert np.allclose(field.distances, expect, atol=1e-6)
    assert np.all(field.distances[occ.state != VoxelState.FREE] == 0.0)


def test_safe_voxels_and_spheres_are_carved_out():
    occ = random_map(1)
    c = np.array([[0.055, 0.045, 0.035]])
    r = np.array([0.021])
    unsafe = unsafe_mask(occ, safe_spheres=(c, r))
    centres = occ.voxel_centers()
    inside = np.linalg.norm(centres - c[0], axis=-1) <= r[0]
    assert inside.sum() == 33  # voxel centres within 2.1 voxels of a voxel centre
    assert not unsafe[inside].any()
    assert np.array_equal(unsafe[~inside], (occ.state != VoxelState.FREE)[~inside])
    safe = np.zeros(occ.shape, bool)
    safe[0] = True
    assert not unsafe_mask(occ, safe_voxels=safe)[0].any()
    field = DistanceField.from_map(occ, safe_spheres=(c, r))
    assert np.allclose(field.distances, brute_force(unsafe, occ.resolution, True), atol=1e-6)
    with pytest.raises(CompassInputError, match="safe_voxels"):
        unsafe_mask(occ, safe_voxels=np.zeros((2, 2, 2), bool))


def test_lookup_nearest_trilinear_and_outside():
    occ = random_map(2)
    field = DistanceField.from_map(occ)
    idx = np.argwhere(np.ones(occ.shape, bool))
    centres = occ.voxel_to_world(idx)
    d = field.distances[idx[:, 0], idx[:, 1], idx[:, 2]]
    assert np.allclose(field.distance_at(centres), d, atol=1e-6)
    near = DistanceField(field.distances, field.grid_min, field.resolution,
                         DistanceFieldConfig(interpolation=Interpolation.NEAREST))
    jitter = np.random.default_rng(0).uniform(-0.0049, 0.0049, centres.shape)
    assert np.allclose(near.distance_at(centres + jitter), d, atol=1e-6)
    # trilinear halfway between two voxel centres along x is the mean of both
    a = np.array([[3, 4, 2]])
    mid = occ.voxel_to_world(a) + [0.005, 0.0, 0.0]
    assert field.distance_at(mid)[0] == pytest.approx(
        0.5 * (field.distances[3, 4, 2] + field.distances[4, 4, 2]), abs=1e-6)
    outside = np.array([[-0.01, 0.05, 0.04], [0.05, 0.05, 0.5]])
    assert field.distance_at(outside).tolist() == [0.0, 0.0]
    free_out = DistanceField.from_map(occ, DistanceFieldConfig(outside_is_unsafe=False))
    proj = np.array([[0.0, 0.05, 0.04], [0.05, 0.05, 0.08 - 1e-12]])
    assert np.allclose(free_out.distance_at(outside), free_out.distance_at(proj))


def test_field_equals_scipy_on_a_larger_grid():
    from scipy import ndimage

    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.6, 0.5, 0.4)))
    rng = np.random.default_rng(5)
    occ.state[:] = rng.choice(np.array([0, 1, 2], np.uint8), size=occ.shape, p=[0.004, 0.995, 0.001])
    field = DistanceField.from_map(occ, DistanceFieldConfig(outside_is_unsafe=False))
    ref = ndimage.distance_transform_edt(occ.state == VoxelState.FREE, sampling=occ.resolution)
    assert np.allclose(field.distances, ref, atol=1e-6)
    occ.state[:] = VoxelState.FREE
    assert np.all(np.isinf(DistanceField.from_map(occ, DistanceFieldConfig(outside_is_unsafe=False)).distances))
