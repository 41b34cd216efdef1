"""The swept space marks only the spheres not already marked (`world_model.fresh_spheres`):
the same mask as marking every sphere of every densified configuration; the fast sphere
rasteriser (`mapping.distance.mark_in_spheres`) against testing every voxel of each sphere's box."""
import numpy as np

from compass_manip.exploration.world_model import WorldModel, fresh_spheres
from compass_manip.mapping.distance import mark_robot
from compass_manip.motion.timing import densify
from compass_manip.robot.model import Q_MAX, Q_MIN, RobotConfig


def test_fresh_spheres_drops_repeats_of_the_configuration_before_and_of_the_last_marked():
    c = np.zeros((3, 2, 3))
    c[1, 1] = 1.0  # sphere 1 moves in the second configuration, sphere 0 never does
    c[2, 1] = 1.0
    np.testing.assert_array_equal(fresh_spheres(c, None), [[True, True], [False, True], [False, False]])
    np.testing.assert_array_equal(fresh_spheres(c, np.zeros((2, 3))), [[False, False], [False, True], [False, False]])
    prev = np.array([[0.0, 0.0, 1e-12], [0.0, 0.0, 0.0]])  # any change of a coordinate is fresh
    np.testing.assert_array_equal(fresh_spheres(c, prev)[0], [True, False])


def brute_force_mark(mask, grid_min, res, centres, radii):
    """Set the voxels of mask whose centres lie inside a sphere, testing every voxel of each
    sphere's box with the kernels' own expression (dx^2 + dy^2 + dz^2 <= r^2)."""
    n = np.array(mask.shape)
    for c, r in zip(np.asarray(centres, float).reshape(-1, 3), np.asarray(radii, float).reshape(-1)):
        lo = np.maximum(np.floor((c - r - grid_min) / res).astype(int), 0)
        hi = np.minimum(np.floor((c + r - grid_min) / res).astype(int), n - 1)
        if np.any(lo > hi):
            continue
        ax = [grid_min[a] + (np.arange(lo[a], hi[a] + 1) + 0.5) * res - c[a] for a in range(3)]
        d2 = ax[0][:, None, None] ** 2 + ax[1][None, :, None] ** 2 + ax[2][None, None, :] ** 2
        mask[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1, lo[2]:hi[2] + 1] |= d2 <= r * r


def robot_spheres(wm, Q, margin):
    """(centres (m*S, 3) [m], radii (m*S,) [m]) of the robot's spheres at Q (m, 7), grown by margin."""
    Q = np.asarray(Q, float).reshape(-1, 7)
    return wm.spheres.sphere_centers(Q).reshape(-1, 3), np.tile(wm.spheres.radii + margin, len(Q))


def test_swept_space_equals_every_sphere_marked():
    q0 = np.asarray(RobotConfig().q_home, float)
    wm = WorldModel(q0)
    ref = wm.swept.copy()
    rng = np.random.default_rng(7)
    q = q0
    for i, margin in enumerate((None, None, 0.03, 0.03, None)):
        step = rng.uniform(-0.08, 0.08, (3, 7))
        step[:, :2] = 0.0 if i == 1 else step[:, :2]  # base joints still: their links' spheres repeat
        path = np.vstack([q, np.clip(q + np.cumsum(step, axis=0), Q_MIN + 0.01, Q_MAX - 0.01)])
        wm.add_swept(path, margin)
        m = wm.config.swept_margin if margin is None else margin
        brute_force_mark(ref, wm.occ.grid_min, wm.occ.resolution, *robot_spheres(wm, densify(path, wm.config.sweep_step), m))
        np.testing.assert_array_equal(wm.swept, ref)
        q = path[-1]
    assert ref.sum() > 1000


def test_mark_in_spheres_equals_every_voxel_tested_and_keeps_what_was_set():
    from compass_manip.mapping.distance import mark_in_spheres
    rng = np.random.default_rng(3)
    grid_min, res = np.array([-0.3, -0.2, 0.1]), 0.01
    for trial in range(4):
        base = rng.random((50, 40, 30)) < 0.02  # voxels set before stay set
        c = rng.uniform([-0.35, -0.25, 0.05], [0.25, 0.25, 0.45], (300, 3))
        r = rng.uniform(0.0, 0.12, 300)
        r[:5] = 0.005 * np.arange(5)  # spheres smaller than a voxel, or of radius 0
        c[5:8] = grid_min + (np.array([[3, 4, 5], [10, 10, 10], [0, 0, 0]]) + 0.5) * res  # on voxel centres
        ref, fast = base.copy(), base.copy()
        brute_force_mark(ref, grid_min, res, c, r)
        mark_in_spheres(fast, grid_min, res, c, r)
        np.testing.assert_array_equal(fast, ref)
        assert ref.sum() > base.sum() + 100


def test_mark_robot_equals_every_voxel_tested_on_a_1cm_grid():
    from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
    occ = OccupancyMap(MapConfig())
    wm = WorldModel(np.asarray(RobotConfig().q_home, float))
    rng = np.random.default_rng(11)
    Q = np.clip(np.asarray(RobotConfig().q_home, float) + np.cumsum(rng.uniform(-0.1, 0.1, (40, 7)), axis=0),
                Q_MIN + 0.01, Q_MAX - 0.01)
    ref, fast = np.zeros(occ.shape, bool), np.zeros(occ.shape, bool)
    brute_force_mark(ref, occ.grid_min, occ.resolution, *robot_spheres(wm, Q, 0.05))
    mark_robot(fast, occ, wm.spheres, Q, 0.05)
    np.testing.assert_array_equal(fast, ref)
    assert ref.sum() > 10000


def test_union_order_puts_large_spheres_first_drops_repeats_and_marks_the_same_union():
    from compass_manip.mapping.distance import mark_in_spheres, union_order
    rng = np.random.default_rng(5)
    c = rng.uniform(-0.2, 0.2, (60, 3))
    r = rng.uniform(0.0, 0.1, 60)
    c, r = np.vstack([c, c[:20]]), np.r_[r, r[:20]]  # 20 exact repeats (a way's base spheres)
    c[70], r[70] = c[3], r[3] + 0.01  # same centre, another radius: not a repeat
    k = union_order(c, r)
    assert len(k) == 61 and len(np.unique(k)) == 61 and np.all(np.diff(r[k]) <= 0)
    assert 70 in k and set(range(60)) <= set(k.tolist())  # the first of each repeat is kept
    fast = np.zeros((40, 40, 40), bool)
    mark_in_spheres(fast, np.full(3, -0.2), 0.01, c, r)
    p = np.full(3, -0.2) + (np.stack(np.meshgrid(*[np.arange(40)] * 3, indexing="ij"), -1) + 0.5) * 0.01
    ref = np.zeros(fast.shape, bool)
    for cc, rr in zip(c, r):  # every voxel centre against every sphere, the kernel's own expression
        d = p - cc
        ref |= d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2] <= rr * rr
    np.testing.assert_array_equal(fast, ref)
    assert len(union_order(np.zeros((0, 3)), np.zeros(0))) == 0


def test_way_order_drops_only_repeats_of_the_configuration_before_and_marks_the_same_union():
    from compass_manip.mapping.distance import _mark_ordered, way_order
    rng = np.random.default_rng(8)
    M, S = 12, 9
    C = rng.uniform(-0.15, 0.15, (M, S, 3))
    C[:, :3] = C[0, :3]  # three spheres that never move (the base)
    C[5:8, 4] = C[4, 4]  # one that rests for three configurations
    C[9, 5] = C[2, 5]  # a repeat of a configuration further back: kept (the union is the same)
    r = rng.uniform(0.0, 0.08, S)
    r[7] = r[8]  # a tie
    k = way_order(C, r)
    flat_r = np.tile(r, M)
    assert len(np.unique(k)) == len(k) == M * S - 3 * (M - 1) - 3
    assert np.all(np.diff(flat_r[k]) <= 0)  # largest first
    assert not ({S + s for s in range(3)} & set(k.tolist())) and {0, 1, 2} <= set(k.tolist())
    fast, ref = np.zeros((36, 32, 30), bool), np.zeros((36, 32, 30), bool)
    gm = np.array([-0.18, -0.16, -0.15])
    _mark_ordered(fast, gm, 0.01, C.reshape(-1, 3)[k], flat_r[k])
    brute_force_mark(ref, gm, 0.01, C.reshape(-1, 3), flat_r)
    np.testing.assert_array_equal(fast, ref)
    assert ref.sum() > 1000
