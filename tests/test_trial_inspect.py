"""INSPECT between FOUND and GRASP: the corridor in front of the target, the frustum count,
views planned on the method's own checker (never through an invalid configuration) that
see the corridor, and the machine's INSPECT state (plans counted, the grasp still tried)."""
import numpy as np
import pytest

from _inspect_fixtures import empty_cabinet_world, machine_parts, observed_view

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.motion.timing import densify
from compass_manip.sim.grasp_only import oracle_detection
from compass_manip.trial.config import TrialConfig
from compass_manip.trial.grasp_stage import GraspStageResult
from compass_manip.trial.inspect import (InspectConfig, InspectPlan, corridor_unknown, frustum_counts,
                                         plan_inspect_view, plan_to_best, seen_counts)
from compass_manip.trial.machine import TrialMachine, TrialState

K = np.array([[300.0, 0.0, 160.0], [0.0, 300.0, 120.0], [0.0, 0.0, 1.0]])


def test_frustum_counts_points_in_front_inside_the_image_and_range():
    T = look_at(np.zeros(3), np.array([1.0, 0.0, 0.0]))[None]
    pts = np.array([[0.5, 0.0, 0.0], [0.5, 0.05, 0.02], [-0.5, 0.0, 0.0], [0.5, 2.0, 0.0], [1.5, 0.0, 0.0]])
    assert frustum_counts(T, K, pts, 0.9).tolist() == [2]  # behind, outside the image, beyond range: not counted
    assert frustum_counts(T, K, np.zeros((0, 3)), 0.9).tolist() == [0]


def test_seen_counts_drop_points_behind_a_seen_obstacle():
    occ = OccupancyMap(MapConfig())
    T = look_at(np.array([0.2, 0.0, 0.5]), np.array([0.7, 0.0, 0.5]))[None]
    pts = np.array([[0.7, 0.0, 0.5], [0.7, 0.03, 0.52], [0.6, -0.02, 0.48]])
    assert seen_counts(occ, T, K, pts, 0.9).tolist() == [3]  # unknown space in the way does not block
    v = occ.world_to_voxel(np.array([[0.65, 0.0, 0.5]]))[0]
    occ.state[v[0], v[1] - 6:v[1] + 7, v[2] - 6:v[2] + 7] = VoxelState.OCCUPIED  # a wall seen occupied at x = 0.65
    assert seen_counts(occ, T, K, pts, 0.9).tolist() == [1]  # only the point in front of it


def test_corridor_reaches_toward_the_opening_and_holds_only_unknown_voxels():
    occ = OccupancyMap(MapConfig())
    pts = np.array([[0.6, 0.0, 0.35], [0.62, 0.02, 0.42]])
    cfg = InspectConfig(corridor=0.2, side=0.05, above=0.1)
    c = corridor_unknown(occ, pts, np.array([-1.0, 0.0, 0.0]), cfg)  # the opening is at -x
    assert len(c) > 0 and c[:, 0].min() < 0.6 - 0.18 and c[:, 0].max() < 0.62 + 0.05 + 0.02
    assert c[:, 2].min() > 0.35 - 0.02 and c[:, 2].max() < 0.42 + 0.1 + 0.02
    occ.state[...] = VoxelState.FREE  # everywhere: nothing left to see
    assert len(corridor_unknown(occ, pts, np.array([-1.0, 0.0, 0.0]), cfg)) == 0


def test_inspect_config_rejects_bad_values():
    with pytest.raises(CompassInputError, match="n_views"):
        InspectConfig(n_views=-1)
    with pytest.raises(CompassInputError, match="sigma"):
        InspectConfig(sigma=5.0)


def test_inspect_view_is_valid_all_the_way_and_sees_the_corridor():
    world = empty_cabinet_world()
    try:
        rng = np.random.default_rng(0)
        task, wm, q_view, view = observed_view(world)
        pts = oracle_detection(world, view)
        outward = np.asarray(task.space.outward, float)
        cfg = InspectConfig()
        before = len(corridor_unknown(wm.occ, pts, outward, cfg))
        p = plan_inspect_view(wm.checker, wm.kin, wm.occ, world.camera.K, pts, outward, q_view, cfg, rng)
        assert p.path is not None and p.gain >= cfg.min_gain and p.n_valid > 0
        assert np.allclose(p.path[0], q_view)
        dense = densify(p.path, 0.005)
        assert all(wm.checker.is_valid(q) for q in dense)  # never through an invalid configuration
        assert not any(world.in_collision(q) for q in dense[::10])  # and free in truth
        wm.observe(world.render(p.path[-1], rgb=False, seg=False).observation())
        after = len(corridor_unknown(wm.occ, pts, outward, cfg))
    finally:
        world.close()
    assert after < before  # the new frame saw part of the corridor


def test_machine_inspects_between_found_and_grasp_and_counts_the_plans():
    calls, order = [], []
    world, method, buffer, metrics = machine_parts()

    def inspect(q, detection):
        calls.append(detection.points_world.shape)
        order.append("inspect")
        return InspectPlan(None, 0, 0, 0.3)

    def grasp(q, detection, moved, look=None):
        order.append("grasp")
        return GraspStageResult(None, 2.0, None, None, q, 0)

    m = TrialMachine(world, method, buffer, metrics, TrialConfig(), grasp=grasp, inspect=inspect, n_inspect=3)
    out = m.run()
    assert out.states == (TrialState.FOUND, TrialState.INSPECT, TrialState.GRASP, TrialState.DONE)
    assert order == ["inspect", "grasp"] and calls == [(20, 3)]  # an unplannable view ends INSPECT
    assert metrics.plans_attempted == 1 and metrics.plans_succeeded == 0 and out.n_inspected == 0
    assert out.t_end == pytest.approx(0.1 + 2.0)  # the fixed planning charge, then the grasp


def test_machine_charges_but_does_not_count_an_inspect_step_that_plans_nothing():
    world, method, buffer, metrics = machine_parts()
    calls = []

    def inspect(q, detection):  # e.g. a grasp hypothesis already needs no unknown voxel
        calls.append(q)
        return InspectPlan(None, 0, 0, 0.3, planned=False)

    def grasp(q, detection, moved, look=None):
        return GraspStageResult(None, 2.0, None, None, q, 0)

    out = TrialMachine(world, method, buffer, metrics, TrialConfig(), grasp=grasp, inspect=inspect, n_inspect=3).run()
    assert len(calls) == 1 and metrics.plans_attempted == 0 and metrics.plans_succeeded == 0
    assert out.t_end == pytest.approx(0.1 + 2.0) and out.n_inspected == 0


def test_plan_to_best_tries_the_next_group_of_views_when_the_best_has_no_path(monkeypatch):
    import compass_manip.trial.inspect as inspect_mod
    from types import SimpleNamespace
    Q = np.arange(9, dtype=np.float64)[:, None] * np.ones((1, 7)) * 0.01
    score = np.array([90.0, 80, 70, 60, 50, 40, 30, 20, 10])
    calls = []

    def fake_plan(q, goals, checker, config, rng):  # only the views scored 50 and 40 can be reached
        calls.append(np.round(goals[:, 0] * 100).astype(int).tolist())
        hit = [k for k, g in enumerate(goals) if round(g[0] * 100) in (4, 5)]
        return SimpleNamespace(success=bool(hit), path=np.stack([q, goals[hit[0]]]) if hit else None,
                               goal_index=hit[0] if hit else -1)

    monkeypatch.setattr(inspect_mod, "plan", fake_plan)
    q, rng = np.zeros(7), np.random.default_rng(0)
    one = plan_to_best(q, Q, score, 15.0, 2, None, None, rng, 0.0)  # the best group only: no path
    assert one.planned and one.path is None and one.n_calls == 1 and calls == [[0, 1]]
    calls.clear()
    p = plan_to_best(q, Q, score, 15.0, 2, None, None, rng, 0.0, n_groups=3)
    assert calls == [[0, 1], [2, 3], [4, 5]] and p.n_calls == 3  # the third group holds the reachable views
    assert np.allclose(p.path[-1], Q[4]) and p.gain == 50
    calls.clear()
    p = plan_to_best(q, Q, score, 15.0, 2, None, None, rng, 0.0, n_groups=2)  # bounded: 2 calls, then no path
    assert calls == [[0, 1], [2, 3]] and p.path is None and p.n_calls == 2
    calls.clear()
    p = plan_to_best(q, Q, score, 75.0, 2, None, None, rng, 0.0, n_groups=3)  # only views scoring >= min_score
    assert calls == [[0, 1]] and p.path is None


def test_inspect_config_rejects_bad_plan_groups():
    with pytest.raises(CompassInputError, match="plan_groups"):
        InspectConfig(plan_groups=0)
    with pytest.raises(CompassInputError, match="up_cone"):
        InspectConfig(up_cone=3.0)


def test_the_trials_inspect_escapes_and_tries_three_view_groups_without_looking_up():
    """The trial's INSPECT (branch sevt): the escape from a start its checker refuses and up to 3
    view groups a step, as the grasp-only harness; the looks up stay the harness's only."""
    from compass_manip.trial.config import GraspTrialConfig
    c = GraspTrialConfig().inspect
    assert c.escape and c.plan_groups == 3
    assert c.n_up == 0 and c.n_views == 20 and c.near_first == 0.0
