"""Look before moving (trial/verify.py and its loop in trial/grasp_stage.py): the swept
unknown voxels on a constructed map, and the stage executes only a manoeuvre whose swept
voxels are seen free."""
from types import SimpleNamespace

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import RobotConfig
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.trial import grasp_stage
from compass_manip.trial.config import GraspTrialConfig
from compass_manip.trial.result import TrialFailure
from compass_manip.trial.verify import (LookOutcome, VerifyConfig, manoeuvre, swept_mask, swept_occupied, swept_unknown,
                                       transfer_path)

ROBOT = RobotConfig()
SPHERES = panda_sphere_model(ROBOT)
Q_HOME = np.asarray(ROBOT.q_home)
FAR_TARGET = SimpleNamespace(points=np.array([[5.0, 5.0, 5.0], [5.01, 5.0, 5.0]]), axes=np.eye(3), bottom_z=5.0)


def _map() -> OccupancyMap:
    return OccupancyMap(MapConfig(resolution=0.02))


def _path() -> np.ndarray:
    q1 = Q_HOME + np.array([0.6, 0.2, 0.0, 0.3, 0.0, 0.0, 0.0])
    return np.stack([Q_HOME, q1])


def test_a_voxel_on_the_path_is_flagged_while_unknown_and_not_once_seen_free():
    occ = _map()
    Q = _path()
    swept = swept_mask(occ, SPHERES, Q, 0.009)
    own = np.zeros(occ.shape, bool)
    flagged = swept_unknown(occ, SPHERES, Q, 0.009, own)
    assert len(flagged) == np.count_nonzero(swept) > 100  # all unknown: every swept voxel
    i, j, k = flagged[len(flagged) // 2]
    occ.state[i, j, k] = VoxelState.FREE  # that one voxel seen free
    again = {tuple(v) for v in swept_unknown(occ, SPHERES, Q, 0.009, own)}
    assert (i, j, k) not in again and len(again) == len(flagged) - 1
    own[tuple(flagged[:10].T)] = True  # the robot's own way is not unknown to it
    assert len(swept_unknown(occ, SPHERES, Q, 0.009, own)) == len(flagged) - 1 - 10
    occ.state[swept] = VoxelState.FREE
    assert len(swept_unknown(occ, SPHERES, Q, 0.009, own)) == 0
    # a voxel off the path is never flagged
    occ.state[:] = VoxelState.UNKNOWN
    occ.state[~swept] = VoxelState.FREE
    assert len(swept_unknown(occ, SPHERES, Q, 0.009, np.zeros(occ.shape, bool))) == np.count_nonzero(swept)


def test_the_swept_space_grows_with_the_path_and_the_inflation_and_sees_occupied_voxels():
    occ = _map()
    short = swept_mask(occ, SPHERES, _path()[:1], 0.0)
    assert np.count_nonzero(swept_mask(occ, SPHERES, _path(), 0.0)) > np.count_nonzero(short)
    assert np.count_nonzero(swept_mask(occ, SPHERES, _path()[:1], 0.03)) > np.count_nonzero(short)
    occ.state[:] = VoxelState.FREE
    assert swept_occupied(occ, SPHERES, _path(), FAR_TARGET, 0.055) == 0
    v = np.argwhere(short)[0]
    occ.state[tuple(v)] = VoxelState.OCCUPIED
    assert swept_occupied(occ, SPHERES, _path(), FAR_TARGET, 0.055) == 1
    with pytest.raises(CompassInputError, match="own has shape"):
        swept_unknown(occ, SPHERES, _path(), 0.0, np.zeros((2, 2, 2), bool))


def test_the_manoeuvre_is_transfer_approach_and_lift_densified():
    sel = SimpleNamespace(path=_path(), q_pregrasp=_path()[-1], q_grasp=_path()[-1] + 0.1, q_lift=_path()[-1] + 0.2)
    Q = manoeuvre(sel, 0.02)
    assert np.allclose(Q[0], Q_HOME) and np.allclose(Q[-1], sel.q_lift)
    assert np.max(np.abs(np.diff(Q, axis=0))) <= 0.02 + 1e-12
    assert np.allclose(manoeuvre(sel, 0.02, transfer=False)[0], sel.q_pregrasp)


def test_verify_config_rejects_bad_values():
    with pytest.raises(CompassInputError, match="max_views"):
        VerifyConfig(max_views=-1)
    with pytest.raises(CompassInputError, match="view_distance"):
        VerifyConfig(view_distance=(0.6, 0.3))
    with pytest.raises(CompassInputError, match="verify"):
        GraspTrialConfig(verify=3)
    import json

    from compass_manip.trial.config import TrialConfig
    d = TrialConfig(grasp=GraspTrialConfig(verify=VerifyConfig(max_views=12))).to_dict()
    assert json.loads(json.dumps(d)) == d and d["grasp"]["verify"]["max_views"] == 12
    assert TrialConfig().to_dict()["grasp"]["verify"] is None  # off by default


@pytest.fixture
def stage(monkeypatch):
    """run_grasp_stage with a fixed selection (home -> a pose beside it), the target far away,
    no strict transfer, and an executor that records whether it ran."""
    ran = []
    q1 = _path()[-1]
    sel = SimpleNamespace(failure=None, path=_path(), q_pregrasp=q1, q_grasp=q1, q_lift=q1, T_world_tcp=None,
                          time_s=0.0)
    monkeypatch.setattr(grasp_stage, "select_grasp", lambda *a, **k: sel)
    monkeypatch.setattr(grasp_stage, "build_target_model", lambda *a, **k: FAR_TARGET)
    monkeypatch.setattr(grasp_stage, "strict_transfer", lambda *a, **k: None)
    monkeypatch.setattr(grasp_stage, "execute_grasp",
                        lambda world, s, q, cfg: ran.append(q) or SimpleNamespace(failure=None, t=1.0, collisions=[]))
    occ = _map()
    world = SimpleNamespace(robot=ROBOT, q=Q_HOME.copy())
    det = SimpleNamespace(points_world=np.zeros((20, 3)) + 0.5, T_world_cam=np.eye(4))
    task = SimpleNamespace(target=None)

    def run(config, look, task=task, rules=None, method_swept=None):
        looker = lambda q, occ_, centres, way=None: SimpleNamespace(path=np.stack([q, q]), planned=True, gain=5,
                                                                     n_valid=1, plan_time_s=0.0)
        return grasp_stage.run_grasp_stage(world, occ, det, task, Q_HOME, [], config, np.random.default_rng(0), 0.1,
                                           looker=looker, look=look, method_rules=rules, method_swept=method_swept)
    return SimpleNamespace(run=run, occ=occ, ran=ran)


def test_the_stage_refuses_a_manoeuvre_through_unknown_space_when_the_budget_is_spent(stage):
    calls = []
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=0)),
                  lambda p, count=True: calls.append(p) or LookOutcome.MOVED)
    assert r.failure is TrialFailure.GRASP_UNVERIFIED and r.outcome is None and not stage.ran and not calls
    assert r.look_log[0]["unknown_grasp"] > 0
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=2)),
                  lambda p, count=True: LookOutcome.NONE)  # no view could be reached
    assert r.failure is TrialFailure.GRASP_UNVERIFIED and not stage.ran


def test_the_stage_executes_once_a_look_has_seen_the_swept_space_free(stage):
    calls = []

    def look(p, count=True):  # the view (counted) and the way back (not counted); the view sees all free
        calls.append(count)
        stage.occ.state[:] = VoxelState.FREE
        return LookOutcome.MOVED
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=3)), look)
    assert r.failure is None and len(stage.ran) == 1 and r.n_looks == 1 and calls == [True, False]
    assert r.duration_s == pytest.approx(0.1 + 0.1 + 1.0)  # the (strict) selection, the view's plan, the grasp


def _task(lo, hi):
    space = SimpleNamespace(interior_min=lo, interior_max=hi, wall_thickness=0.02, outward=(-1.0, 0.0, 0.0))
    return SimpleNamespace(target=None, space=space, floor_z=-0.5, robot_base_pos=(0.0, 0.0, 0.0))


def test_trusting_the_space_outside_the_confined_space_needs_no_look_there_only(stage):
    from compass_manip.exploration.world_model import WorldModelConfig
    config = GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=0, trust_outside_space=True))
    rules = WorldModelConfig(near_base_box=((-0.5, -0.5, 0.0), (0.5, 0.5, 1.0)))  # COMPASS's box: ignored here
    far = stage.run(config, lambda p, count=True: LookOutcome.NONE, _task((2.0, 2.0, 0.3), (2.5, 2.5, 0.8)), rules)
    assert far.failure is None and len(stage.ran) == 1  # the whole arm is outside the confined space
    around = stage.run(config, lambda p, count=True: LookOutcome.NONE, _task((-1.0, -1.0, 0.0), (1.0, 1.0, 1.2)), rules)
    assert around.failure is TrialFailure.GRASP_UNVERIFIED and len(stage.ran) == 1  # inside it: unknown is unknown
    off = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=0)),
                    lambda p, count=True: LookOutcome.NONE, _task((2.0, 2.0, 0.3), (2.5, 2.5, 0.8)), rules)
    assert off.failure is TrialFailure.GRASP_UNVERIFIED


def test_the_stage_needs_the_look_callbacks_with_verify():
    with pytest.raises(CompassInputError, match="verify"):
        grasp_stage.run_grasp_stage(SimpleNamespace(robot=ROBOT), _map(), SimpleNamespace(
            points_world=np.zeros((20, 3)), T_world_cam=np.eye(4)), None, Q_HOME, [],
            GraspTrialConfig(verify=VerifyConfig()), np.random.default_rng(0), 0.1)


@pytest.mark.slow
def test_same_seed_gives_an_identical_trial_with_look_before_moving():
    from dataclasses import replace

    from compass_manip.trial.config import TrialConfig
    from compass_manip.trial.inspect import InspectConfig
    from compass_manip.trial.runner import TrialSpec, run_trial
    config = TrialConfig(grasp=GraspTrialConfig(grasp_map=True, near_body_halo=0.08, inspect=InspectConfig(n_views=2),
                                                verify=VerifyConfig(max_views=2)))
    a = run_trial(TrialSpec("compass", 1, 0, 0, 101), config).to_dict()
    b = run_trial(TrialSpec("compass", 1, 0, 0, 101), replace(config)).to_dict()
    for k in ("wall_s", "planning_ms_median", "planning_ms_p90"):  # measured compute times, not the trial
        a.pop(k), b.pop(k)
    assert a == b and a["grasp_looks"] is not None  # GRASP was entered with the look loop


def _target_at_mid_path():
    """A small target model around the hand's sphere centres halfway along _path()."""
    q_mid = _path().mean(axis=0)
    c = SPHERES.sphere_centers(q_mid[None])[0][-3:]
    pts = np.vstack([c + d for d in 0.01 * np.eye(3)] + [c])
    return SimpleNamespace(points=pts, axes=np.eye(3), bottom_z=float(pts[:, 2].min()) - 0.1)


def test_the_transfer_is_checked_without_the_targets_carve():
    occ = _map()
    target = _target_at_mid_path()
    own = np.zeros(occ.shape, bool)
    sel = SimpleNamespace(path=_path(), q_pregrasp=_path()[-1])
    Q = transfer_path(sel, 0.02)
    assert np.allclose(Q[0], Q_HOME) and np.allclose(Q[-1], sel.q_pregrasp)
    assert np.max(np.abs(np.diff(Q, axis=0))) <= 0.02 + 1e-12
    all_unknown = len(swept_unknown(occ, SPHERES, Q, 0.009, own))
    carved = len(swept_unknown(occ, SPHERES, Q, 0.009, own, target, 0.055))
    assert carved < all_unknown  # the carve would have exempted voxels the transfer sweeps


def test_the_stage_looks_at_a_transfer_through_the_targets_unseen_surroundings(stage, monkeypatch):
    target = _target_at_mid_path()
    monkeypatch.setattr(grasp_stage, "build_target_model", lambda *a, **k: target)
    from compass_manip.grasp.carve import target_carve
    carve = target_carve(stage.occ, target, 0.055)
    stage.occ.state[~carve] = VoxelState.FREE  # everything seen free but the unseen space around the target
    calls = []
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=0)),
                  lambda p, count=True: calls.append(p) or LookOutcome.MOVED)
    assert r.failure is TrialFailure.GRASP_UNVERIFIED and not stage.ran
    assert r.look_log[0]["unknown_grasp"] == 0 and r.look_log[0]["unknown_all"] > 0
    stage.occ.state[:] = VoxelState.FREE  # seen: the transfer may go
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=0)),
                  lambda p, count=True: LookOutcome.NONE)
    assert r.failure is None and len(stage.ran) == 1


def test_a_look_that_sees_none_of_its_voxels_sends_the_stage_back_to_choose_without_them(stage, monkeypatch):
    selections = []
    orig = grasp_stage.select_grasp
    monkeypatch.setattr(grasp_stage, "select_grasp", lambda *a, **k: selections.append(k["extra_safe"].copy())
                        or orig(*a, **k))
    calls = []
    config = GraspTrialConfig(near_body_free=True, verify=VerifyConfig(max_views=5, max_rounds=2, strict_first=False))
    r = stage.run(config,
                  lambda p, count=True: calls.append(count) or LookOutcome.MOVED)  # moves, sees nothing
    assert r.failure is TrialFailure.GRASP_UNVERIFIED and not stage.ran
    assert r.n_looks == 2 and calls == [True, False, True, False]  # one look per choice, not five in a row
    unseen = [e for e in r.look_log if "unseen" in e]
    assert len(unseen) == 2 and unseen[0]["round"] == 0 and unseen[0]["unseen"] == r.look_log[0]["unknown_grasp"]
    # the second choice no longer takes the voxels the look missed as free (near-body space assumed before)
    assert len(selections) == 2 and np.count_nonzero(selections[1]) < np.count_nonzero(selections[0])


def test_the_methods_swept_space_is_the_robots_own_but_not_where_it_was_seen_occupied(stage, monkeypatch):
    everywhere = lambda: np.ones(stage.occ.shape, bool)  # the method claims the whole grid as its way
    config = GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=0))
    r = stage.run(config, lambda p, count=True: LookOutcome.NONE, method_swept=everywhere)
    assert r.failure is None and len(stage.ran) == 1  # nothing unknown to look at
    from dataclasses import replace
    off = stage.run(replace(config, method_swept=False), lambda p, count=True: LookOutcome.NONE,
                    method_swept=everywhere)
    assert off.failure is TrialFailure.GRASP_UNVERIFIED and len(stage.ran) == 1
    safe = []
    orig = grasp_stage.select_grasp
    monkeypatch.setattr(grasp_stage, "select_grasp", lambda *a, **k: safe.append(k["extra_safe"].copy())
                        or orig(*a, **k))
    stage.occ.state[3, 4, 5] = VoxelState.OCCUPIED  # seen occupied: never the robot's own
    stage.run(config, lambda p, count=True: LookOutcome.NONE, method_swept=everywhere)
    assert not safe[0][3, 4, 5] and np.count_nonzero(~safe[0]) == 1


def test_a_best_effort_look_sees_only_the_assumed_space_and_never_refuses_for_the_unseen(stage):
    calls = []
    best = VerifyConfig(max_views=2, assumed_only=True, refuse=False, strict_first=False)
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=best), lambda p, count=True: calls.append(p))
    assert r.failure is None and len(stage.ran) == 1 and not calls  # nothing taken as free by assumption: no look
    r = stage.run(GraspTrialConfig(near_body_free=True, verify=best),
                  lambda p, count=True: calls.append(count) or LookOutcome.NONE)  # no view can be reached
    assert r.failure is None and len(stage.ran) == 2 and calls == [True]  # looked once, executed as chosen
    # the transfer's assumed voxels are aimed at with the approach's and lift's, not after them
    assert r.look_log[0]["unknown_all"] > r.look_log[0]["unknown_grasp"] > 0
    strict = VerifyConfig(max_views=2, assumed_only=True, strict_first=False)
    r = stage.run(GraspTrialConfig(near_body_free=True, verify=strict), lambda p, count=True: LookOutcome.NONE)
    assert r.failure is TrialFailure.GRASP_UNVERIFIED and len(stage.ran) == 2  # refused (the old rule)
    r = stage.run(GraspTrialConfig(near_body_free=True, verify=best),
                  lambda p, count=True: LookOutcome.MOVED)  # looks that see nothing: executed after the first
    assert r.failure is None and len(stage.ran) == 3 and r.n_looks == 1 and "unseen" in r.look_log[-1]


def test_a_best_effort_look_that_shows_a_blocker_chooses_again_and_never_executes_it(stage, monkeypatch):
    selections = []
    orig = grasp_stage.select_grasp
    monkeypatch.setattr(grasp_stage, "select_grasp", lambda *a, **k: selections.append(1) or orig(*a, **k))
    best = VerifyConfig(max_views=4, max_rounds=3, assumed_only=True, refuse=False, strict_first=False)
    aimed = []

    def look(p, count=True):  # the look sees the voxels it aimed at occupied, the rest free
        if count:
            stage.occ.state[stage.occ.state == VoxelState.UNKNOWN] = VoxelState.FREE
            stage.occ.state[tuple(aimed[-1].T)] = VoxelState.OCCUPIED
        return LookOutcome.MOVED
    looker_calls = []

    def run():
        world = SimpleNamespace(robot=ROBOT, q=Q_HOME.copy())
        det = SimpleNamespace(points_world=np.zeros((20, 3)) + 0.5, T_world_cam=np.eye(4))

        def looker(q, occ_, centres, way=None):
            aimed.append(occ_.world_to_voxel(centres))
            looker_calls.append(1)
            return SimpleNamespace(path=np.stack([q, q]), planned=True, gain=5, n_valid=1, plan_time_s=0.0)
        return grasp_stage.run_grasp_stage(world, stage.occ, det, SimpleNamespace(target=None), Q_HOME, [],
                                           GraspTrialConfig(near_body_free=True, verify=best),
                                           np.random.default_rng(0), 0.1, looker=looker, look=look)
    r = run()
    # the look showed a blocker: chosen again on the new map (the selection is trusted with it), then executed
    assert len(looker_calls) == 1 and len(selections) == 2 and len(stage.ran) == 1
    assert [e["round"] for e in r.look_log] == [0, 0, 1] and r.look_log[1]["occupied"] > 0


def test_outward_look_directions_add_views_from_the_base_side():
    from compass_manip.trial.verify import look_axis
    tb = np.array([0.0, 0.5, 0.1])
    plain = [look_axis(k, tb, False) for k in range(6)]
    out = [look_axis(k, tb, True) for k in range(6)]
    assert not any(np.allclose(a, -tb) for a in plain) and sum(np.allclose(a, tb) for a in plain) == 3
    assert sum(np.allclose(a, -tb) for a in out) == 2 and sum(np.allclose(a, tb) for a in out) == 2
    assert sum(np.allclose(a, [0.0, 0.0, -1.0]) for a in out) == 2


def test_a_look_that_shows_the_transfer_blocked_sends_the_stage_to_choose_again(stage, monkeypatch):
    selections = []
    orig = grasp_stage.select_grasp
    monkeypatch.setattr(grasp_stage, "select_grasp", lambda *a, **k: selections.append(1) or orig(*a, **k))
    occ = stage.occ
    Qt = transfer_path(SimpleNamespace(path=_path(), q_pregrasp=_path()[-1]), 0.02)
    inside = swept_mask(occ, SPHERES, Qt, 0.0) & ~swept_mask(occ, SPHERES, _path()[-1:], 0.03)  # transfer only
    occ.state[:] = VoxelState.FREE
    occ.state[inside] = VoxelState.UNKNOWN

    def look(p, count=True):  # the look sees the transfer's unknown voxels occupied
        if count:
            occ.state[inside] = VoxelState.OCCUPIED
        return LookOutcome.MOVED
    r = stage.run(GraspTrialConfig(near_body_free=False, verify=VerifyConfig(max_views=3, strict_first=False)), look)
    assert r.look_log[0]["unknown_grasp"] == 0 and r.look_log[0]["unknown_all"] > 0
    assert r.look_log[1]["occupied"] > 0 and len(selections) == 2  # blocked: chosen again on the new map
