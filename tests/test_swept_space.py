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
