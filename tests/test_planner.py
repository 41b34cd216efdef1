"""Motion planner: valid paths, typed failures, determinism, bad input."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import make_T
from compass_manip.motion.planner import PlanFailure, PlannerConfig, PlanResult, plan
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.motion.validity import ValidityChecker
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.robot.spheres import panda_sphere_model

FINE = 0.005  # [rad] re-check resolution, 8x finer than the planner's default search step

Q_LEFT = Q_HOME.copy()
Q_LEFT[0] = 1.0
Q_RIGHT = Q_HOME.copy()
Q_RIGHT[0] = -1.0


@pytest.fixture(scope="module")
def spheres():
    return panda_sphere_model()


def _tcp(q):
    return PandaKinematics().T_world_tcp(q)[:3, 3]


def _wall_checker(spheres) -> ValidityChecker:
    """A wall in the x-z plane across the TCP's straight joint-1 sweep from Q_LEFT to Q_RIGHT."""
    q_mid = 0.5 * (Q_LEFT + Q_RIGHT)
    c = _tcp(q_mid)
    wall = (make_T(t=[c[0], 0.0, c[2]]), np.array([0.12, 0.02, 0.25]))
    floor = (make_T(t=[0.0, 0.0, -0.05]), np.array([2.0, 2.0, 0.05]))
    return ValidityChecker(spheres, obstacles=PrimitiveSet.from_lists(boxes=[wall, floor]))


def _assert_valid_path(result: PlanResult, validity, q_start, q_goal):
    assert result.success and result.failure is None
    P = result.path
    assert P.ndim == 2 and P.shape[1] == 7 and len(P) >= 2
    np.testing.assert_array_equal(P[0], q_start)
    np.testing.assert_array_equal(P[-1], q_goal)
    assert np.all(P >= Q_MIN) and np.all(P <= Q_MAX)
    for a, b in zip(P[:-1], P[1:]):
        assert validity.edge_valid(a, b, FINE)
        # and the same by dense states checked one by one
        n = int(np.ceil(np.max(np.abs(b - a)) / FINE))
        Q = a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)
        assert np.all(validity.are_valid(Q))


def test_wall_blocks_straight_line_and_planner_goes_around(spheres):
    v = _wall_checker(spheres)
    assert v.is_valid(Q_LEFT) and v.is_valid(Q_RIGHT)
    assert not v.edge_valid(Q_LEFT, Q_RIGHT, FINE)  # the test needs a detour
    r = plan(Q_LEFT, Q_RIGHT, v, PlannerConfig(time_budget=5.0), np.random.default_rng(0))
    _assert_valid_path(r, v, Q_LEFT, Q_RIGHT)
    assert len(r.path) >= 3 and r.goal_index == 0 and r.n_checks > 3 and r.plan_time_s > 0


def test_free_space_gives_the_straight_line(spheres):
    v = ValidityChecker(spheres)
    r = plan(Q_LEFT, Q_RIGHT, v, PlannerConfig(), np.random.default_rng(0))
    assert r.success and len(r.path) == 2


def test_same_seed_same_path(spheres):
    v = _wall_checker(spheres)
    cfg = PlannerConfig(time_budget=5.0, seed=3)
    a = plan(Q_LEFT, Q_RIGHT, v, cfg)
    b = plan(Q_LEFT, Q_RIGHT, v, cfg)
    assert a.success and b.success and len(a.path) >= 3  # found by the tree search
    np.testing.assert_array_equal(a.path, b.path)
    c = plan(Q_LEFT, Q_RIGHT, v, cfg, np.random.default_rng(3))
    d = plan(Q_LEFT, Q_RIGHT, v, cfg, np.random.default_rng(3))
    np.testing.assert_array_equal(c.path, d.path)


def _box_at_tcp(q, half=0.05):
    return (make_T(t=_tcp(q)), np.array([half, half, half]))


def test_goal_inside_obstacle_is_a_typed_failure(spheres):
    v = ValidityChecker(spheres, obstacles=PrimitiveSet.from_lists(boxes=[_box_at_tcp(Q_RIGHT)]))
    assert v.is_valid(Q_LEFT) and not v.is_valid(Q_RIGHT)
    r = plan(Q_LEFT, Q_RIGHT, v)
    assert not r.success and r.failure is PlanFailure.GOAL_INVALID and r.path is None and r.goal_index == -1


def test_start_inside_obstacle_is_a_typed_failure(spheres):
    v = ValidityChecker(spheres, obstacles=PrimitiveSet.from_lists(spheres=[(_tcp(Q_LEFT), 0.05)]))
    r = plan(Q_LEFT, Q_RIGHT, v)
    assert not r.success and r.failure is PlanFailure.START_INVALID and r.path is None


def test_any_of_several_goals(spheres):
    blocked = Q_RIGHT.copy()
    blocked[1] += 0.3
    v = ValidityChecker(spheres, obstacles=PrimitiveSet.from_lists(boxes=[_box_at_tcp(blocked)]))
    assert not v.is_valid(blocked) and v.is_valid(Q_RIGHT)
    r = plan(Q_LEFT, np.stack([blocked, Q_RIGHT]), v, PlannerConfig(time_budget=5.0), np.random.default_rng(1))
    assert r.success and r.goal_index == 1
    _assert_valid_path(r, v, Q_LEFT, Q_RIGHT)


def test_time_budget_exhausted_is_timeout(spheres):
    v = _wall_checker(spheres)
    r = plan(Q_LEFT, Q_RIGHT, v, PlannerConfig(time_budget=1e-6))
    assert not r.success and r.failure is PlanFailure.TIMEOUT and r.path is None


def test_ompl_backend_gives_a_valid_path(spheres):
    v = _wall_checker(spheres)
    r = plan(Q_LEFT, Q_RIGHT, v, PlannerConfig(time_budget=10.0, backend="ompl"))
    _assert_valid_path(r, v, Q_LEFT, Q_RIGHT)


@pytest.mark.parametrize(
    "q_start, q_goals",
    [
        (np.full(7, np.nan), Q_HOME),
        (Q_HOME, np.r_[Q_HOME[:3], 0.5, Q_HOME[4:]]),  # joint 4 above its upper limit
        (Q_HOME[:6], Q_HOME),
        (Q_HOME, np.zeros((0, 7))),
        (Q_HOME, np.zeros((2, 6))),
    ],
)
def test_bad_inputs_raise(spheres, q_start, q_goals):
    with pytest.raises(CompassInputError):
        plan(q_start, q_goals, ValidityChecker(spheres))


def test_bad_config_raises():
    with pytest.raises(CompassInputError):
        PlannerConfig(time_budget=0.0)
    with pytest.raises(CompassInputError):
        PlannerConfig(backend="vamp")
    with pytest.raises(CompassInputError):
        PlannerConfig(edge_resolution=float("nan"))


def test_coarse_search_is_repaired_to_the_fine_step(spheres, monkeypatch):
    # at 0.25 rad steps the TCP jumps ~0.15 m, so coarse edges tunnel through the 4 cm wall
    import compass_manip.motion.planner as planner

    steps = []
    inner = planner._plan_numba

    def spy(q_start, goals, args, config, res, rng, deadline):
        steps.append(res)
        return inner(q_start, goals, args, config, res, rng, deadline)

    monkeypatch.setattr(planner, "_plan_numba", spy)
    v = _wall_checker(spheres)
    cfg = PlannerConfig(time_budget=10.0, edge_resolution=0.25, verify_resolution=0.005)
    for seed in range(3):
        r = plan(Q_LEFT, Q_RIGHT, v, cfg, np.random.default_rng(seed))
        _assert_valid_path(r, v, Q_LEFT, Q_RIGHT)
    assert 0.25 in steps and 0.005 in steps  # some coarse path needed a fine-step repair


def test_every_returned_segment_was_checked_as_is(spheres):
    # without the fine re-check, each segment of a shortcut path must still be valid when
    # sampled from its own ends at the search step (shortcuts split segments at new states)
    v = _wall_checker(spheres)
    cfg = PlannerConfig(time_budget=10.0, edge_resolution=0.1, verify_resolution=0.0, simplify_rounds=50)
    for seed in range(30):  # before the fix seeds 0, 8 and 22 returned such a segment
        r = plan(Q_LEFT, Q_RIGHT, v, cfg, np.random.default_rng(seed))
        assert r.success
        assert all(v.edge_valid(a, b, 0.1) for a, b in zip(r.path[:-1], r.path[1:]))


Q_REACH = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.7, 0.785])  # arm stretched out: TCP 0.70 m from the base axis
Q_REACH_LEFT, Q_REACH_RIGHT = Q_REACH + [1.0, 0, 0, 0, 0, 0, 0], Q_REACH - [1.0, 0, 0, 0, 0, 0, 0]


def _thin_wall_between_samples(spheres) -> ValidityChecker:
    """A 2 cm radial plate at joint-1 angle 0.25 rad across the TCP's sweep from
    Q_REACH_LEFT to Q_REACH_RIGHT: a 0.5 rad edge check samples joint 1 at 1.0, 0.5, 0.0, ...
    (the TCP 17 cm apart) and steps over it."""
    from compass_manip.geometry import rot_z

    q_wall = Q_REACH.copy()
    q_wall[0] = 0.25
    wall = (make_T(rot_z(0.25), _tcp(q_wall)), np.array([0.1, 0.01, 0.1]))
    return ValidityChecker(spheres, obstacles=PrimitiveSet.from_lists(boxes=[wall]))


@pytest.mark.parametrize("backend", ["numba", "ompl"])
def test_final_recheck_catches_a_straight_line_that_tunnels(spheres, backend):
    """Fails if `plan` skips its final re-check at verify_resolution."""
    v = _thin_wall_between_samples(spheres)
    a, b = Q_REACH_LEFT, Q_REACH_RIGHT
    assert v.is_valid(a) and v.is_valid(b)
    assert v.edge_valid(a, b, 0.5)  # the search step steps over the wall ...
    assert not v.edge_valid(a, b, FINE)  # ... which the fine step finds
    cfg = PlannerConfig(time_budget=10.0, edge_resolution=0.5, verify_resolution=FINE, backend=backend)
    r = plan(a, b, v, cfg, np.random.default_rng(0))
    _assert_valid_path(r, v, a, b)
    assert len(r.path) > 2
