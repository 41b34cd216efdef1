"""The swept space marks only the spheres not already marked (`world_model.fresh_spheres`):
the same mask as marking every sphere of every densified configuration."""
import numpy as np

from compass_manip.exploration.world_model import WorldModel, fresh_spheres, mark_configs
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
        mark_configs(ref, wm.occ, wm.spheres, densify(path, wm.config.sweep_step), m)
        np.testing.assert_array_equal(wm.swept, ref)
        q = path[-1]
    assert ref.sum() > 1000


def test_mark_in_spheres_equals_every_voxel_tested_and_keeps_what_was_set():
    from compass_manip.exploration.world_model import mark_spheres
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
        mark_spheres(ref, grid_min, res, c, r)
        mark_in_spheres(fast, grid_min, res, c, r)
        np.testing.assert_array_equal(fast, ref)
        assert ref.sum() > base.sum() + 100


def test_mark_robot_equals_mark_configs_on_a_1cm_grid():
    from compass_manip.mapping.distance import mark_robot
    from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
    occ = OccupancyMap(MapConfig())
    wm = WorldModel(np.asarray(RobotConfig().q_home, float))
    rng = np.random.default_rng(11)
    Q = np.clip(np.asarray(RobotConfig().q_home, float) + np.cumsum(rng.uniform(-0.1, 0.1, (40, 7)), axis=0),
                Q_MIN + 0.01, Q_MAX - 0.01)
    ref, fast = np.zeros(occ.shape, bool), np.zeros(occ.shape, bool)
    mark_configs(ref, occ, wm.spheres, Q, 0.05)
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
