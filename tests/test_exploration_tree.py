"""MUE-RRT tree and NFA scan on a real first view: every node valid and reachable along its
path, NFA candidates hold the body joints, decisions return validated paths."""
import numpy as np
import pytest

from compass_manip.exploration.base import Phase
from compass_manip.exploration.compass import CompassConfig, CompassMethod, task_priors
from compass_manip.exploration.mue_rrt import TreeConfig, grow_tree, score_tree, shortcut, UtilityWeights
from compass_manip.exploration.nfa import NFAConfig, nfa_step, safe_box_map, wrist_candidates
from compass_manip.exploration.registry import METHODS, available_methods, make_method
from compass_manip.errors import CompassInputError
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.robot.ik import PandaIK
from compass_manip.robot.model import RobotConfig
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World


@pytest.fixture(scope="module")
def setup():
    scene = certified_scene(1, 1, 0).scene
    world = World(scene)
    q0 = np.asarray(world.robot.q_home)
    frame = world.render(q0, seg=False)
    K = world.camera.K
    world.close()
    return scene, frame, q0, K


def _method(setup, config=None, seed=0):
    scene, frame, q0, K = setup
    m = CompassMethod(scene.task(), config or CompassConfig(), np.random.default_rng(seed), q0, K)
    m.observe(frame.observation())
    return m


def test_every_tree_node_is_valid_and_reachable_along_its_path(setup):
    m = _method(setup)
    w = m.world
    tree = grow_tree(w, PandaIK(w.kin), w.frontiers, m.priors, np.array([-1.0, 0, 0]),
                     TreeConfig(iterations=40), np.random.default_rng(1))
    assert tree.count > 5
    checker = w.checker
    assert np.all(checker.are_valid(tree.q))
    for k in range(tree.count):
        path = tree.path_to(k)
        assert np.allclose(path[0], w.q) and np.allclose(path[-1], tree.q[k])
        assert checker.path_valid(path, 0.005), k
    scored = score_tree(w, tree, m.K, None, m.priors, UtilityWeights(), TreeConfig())
    assert scored.U[0] == -np.inf and np.isfinite(scored.U).any()
    # the camera pose of each node is FK of its configuration
    np.testing.assert_allclose(scored.T_world_cam[3], w.kin.T_world_cam(tree.q[3]), atol=1e-9)


def test_shortcut_keeps_ends_and_only_valid_jumps():
    path = np.zeros((5, 7))
    path[:, 0] = [0, 1, 2, 3, 4]
    blocked = lambda a, b: abs(b[0] - a[0]) <= 2  # noqa: E731  jumps of at most 2 are valid
    out = shortcut(path, blocked)
    assert out[:, 0].tolist() == [0, 2, 4]


def test_nfa_holds_the_body_and_picks_the_best_valid_wrist_view(setup):
    rng = np.random.default_rng(3)
    _, _, q0, _ = setup
    Q = wrist_candidates(q0, 50, rng, wrist_range=1.0)
    assert np.all(Q[:, :4] == q0[:4]) and np.all(np.abs(Q[:, 4:] - q0[4:]) <= 1.0 + 1e-12)
    m = _method(setup)
    path, gain, att, ok, scratch = nfa_step(m.world, q0, np.zeros(3), NFAConfig(), m.K, np.random.default_rng(4))
    assert path is not None and gain >= NFAConfig().min_gain and ok == 1 and att >= 1
    assert np.all(path[:, :4] == q0[:4])
    assert m.world.checker.path_valid(path, 0.005)
    # the gain map keeps the unknown voxels of the safety box only
    occ = m.world.occ
    small = safe_box_map(occ, np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.1, 0.1]))
    i0 = occ.world_to_voxel(np.zeros((1, 3)))[0]
    i1 = occ.world_to_voxel(np.full((1, 3), 0.1))[0] + 1
    box = tuple(slice(a, b) for a, b in zip(i0, i1))
    assert np.array_equal(small.state[box], occ.state[box])
    outside = small.state.copy()
    outside[box] = VoxelState.FREE
    assert np.all(outside == VoxelState.FREE)


def test_decisions_start_with_the_nfa_and_return_valid_paths(setup):
    m = _method(setup)
    d = m.decide()
    assert d.phase is Phase.NFA and d.stop is None and d.plans_succeeded == 1
    assert m.world.checker.path_valid(d.path, 0.005)
    m2 = make_method("compass-no-nfa", setup[0].task(), CompassConfig(), np.random.default_rng(0), setup[2],
                     setup[3])
    m2.observe(setup[1].observation())
    d2 = m2.decide()
    assert d2.phase is Phase.EXPLORE and d2.path is not None
    assert m2.world.checker.path_valid(d2.path, 0.005)


def test_registry_lists_methods_and_ablations():
    assert {"compass", "compass-no-nfa", "compass-no-heuristic", "compass-no-momentum",
            "compass-no-manip"} <= set(available_methods())
    assert set(METHODS) == set(available_methods())
    with pytest.raises(CompassInputError, match="use one of compass, compass-no-nfa"):
        make_method("nope", None, CompassConfig(), np.random.default_rng(0), np.zeros(7), np.eye(3))


def test_task_priors_lie_inside_the_space(setup):
    task = setup[0].task()
    p = task_priors(task, 0.06)
    assert p.shape == (7, 3) and np.all(task.space.contains(p))


def test_tree_costs_equal_the_path_lengths(setup):
    from compass_manip.exploration.mue_rrt import tree_costs
    from compass_manip.exploration.utility import motion_cost

    m = _method(setup)
    w = m.world
    tree = grow_tree(w, PandaIK(w.kin), w.frontiers, m.priors, np.array([-1.0, 0, 0]),
                     TreeConfig(iterations=20), np.random.default_rng(5))
    np.testing.assert_allclose(tree_costs(tree.q, tree.parent[: tree.count]),
                               motion_cost([tree.path_to(k) for k in range(tree.count)]), atol=1e-12)


def test_compass_keeps_unknown_space_unsafe_inside_omega_safe_and_free_beyond_it(setup):
    from compass_manip.exploration.world_model import WorldModel

    m = _method(setup)
    w, task = m.world, setup[0].task()
    nfa = NFAConfig()
    lo, hi = (np.asarray(b) + np.asarray(task.robot_base_pos) for b in (nfa.safe_box_min, nfa.safe_box_max))
    c = w.occ.voxel_centers()
    inside = np.all((c >= lo) & (c <= hi), axis=-1)
    assert inside.any() and not w.assumed_free[inside].any()
    beyond = ~inside & (c[..., 2] > task.floor_z + 0.1) & (c[..., 1] > hi[1] + 0.1)
    assert beyond.any() and w.assumed_free[beyond].all()
    # the shared world model (the baselines') keeps the paper's rule: free outside the space
    shared = WorldModel(setup[2], CompassConfig().world, m.robot, task)
    assert shared.assumed_free[inside & (c[..., 0] < 0.2) & (c[..., 2] > 0.1)].all()
    assert _method(setup, CompassConfig(near_field_unsafe=False)).world.assumed_free[inside & (c[..., 0] < 0.2)].any()
    # the registry's compass-baseline-rule is COMPASS on the baselines' rule, map for map
    b = make_method("compass-baseline-rule", task, CompassConfig(), np.random.default_rng(0), setup[2], setup[3])
    assert b.name == "compass-baseline-rule"
    np.testing.assert_array_equal(b.world.assumed_free, shared.assumed_free)


def test_a_stuck_exploration_step_falls_back_to_a_near_field_step(setup, monkeypatch):
    from compass_manip.exploration.base import Decision, StopReason

    m = _method(setup)
    m.phase = Phase.EXPLORE
    stuck = Decision(None, StopReason.NO_REACHABLE_VIEW, Phase.EXPLORE, 2, 0, stats={"tree_nodes": 1})
    monkeypatch.setattr(m, "_explore", lambda: stuck)
    d = m.decide()
    assert d.stop is None and d.path is not None and d.stats["rescan_gain"] >= NFAConfig().min_gain
    assert d.plans_attempted >= 3 and d.plans_succeeded == 1
    assert np.allclose(d.path[0], m.world.q) and m.world.checker.path_valid(d.path, 0.005)
    off = _method(setup, CompassConfig(nfa=NFAConfig(enabled=False)))
    monkeypatch.setattr(off, "_explore", lambda: stuck)
    assert off.decide().stop is StopReason.NO_REACHABLE_VIEW


def test_with_no_view_and_no_near_field_gain_the_method_backtracks_along_its_last_path(setup, monkeypatch):
    from compass_manip.exploration import compass as compass_module
    from compass_manip.exploration.base import Decision, StopReason

    m = _method(setup)
    first = m.decide()  # an NFA step from the start
    m.executed(first.path)
    assert np.allclose(m.world.q, first.path[-1]) and len(m.history) == 1
    m.phase = Phase.EXPLORE
    monkeypatch.setattr(m, "_explore", lambda: Decision(None, StopReason.NO_REACHABLE_VIEW, Phase.EXPLORE))
    monkeypatch.setattr(compass_module, "nfa_step", lambda *a, **k: (None, 0, 0, 0, None))
    d = m.decide()
    assert d.stop is None and d.stats["backtrack"] == 1 and (d.plans_attempted, d.plans_succeeded) == (1, 1)
    np.testing.assert_allclose(d.path[0], first.path[-1])
    np.testing.assert_allclose(d.path[-1], first.path[0])
    m.executed(d.path)  # the way back is not itself a path to backtrack along
    assert m.history == [] and m.decide().stop is StopReason.NO_REACHABLE_VIEW


def test_backtracking_replays_the_last_path_when_the_map_now_rejects_it(setup, monkeypatch):
    from compass_manip.exploration import compass as compass_module
    from compass_manip.exploration.base import Decision, StopReason

    m = _method(setup)
    first = m.decide()
    m.executed(first.path)
    m.phase = Phase.EXPLORE
    monkeypatch.setattr(m, "_explore", lambda: Decision(None, StopReason.NO_REACHABLE_VIEW, Phase.EXPLORE))
    monkeypatch.setattr(compass_module, "nfa_step", lambda *a, **k: (None, 0, 0, 0, None))
    monkeypatch.setattr(compass_module, "validated_path", lambda *a, **k: None)  # the map check fails
    d = m.decide()
    assert d.stats["replay"] == 1 and (d.plans_attempted, d.plans_succeeded) == (1, 1)
    np.testing.assert_array_equal(d.path, first.path[::-1])


def test_start_shell_claims_only_the_body_margin_inside_the_confined_space(setup):
    """The shell around the start posture (start_free_margin) is safe outside the space's outer
    box; inside it (the box grown by its wall and one voxel) only start_body_margin is, so a
    face frame just in front of the fingers is never assumed free."""
    from compass_manip.exploration.world_model import WorldModel, WorldModelConfig, space_box_mask
    from compass_manip.mapping.distance import mark_robot

    task, q0 = setup[0].task(), setup[2]
    cfg = WorldModelConfig(start_free_margin=0.10, start_body_margin=0.05)
    wm = WorldModel(q0, cfg, None, task)
    box = space_box_mask(wm.occ, task, task.space.wall_thickness + wm.occ.resolution)
    for margin in (0.05, 0.10):
        m = np.zeros(wm.occ.shape, bool)
        mark_robot(m, wm.occ, wm.spheres, q0[None], margin)
        if margin == 0.05:
            body = m
        else:
            shell = m
    assert (shell & box & ~body).any()  # the home shell reaches into the box in this set-up
    assert not (wm.swept & box & ~body).any()
    assert wm.swept[shell & ~box].all() and wm.swept[body].all()
    assert wm.checker.is_valid(q0)


def test_without_the_near_field_scan_a_stuck_decision_still_backtracks(setup):
    """compass-no-nfa drops the near-field scan (at the start and as the rescan when stuck)
    but keeps backtracking along the last executed path."""
    from dataclasses import replace

    from compass_manip.exploration.base import Decision, StopReason

    config = CompassConfig()
    m = _method(setup, replace(config, nfa=replace(config.nfa, enabled=False)))
    assert m.phase is Phase.EXPLORE
    q0 = m.world.q.copy()
    d = m.decide()
    assert d.path is not None
    m.executed(d.path)
    stuck = Decision(None, StopReason.NO_REACHABLE_VIEW, Phase.EXPLORE, 0, 0)
    back = m._rescan(stuck)
    assert back.stop is None and back.stats.get("backtrack") == 1 and back.stats["rescan_gain"] == 0
    np.testing.assert_allclose(back.path[-1], q0)
    np.testing.assert_allclose(back.path, d.path[::-1])
    # nothing left to go back along: the stop stands
    m.executed(back.path)
    assert m._rescan(stuck).stop is StopReason.NO_REACHABLE_VIEW


def test_the_grasp_maps_start_shell_is_the_world_models_rule(setup):
    """Given the Task, the grasp map's own space at the start is `start_shell` on its own grid:
    the full shell outside the confined space's box, only the body margin inside it."""
    from types import SimpleNamespace

    from compass_manip.exploration.world_model import space_box_mask, start_shell
    from compass_manip.mapping.distance import mark_robot
    from compass_manip.trial.grasp_map import GraspMap

    scene, _, q0, _ = setup
    task = scene.task()
    world = SimpleNamespace(q=q0)
    gm, loose = GraspMap(RobotConfig(), task=task), GraspMap(RobotConfig())
    gm.start(world, None)
    loose.start(world, None)
    box = space_box_mask(gm.occ, task, task.space.wall_thickness + gm.occ.resolution)
    body = np.zeros(gm.occ.shape, bool)
    mark_robot(body, gm.occ, gm.spheres, q0[None], 0.05)
    np.testing.assert_array_equal(gm.swept_all, start_shell(gm.occ, gm.spheres, q0, 0.05, 0.10, task))
    assert (loose.swept_all & box & ~body).any() and not (gm.swept_all & box & ~body).any()
    assert gm.swept_all[loose.swept_all & ~box].all()
