"""IK round trips FK(IK(T)) = T for TCP and camera, look-at geometry, failures."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import make_T
from compass_manip.robot.ik import IKConfig, IKFailure, PandaIK, ik_camera, ik_look_at, ik_tcp
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN, RobotConfig


@pytest.fixture(scope="module")
def kin():
    return PandaKinematics()


def _errors(T_a, T_b):
    pe = np.linalg.norm(T_a[:3, 3] - T_b[:3, 3])
    c = np.clip((np.trace(T_a[:3, :3].T @ T_b[:3, :3]) - 1) / 2, -1, 1)
    return pe, np.arccos(c)


def test_fk_ik_round_trip_tcp(kin):
    rng = np.random.default_rng(10)
    n, ok = 100, 0
    for _ in range(n):
        q = rng.uniform(Q_MIN, Q_MAX)
        T = kin.T_world_tcp(q)
        r = ik_tcp(T, Q_HOME)
        if not r.success:
            continue
        good = True
        for s in r.solutions:
            assert np.all(s >= Q_MIN) and np.all(s <= Q_MAX)
            pe, re = _errors(kin.T_world_tcp(s), T)
            good &= pe < 1e-3 and re < 1e-3
        ok += good
    assert ok / n >= 0.95


def test_solutions_ordered_distinct_and_contain_source(kin):
    rng = np.random.default_rng(11)
    q = rng.uniform(Q_MIN + 0.2, Q_MAX - 0.2)
    r = ik_tcp(kin.T_world_tcp(q), q_ref=q, n_q7=32)
    d = np.linalg.norm(r.solutions - q, axis=1)
    assert np.all(np.diff(d) >= 0)
    assert d[0] < 1e-3  # the configuration that produced the pose is found first
    for i in range(len(r.solutions)):
        for j in range(i):
            assert np.max(np.abs(r.solutions[i] - r.solutions[j])) > 1e-3
    assert r.solutions.shape[0] > 4  # redundancy: several q7 branches
    assert r.T_world_targets.shape == (len(r.solutions), 4, 4)
    np.testing.assert_allclose(r.best, r.solutions[0])
    assert r.failure is None


def test_camera_ik_with_moved_base():
    cfg = RobotConfig(base_pos=(0.3, 0.1, 0.2), base_yaw=-1.0)
    kin = PandaKinematics(cfg)
    solver = PandaIK(kin)
    rng = np.random.default_rng(12)
    ok = 0
    for _ in range(30):
        q = rng.uniform(Q_MIN, Q_MAX)
        T = kin.T_world_cam(q)
        r = ik_camera(T, Q_HOME, ik=solver)
        if r.success:
            pe, re = _errors(kin.T_world_cam(r.best), T)
            ok += pe < 1e-3 and re < 1e-3
    assert ok >= 28


def test_look_at_points_camera_at_target(kin):
    p = np.array([0.5, 0.05, 0.15])
    r = ik_look_at(p, 0.3, Q_HOME, n_samples=8)
    assert r.success
    for s in r.solutions[:20]:
        C = kin.T_world_cam(s)
        v = p - C[:3, 3]
        assert np.linalg.norm(v) == pytest.approx(0.3, abs=1e-3)
        assert np.dot(v / np.linalg.norm(v), C[:3, 2]) > 1 - 1e-6  # optical axis (+z) on p
    r2 = ik_look_at(p, 0.3, Q_HOME, rng=np.random.default_rng(5), n_samples=4)
    r3 = ik_look_at(p, 0.3, Q_HOME, rng=np.random.default_rng(5), n_samples=4)
    np.testing.assert_array_equal(r2.solutions, r3.solutions)


def test_unreachable_and_bad_input():
    r = ik_tcp(make_T(t=[3.0, 0.0, 0.5]), Q_HOME)
    assert not r.success and r.solutions.shape == (0, 7) and r.best is None
    assert r.failure is IKFailure.NO_ANALYTIC_SOLUTION
    with pytest.raises(CompassInputError, match="rigid"):
        ik_tcp(np.eye(4) * 2, Q_HOME)
    with pytest.raises(CompassInputError, match="NaN"):
        ik_tcp(np.eye(4), np.full(7, np.nan))
    with pytest.raises(CompassInputError, match="distance"):
        ik_look_at(np.zeros(3), 5.0, Q_HOME)
    with pytest.raises(CompassInputError, match="n_q7"):
        IKConfig(n_q7=0)


def test_validity_filter_keeps_only_collision_free_solutions(kin):
    from compass_manip.motion.primitives import PrimitiveSet
    from compass_manip.motion.validity import ValidityChecker
    from compass_manip.robot.spheres import panda_sphere_model

    sm = panda_sphere_model()
    T = kin.T_world_tcp(Q_HOME)
    everything = ik_tcp(T, Q_HOME, n_q7=32)
    # a post above the base: removes the elbow-up solutions, keeps others
    elbow = kin.fk_links(everything.solutions[0])[kin.tree.index("panda_link4")][:3, 3]
    vc = ValidityChecker(sm, obstacles=PrimitiveSet.from_lists(spheres=[(elbow, 0.05)]))
    free = ik_tcp(T, Q_HOME, n_q7=32, validity=vc)
    assert 0 < len(free.solutions) < len(everything.solutions)
    assert np.all(vc.are_valid(free.solutions))
    blocked = ValidityChecker(sm, obstacles=PrimitiveSet.from_lists(spheres=[(T[:3, 3], 0.05)]))
    r = ik_tcp(T, Q_HOME, validity=blocked)
    assert not r.success and r.failure is IKFailure.IN_COLLISION
