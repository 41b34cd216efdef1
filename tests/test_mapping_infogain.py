"""Information gain against frustum voxel counts, walls, and the batch version."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at
from compass_manip.mapping.infogain import camera_ray_directions, info_gain, info_gain_batch
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState

K = np.array([[50.0, 0.0, 15.5], [0.0, 50.0, 11.5], [0.0, 0.0, 1.0]])  # 32 x 24 px
# the wrist camera: 320 x 240 px, 58 deg vertical field of view
f = 120.0 / np.tan(np.radians(29.0))
K_WRIST = np.array([[f, 0.0, 159.5], [0.0, f, 119.5], [0.0, 0.0, 1.0]])


def frustum_count(occ, T, K, max_range, shrink, x_max=np.inf):
    """Voxel centres within `shrink` [m] inside (shrink < 0: outside) the frustum of
    directions through the image, cut at distance max_range and at world x <= x_max."""
    a_x = (K[0, 2] + 0.5) / K[0, 0]  # image half-width at z = 1: x / z in [-a_x, a_x]
    a_y = (K[1, 2] + 0.5) / K[1, 1]
    c = occ.voxel_centers().reshape(-1, 3)
    p = (c - T[:3, 3]) @ T[:3, :3]
    inside = np.linalg.norm(p, axis=1) <= max_range - shrink
    for a, axis in ((a_x, 0), (a_y, 1)):
        for sgn in (1.0, -1.0):
            n = np.zeros(3)
            n[axis], n[2] = sgn, -a
            inside &= p @ (n / np.linalg.norm(n)) <= -shrink
    inside &= c[:, 0] <= x_max - shrink
    return int(inside.sum())


def unknown_map():
    return OccupancyMap(MapConfig(box_min=(-0.05, -0.3, 0.2), box_max=(0.35, 0.3, 0.8)))


def test_all_unknown_gain_is_frustum_voxel_count():
    # rays dense enough that every voxel inside the frustum is crossed (< 7 mm apart at 0.5 m)
    occ = OccupancyMap(MapConfig(box_min=(-0.05, -0.45, 0.1), box_max=(0.55, 0.45, 0.9)))
    T = look_at([0.003, 0.002, 0.501], [1.0, 0.002, 0.501])
    r = np.sqrt(3) / 2 * occ.resolution  # a voxel lies within r of its centre
    gain = info_gain(occ, T, K_WRIST, 0.5, rays=(160, 120))
    nominal = frustum_count(occ, T, K_WRIST, 0.5, 0.0)
    assert frustum_count(occ, T, K_WRIST, 0.5, r) <= gain <= frustum_count(occ, T, K_WRIST, 0.5, -r)
    assert abs(gain - nominal) < 0.1 * nominal
    # camera outside the grid: rays enter through its -x face
    T_out = look_at([-0.15, 0.002, 0.501], [1.0, 0.002, 0.501])
    gain = info_gain(occ, T_out, K_WRIST, 0.5, rays=(160, 120))
    assert frustum_count(occ, T_out, K_WRIST, 0.5, r) <= gain <= frustum_count(occ, T_out, K_WRIST, 0.5, -r)
    assert gain > 10000
    # a smaller camera, shorter range
    occ = unknown_map()
    gain = info_gain(occ, T, K, 0.25, rays=(80, 60))
    assert frustum_count(occ, T, K, 0.25, r) <= gain <= frustum_count(occ, T, K, 0.25, -r)


def test_wall_limits_gain_and_wall_at_1cm_gives_zero():
    occ = unknown_map()
    T = look_at([0.003, 0.002, 0.501], [1.0, 0.002, 0.501])
    wall = occ.world_to_voxel(np.array([[0.105, 0.0, 0.5]]))[0, 0]
    occ.state[wall] = VoxelState.OCCUPIED
    r = np.sqrt(3) / 2 * occ.resolution
    gain = info_gain(occ, T, K, 0.25, rays=(80, 60))
    lo = frustum_count(occ, T, K, 0.25, r, x_max=0.10)
    hi = frustum_count(occ, T, K, 0.25, -r, x_max=0.11)
    assert lo <= gain <= hi
    # camera in known free space 1 cm in front of a wall
    occ.state[:] = VoxelState.UNKNOWN
    i0 = occ.world_to_voxel(np.array([[0.0, 0.0, 0.5]]))[0, 0]
    occ.state[: i0 + 1] = VoxelState.FREE
    occ.state[i0 + 1] = VoxelState.OCCUPIED
    T_wall = look_at([0.0001, 0.0, 0.5], [1.0, 0.0, 0.5])
    assert info_gain(occ, T_wall, K, 1.0) == 0
    assert info_gain(occ, T_wall, K, 1.0, rays=(160, 120)) == 0


def test_batch_equals_single_and_is_deterministic():
    occ = unknown_map()
    occ.set_box([0.1, -0.3, 0.2], [0.12, 0.3, 0.8], VoxelState.OCCUPIED)
    occ.set_box([-0.05, -0.3, 0.2], [0.05, 0.3, 0.8], VoxelState.FREE)
    rng = np.random.default_rng(3)
    eyes = rng.uniform([-0.2, -0.1, 0.3], [0.08, 0.1, 0.7], (23, 3))  # some outside the grid
    targets = rng.uniform([0.2, -0.2, 0.3], [0.3, 0.2, 0.7], (23, 3))
    poses = np.stack([look_at(e, t) for e, t in zip(eyes, targets)])
    batch = info_gain_batch(occ, poses, K, 0.4)
    single = [info_gain(occ, T, K, 0.4) for T in poses]
    assert batch.tolist() == single
    assert info_gain_batch(occ, poses, K, 0.4).tolist() == single
    assert batch.min() >= 0 and batch.max() > 0


def test_ray_directions_and_bad_input():
    d = camera_ray_directions(K, rays=(4, 3))
    assert d.shape == (12, 3) and np.allclose(np.linalg.norm(d, axis=1), 1.0)
    # symmetric about the optical axis for a centred principal point
    assert np.allclose(d.mean(axis=0)[:2], 0.0)
    occ = unknown_map()
    poses = np.stack([np.eye(4), np.eye(4)])
    poses[1, 0, 0] = 2.0
    with pytest.raises(CompassInputError, match=r"T_world_cams\[1\]"):
        info_gain_batch(occ, poses, K, 1.0)
    with pytest.raises(CompassInputError, match="max_range"):
        info_gain(occ, np.eye(4), K, 0.0)
    with pytest.raises(CompassInputError, match="rays"):
        info_gain(occ, np.eye(4), K, 1.0, rays=(0, 3))
