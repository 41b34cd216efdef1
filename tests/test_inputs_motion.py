"""Property-based checks of the motion boundaries: configs, joint vectors, paths, the
planner, timing, the validity checker and the executor. Every call raises CompassInputError
or returns a well-formed result; nothing else may escape."""
import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from compass_manip.errors import CompassInputError
from compass_manip.motion.planner import PlannerConfig, plan
from compass_manip.motion.timing import TimingConfig, densify, joint_path_length, time_parameterize
from compass_manip.motion.validity import ValidityChecker, ValidityConfig
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.executor import ExecutorConfig, execute
from compass_manip.types import Trajectory

#: Scalars of every kind a caller might pass by mistake.
SCALARS = st.sampled_from([0, 1, -1, 0.0, 1e-12, 0.004, 0.5, 1.0, 5.0, 1e6, -1e-3, float("nan"), float("inf"),
                           -float("inf"), np.float32(0.01), np.int64(2), np.int64(-1), True, False, "1", None,
                           [1.0], np.array(1.0), 2**64])


def _accepts(call):
    """(accepted, result): CompassInputError means rejected; any other exception fails the test."""
    try:
        return True, call()
    except CompassInputError as exc:
        assert str(exc) and "\n" not in str(exc)
        return False, None


@given(field=st.sampled_from(["max_checks", "time_budget", "range", "edge_resolution", "verify_resolution", "simplify_rounds",
                              "seed", "backend", "simplify"]), value=SCALARS | st.text(max_size=5))
def test_planner_config_fields(field, value):
    ok, config = _accepts(lambda: PlannerConfig(**{field: value}))
    if ok:
        v = getattr(config, field)
        if field == "seed":
            assert isinstance(v, (int, np.integer)) and not isinstance(v, bool) and 0 <= v < 2**63
        elif field == "backend":
            assert v in ("numba", "ompl")
        elif field == "simplify":
            assert isinstance(v, (bool, np.bool_))
        elif field == "max_checks":  # None: the default check budget
            assert isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1
        elif field == "time_budget" and v is None:  # no clock: the default check budget
            assert config.max_checks >= 1
        else:
            assert math.isfinite(float(v)) and float(v) >= 0


def test_planner_config_seed_minus_one_is_refused():
    with pytest.raises(CompassInputError, match="seed = -1"):
        PlannerConfig(seed=-1)


@given(field=st.sampled_from(["velocity_scale", "acceleration_scale", "jerk_scale", "dt"]), value=SCALARS)
def test_timing_config_fields(field, value):
    ok, config = _accepts(lambda: TimingConfig(**{field: value}))
    if ok:
        assert 0 < float(getattr(config, field)) <= 1.0


@given(field=st.sampled_from(["frame_rate", "check_step", "stop_on_contact", "render_rgb"]), value=SCALARS)
def test_executor_config_fields(field, value):
    ok, config = _accepts(lambda: ExecutorConfig(**{field: value}))
    if ok and field in ("frame_rate", "check_step"):
        assert math.isfinite(float(getattr(config, field)))


@given(field=st.sampled_from(["margin", "self_margin", "edge_resolution"]), value=SCALARS)
def test_validity_config_fields(field, value):
    ok, config = _accepts(lambda: ValidityConfig(**{field: value}))
    if ok:
        assert math.isfinite(float(getattr(config, field)))


@st.composite
def joint_vectors(draw):
    """Joint vectors: fine, out of limits, NaN/inf, wrong length or dtype, degrees, text."""
    kind = draw(st.sampled_from(["ok", "limits", "nan", "inf", "short", "long", "text", "degrees", "matrix", "none"]))
    q = Q_MIN + draw(st.floats(0.05, 0.95)) * (Q_MAX - Q_MIN)
    j = draw(st.integers(0, 6))
    if kind == "limits":
        q[j] = Q_MAX[j] + draw(st.floats(0.01, 10.0))
    elif kind == "nan":
        q[j] = np.nan
    elif kind == "inf":
        q[j] = -np.inf
    elif kind == "short":
        q = q[:6]
    elif kind == "long":
        q = np.r_[q, 0.0]
    elif kind == "text":
        return kind, ["abc"] * 7
    elif kind == "degrees":
        q = np.degrees(q) + 200.0  # joint 4 alone cannot be in range in degrees
    elif kind == "matrix":
        q = np.tile(q, (2, 1))
    elif kind == "none":
        return kind, None
    return kind, q


@pytest.fixture(scope="module")
def checker():
    return ValidityChecker(panda_sphere_model())


@given(q=joint_vectors(), res=st.sampled_from([None, 0.01, np.float32(0.01), 0.0, -0.1, float("nan"), "x", 1.0]))
def test_validity_checker_inputs(checker, q, res):
    kind, q = q
    ok, valid = _accepts(lambda: checker.is_valid(q))
    assert ok == (kind == "ok")
    ok, edge = _accepts(lambda: checker.edge_valid(Q_HOME, q, res))
    res_ok = res is None or (not isinstance(res, str) and np.isfinite(res) and 1e-4 <= res <= 0.5)
    assert ok == (kind == "ok" and res_ok)
    if ok:
        assert isinstance(edge, bool)


@given(q_start=joint_vectors(), q_goal=joint_vectors())
def test_plan_inputs(checker, q_start, q_goal):
    (ks, qs), (kg, qg) = q_start, q_goal
    ok, r = _accepts(lambda: plan(qs, qg, checker, PlannerConfig(time_budget=0.5), np.random.default_rng(0)))
    goal_ok = kg == "ok" or (kg == "matrix")  # (k, 7) goals are several goals
    assert ok == (ks == "ok" and goal_ok)
    if ok:
        assert (r.failure is None) == r.success and (r.path is None) != r.success


def test_plan_refuses_a_bad_config_or_rng(checker):
    with pytest.raises(CompassInputError, match="PlannerConfig"):
        plan(Q_HOME, Q_HOME, checker, {"time_budget": 1.0})
    with pytest.raises(CompassInputError, match="Generator"):
        plan(Q_HOME, Q_HOME, checker, PlannerConfig(), rng=0)


@st.composite
def paths(draw):
    n = draw(st.integers(1, 4))
    P = Q_MIN + np.array(draw(st.lists(st.floats(0.05, 0.95), min_size=7 * n, max_size=7 * n))).reshape(n, 7) * (
        Q_MAX - Q_MIN)
    kind = draw(st.sampled_from(["ok", "ok", "huge", "nan", "shape", "empty", "text", "degrees"]))
    if kind == "huge":
        P[-1, 0] = 1e6
    elif kind == "nan":
        P[0, draw(st.integers(0, 6))] = np.nan
    elif kind == "shape":
        P = P[:, :6]
    elif kind == "empty":
        P = P[:0]
    elif kind == "text":
        return kind, [["a"] * 7]
    elif kind == "degrees":
        P = np.degrees(P) + 200.0
    return kind, P


@given(path=paths())
def test_time_parameterize_inputs(path):
    kind, P = path
    ok, traj = _accepts(lambda: time_parameterize(P))
    assert ok == (kind == "ok")
    if ok:
        assert np.all(np.isfinite(traj.t)) and np.all(np.diff(traj.t) > 0) and np.all(np.isfinite(traj.q))
        np.testing.assert_array_equal(traj.q[-1], P[-1])


def test_a_path_in_the_wrong_unit_is_refused_with_one_line():
    with pytest.raises(CompassInputError, match="outside joint"):
        time_parameterize(np.stack([Q_HOME, np.full(7, 1e6)]))
    with pytest.raises(CompassInputError, match="densify would create"):
        densify(np.stack([np.zeros(7), np.full(7, 1e6)]), 0.001)
    assert joint_path_length(np.stack([np.zeros(7), np.ones(7)])) == pytest.approx(math.sqrt(7))


@given(t0=SCALARS, width=st.sampled_from([None, 0.0, 0.04, 0.08, -1.0, float("nan"), 1.0, "0.04"]),
       traj_kind=st.sampled_from(["ok", "nan_t", "decreasing", "nan_q", "not a trajectory"]))
def test_execute_rejects_before_touching_the_world(t0, width, traj_kind):
    """Bad input is refused before the world is used: `world=None` would fail otherwise."""
    t = np.array([0.0, 1.0])
    q = np.stack([Q_HOME, Q_HOME])
    if traj_kind == "nan_t":
        t = np.array([0.0, np.nan])
    elif traj_kind == "decreasing":
        t = np.array([1.0, 0.0])
    elif traj_kind == "nan_q":
        q = q.copy()
        q[1, 2] = np.nan
    traj = "traj" if traj_kind == "not a trajectory" else Trajectory(t, q)
    t0_ok = (isinstance(t0, (int, float, np.floating, np.integer)) and not isinstance(t0, (bool, np.bool_))
             and math.isfinite(float(t0)) and not isinstance(t0, np.ndarray))
    width_ok = width is None or (not isinstance(width, str) and math.isfinite(width) and 0 <= width <= 0.08)
    if t0_ok and width_ok and traj_kind == "ok":
        return  # valid input: needs a world (tests/test_sim_executor.py)
    with pytest.raises(CompassInputError):
        execute(None, traj, ExecutorConfig(frame_rate=0.0), t0=t0, finger_width=width)


def test_kinematics_inputs():
    with pytest.raises(CompassInputError):
        PandaKinematics(finger_width=float("nan"))
    with pytest.raises(CompassInputError):
        PandaKinematics(finger_width="0.04")
    kin = PandaKinematics()
    with pytest.raises(CompassInputError):
        kin.T_world_tcp(["a"] * 7)
    with pytest.raises(CompassInputError):
        kin.T_world_tcp_batch([["a"] * 7])
    with pytest.raises(CompassInputError):
        kin.T_world_frame(Q_HOME, 3)
