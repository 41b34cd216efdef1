"""The planner's deterministic edge-check budget: the same call gives the same result
whatever the clock or the machine's load does; a too-small budget is a named failure; the
wall clock is an explicit option."""
import dataclasses
import threading

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import make_T
from compass_manip.motion import planner as planner_module
from compass_manip.motion.planner import DEFAULT_MAX_CHECKS, PlanFailure, PlannerConfig, plan
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.motion.validity import ValidityChecker
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model

Q_LEFT = Q_HOME.copy()
Q_LEFT[0] = 1.0
Q_RIGHT = Q_HOME.copy()
Q_RIGHT[0] = -1.0


@pytest.fixture(scope="module")
def wall():
    """A wall across the TCP's straight joint-1 sweep from Q_LEFT to Q_RIGHT: a tree search is needed."""
    c = PandaKinematics().T_world_tcp(0.5 * (Q_LEFT + Q_RIGHT))[:3, 3]
    boxes = [(make_T(t=[c[0], 0.0, c[2]]), np.array([0.12, 0.02, 0.25])),
             (make_T(t=[0.0, 0.0, -0.05]), np.array([2.0, 2.0, 0.05]))]
    v = ValidityChecker(panda_sphere_model(), obstacles=PrimitiveSet.from_lists(boxes=boxes))
    assert not v.edge_valid(Q_LEFT, Q_RIGHT, 0.005)
    return v


def _slow_clock(monkeypatch, factor=1000.0):
    """time.perf_counter as the planner sees it runs `factor` times fast (a machine that
    is `factor` times slower, as far as any wall-clock budget can tell)."""
    real = planner_module.time.perf_counter
    start = real()

    class _Time:
        @staticmethod
        def perf_counter():
            return start + factor * (real() - start)

    monkeypatch.setattr(planner_module, "time", _Time)


def test_default_budget_is_checks_not_time():
    c = PlannerConfig()
    assert c.max_checks == DEFAULT_MAX_CHECKS and c.time_budget is None
    t = PlannerConfig(time_budget=2.0)  # the explicit wall-clock option alone, as the MBM benchmark uses it
    assert t.max_checks is None and t.time_budget == 2.0
    both = PlannerConfig(max_checks=10, time_budget=2.0)
    assert both.max_checks == 10 and both.time_budget == 2.0
    for bad in (0, -3, 2.5, True):
        with pytest.raises(CompassInputError):
            PlannerConfig(max_checks=bad)


def test_same_call_same_result_under_a_slow_clock_and_load(wall, monkeypatch):
    cfg = PlannerConfig(seed=3)
    idle = plan(Q_LEFT, Q_RIGHT, wall, cfg, np.random.default_rng(7))
    assert idle.success and len(idle.path) >= 3  # found by the tree search
    stop = threading.Event()
    busy = threading.Thread(target=lambda: [None for _ in iter(stop.is_set, True)], daemon=True)
    busy.start()  # competes for the interpreter and a core
    try:
        _slow_clock(monkeypatch)
        loaded = plan(Q_LEFT, Q_RIGHT, wall, cfg, np.random.default_rng(7))
        # the old rule, a wall-clock budget, fails on the same call on that "machine"
        timed = plan(Q_LEFT, Q_RIGHT, wall, PlannerConfig(time_budget=0.5, seed=3), np.random.default_rng(7))
    finally:
        stop.set()
        busy.join()
    assert loaded.success and loaded.failure is None and loaded.goal_index == idle.goal_index
    np.testing.assert_array_equal(loaded.path, idle.path)
    assert loaded.n_checks == idle.n_checks
    assert timed.failure is PlanFailure.TIMEOUT


def test_a_clock_cap_does_not_change_the_search(wall):
    """With a generous wall-clock cap added the search runs in clock-checked chunks: same path."""
    cfg = PlannerConfig(seed=5)
    a = plan(Q_LEFT, Q_RIGHT, wall, cfg, np.random.default_rng(1))
    b = plan(Q_LEFT, Q_RIGHT, wall, dataclasses.replace(cfg, time_budget=60.0), np.random.default_rng(1))
    assert a.success and b.success
    np.testing.assert_array_equal(a.path, b.path)
    assert a.n_checks == b.n_checks


def test_too_small_budget_is_the_named_failure(wall):
    r = plan(Q_LEFT, Q_RIGHT, wall, PlannerConfig(max_checks=1), np.random.default_rng(0))
    assert not r.success and r.failure is PlanFailure.CHECK_BUDGET and r.path is None and r.goal_index == -1
    # the cap is kept to within one RRT-Connect iteration (one extension and one connection)
    small = plan(Q_LEFT, Q_RIGHT, wall, PlannerConfig(max_checks=20), np.random.default_rng(0))
    assert small.failure is PlanFailure.CHECK_BUDGET and small.n_checks <= 20 + 65 + 3  # + start, goal and straight-line checks


def test_ompl_stops_on_the_check_budget(wall):
    pytest.importorskip("ompl")
    r = plan(Q_LEFT, Q_RIGHT, wall, PlannerConfig(max_checks=5, backend="ompl"))
    assert r.failure is PlanFailure.CHECK_BUDGET
    ok = plan(Q_LEFT, Q_RIGHT, wall, PlannerConfig(backend="ompl"))
    assert ok.success


def test_method_and_grasp_sides_use_the_deterministic_budget():
    """No wall clock in any method-side or grasp-side planner default (issue 9: same seed, same trial)."""
    from compass_manip.exploration.baseline_common import ViewPlanningConfig
    from compass_manip.grasp.select import GraspSelectConfig
    from compass_manip.trial.grasp_scan import TrialScanConfig
    from compass_manip.trial.inspect import InspectConfig
    from compass_manip.trial.verify import VerifyConfig

    for cfg, checks in ((GraspSelectConfig().planner, 2 * DEFAULT_MAX_CHECKS), (InspectConfig().planner, DEFAULT_MAX_CHECKS),
                        (VerifyConfig().planner, DEFAULT_MAX_CHECKS), (ViewPlanningConfig().planner, 2 * DEFAULT_MAX_CHECKS),
                        (TrialScanConfig().planner, 2 * DEFAULT_MAX_CHECKS)):
        assert cfg.time_budget is None and cfg.max_checks == checks


def test_the_selection_spends_its_failed_plans_on_fewer_longer_searches():
    """Branch gmod: 2 x the default checks a call, 3 failed calls a field: the same 120,000 checks
    at most as 6 calls of 20,000 (a narrow way out of the cabinet needed 21-32k in one search)."""
    from compass_manip.grasp.select import SELECT_MAX_CHECKS, GraspSelectConfig

    cfg = GraspSelectConfig()
    assert cfg.planner.max_checks == SELECT_MAX_CHECKS == 2 * DEFAULT_MAX_CHECKS
    assert cfg.max_failed_plans == 3
    assert cfg.planner.max_checks * cfg.max_failed_plans == 6 * DEFAULT_MAX_CHECKS
