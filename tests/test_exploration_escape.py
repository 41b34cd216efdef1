"""The NFA's reachable candidates and the escape motion, on a checker whose invalid set is
known in closed form (a ball in joint space, max-norm), so the expected answers are exact."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.exploration.escape import EscapeConfig, escape_path
from compass_manip.exploration.nfa import reachable_candidates
from compass_manip.robot.model import Q_HOME

from _ball_checker import BallChecker



def test_candidates_are_pulled_back_before_the_first_invalid_state_by_the_backoff():
    q0 = np.array(Q_HOME, float)
    wall = q0.copy()
    wall[4] += 0.605  # invalid where joint 5 is 0.505..0.705 rad past q0 (the others equal)
    checker = BallChecker(wall, 0.1)
    far, free, inside, tiny = q0.copy(), q0.copy(), q0.copy(), q0.copy()
    far[4] += 1.0  # crosses the ball: first invalid state at 0.51 rad (scan step 0.01)
    free[5] -= 0.8  # never near it: kept as it is
    inside[4] += 0.53  # ends inside the ball: the same first invalid state
    tiny[6] += 0.2  # valid but moves less than min_motion: dropped
    out = reachable_candidates(checker, q0, np.stack([far, free, inside, tiny]), 0.01, min_motion=0.3,
                               backoff=0.15)
    pulled = q0.copy()
    pulled[4] += 0.51 - 0.01 - 0.15
    np.testing.assert_allclose(out, np.stack([pulled, free, pulled]), atol=1e-12)
    for q in out:
        assert checker.first_invalid(q0, q, 0.001) is None
    # without backoff the candidate stops one scan step before the first invalid state
    out0 = reachable_candidates(checker, q0, far[None], 0.01, min_motion=0.0, backoff=0.0)
    assert out0[0, 4] - q0[4] == pytest.approx(0.50)


def test_escape_leaves_an_invalid_configuration_through_a_short_invalid_stretch():
    q = np.array(Q_HOME, float)
    centre = q.copy()
    centre[1] += 0.02  # q lies 0.02 rad inside a ball of radius 0.05: the way out is >= 0.03 rad
    checker = BallChecker(centre, 0.05)
    assert not checker.is_valid(q)
    config = EscapeConfig(samples=400, radius=0.25, tolerance=0.06)
    path = escape_path(checker, q, config, np.random.default_rng(0))
    assert path is not None and path.shape == (2, 7)
    np.testing.assert_array_equal(path[0], q)
    assert checker.is_valid(path[1])
    span = np.max(np.abs(path[1] - q))
    s = checker.first_invalid(path[1], q, 0.001)  # from the valid end back to q
    assert (1 - s) * span <= config.tolerance + 0.002
    # buried deeper than the tolerance allows: no escape
    deep = BallChecker(q, 0.2)
    assert escape_path(deep, q, config, np.random.default_rng(0)) is None


def test_escape_config_rejects_a_tolerance_beyond_the_radius():
    with pytest.raises(CompassInputError, match="tolerance 0.3"):
        EscapeConfig(radius=0.2, tolerance=0.3)


def test_the_obstacle_halo_equals_scipys_binary_dilation():
    from scipy import ndimage

    from compass_manip.exploration.world_model import manhattan_dilate

    rng = np.random.default_rng(7)
    for shape, p, r in (((9, 11, 7), 0.02, 3), ((12, 5, 10), 0.1, 1), ((6, 6, 6), 0.0, 2), ((8, 9, 10), 0.01, 4)):
        mask = rng.random(shape) < p
        mask[0, 0, 0] = p > 0  # a source on the border: the dilation must not wrap or leak
        np.testing.assert_array_equal(manhattan_dilate(mask, r), ndimage.binary_dilation(mask, iterations=r))
