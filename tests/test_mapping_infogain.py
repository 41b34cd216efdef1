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


# ----------------------------------------------------------------------- exact brute-force oracle
def _oracle_gain(state, k0, res, origin, dirs_world, max_range):
    """Distinct unknown voxels crossed by the rays, found without any DDA: the segment's
    crossings of every grid plane are sorted and the voxel of each piece's midpoint is taken.
    A ray stops at the first occupied voxel (not counted), where it leaves the grid, and
    before the voxel of its end point at max_range (OctoMap's convention)."""
    shape = np.array(state.shape)
    g0 = origin / res - k0
    seen = set()
    for d in dirs_world:
        g1 = (origin + max_range * d) / res - k0
        ts = [0.0, 1.0]
        for a in range(3):
            lo, hi = sorted((g0[a], g1[a]))
            planes = np.arange(np.floor(lo) + 1, np.ceil(hi))
            if g1[a] != g0[a]:
                ts.extend((planes - g0[a]) / (g1[a] - g0[a]))
        ts = np.unique(np.clip(ts, 0.0, 1.0))
        end = tuple(np.floor(g1).astype(int))
        for t0, t1 in zip(ts[:-1], ts[1:]):
            v = tuple(np.floor(g0 + 0.5 * (t0 + t1) * (g1 - g0)).astype(int))
            if v == end or not all(0 <= v[i] < shape[i] for i in range(3)) or state[v] == VoxelState.OCCUPIED:
                break
            if state[v] == VoxelState.UNKNOWN:
                seen.add(v)
    return len(seen)


def _random_small_map(seed):
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(1.2, 1.0, 0.8), resolution=0.1))
    rng = np.random.default_rng(seed)
    s = rng.choice([VoxelState.UNKNOWN, VoxelState.FREE, VoxelState.OCCUPIED], size=occ.shape, p=[0.6, 0.3, 0.1])
    for state in (VoxelState.FREE, VoxelState.OCCUPIED):
        occ.set_voxels(np.argwhere(s == state), state)
    return occ, rng


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gain_equals_a_brute_force_count_exactly(seed):
    """No tolerance: one voxel more or less per view fails (e.g. a DDA step too many)."""
    occ, rng = _random_small_map(seed)
    K_small = np.array([[8.0, 0.0, 5.5], [0.0, 8.0, 4.5], [0.0, 0.0, 1.0]])  # 12 x 10 px, wide view
    dirs_cam = camera_ray_directions(K_small, (7, 5))
    poses = []
    for _ in range(20):  # >= 16 views: the batch uses the view-grid kernel; single calls the stamp kernel
        eye = rng.uniform([0.15, 0.15, 0.15], [1.05, 0.85, 0.65])
        poses.append(look_at(eye, eye + rng.normal(size=3)))
    poses = np.array(poses)
    max_range = 0.73
    expected = []
    for T in poses:
        occ_eye = occ.state[tuple(occ.world_to_voxel(T[:3, 3])[0])]
        expected.append(_oracle_gain(occ.state, occ.grid_key_min, occ.resolution, T[:3, 3],
                                     dirs_cam @ T[:3, :3].T, max_range) if occ_eye != VoxelState.OCCUPIED else 0)
    expected = np.array(expected)
    assert expected.sum() > 200 and len(set(expected.tolist())) > 5  # a varied, non-trivial case
    singles = np.array([info_gain(occ, T, K_small, max_range, (7, 5)) for T in poses])
    np.testing.assert_array_equal(singles, expected)
    np.testing.assert_array_equal(info_gain_batch(occ, poses, K_small, max_range, (7, 5)), expected)
    np.testing.assert_array_equal(info_gain_batch(occ, poses[:5], K_small, max_range, (7, 5)), expected[:5])


def test_one_axis_ray_counts_the_voxels_before_its_end():
    """A single ray along +x from a voxel centre: exactly the voxels up to (not including)
    the one holding the end point, stopping before the first occupied voxel."""
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(2.0, 0.3, 0.3), resolution=0.1))
    K1 = np.array([[10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 1.0]])
    T = look_at([0.05, 0.15, 0.15], [1.0, 0.15, 0.15])
    assert info_gain(occ, T, K1, 0.5, (1, 1)) == 5  # voxels 0..4; the end point lies in voxel 5
    assert info_gain(occ, T, K1, 0.9, (1, 1)) == 9  # end point at x = 0.95 m: voxel 9
    assert info_gain(occ, T, K1, 0.95, (1, 1)) == 10  # end point on the boundary of voxel 10
    occ.set_voxels([[7, 1, 1]], VoxelState.OCCUPIED)
    occ.set_voxels([[2, 1, 1]], VoxelState.FREE)
    assert info_gain(occ, T, K1, 1.5, (1, 1)) == 6  # 0..6 without the free voxel 2
