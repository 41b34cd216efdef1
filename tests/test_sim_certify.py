"""Certification: every rejection branch on a constructed scene, the recorded path replays
without contact, the reference fixed-view check, determinism."""
from dataclasses import replace
import re

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.motion.timing import time_parameterize
from compass_manip.sim.certify import CertFailure, CertifyConfig, certified_scene, certify
from compass_manip.sim.executor import ExecutorConfig, execute
from compass_manip.sim.objects import build_object
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
from compass_manip.sim.world import World

#: a two-storey cabinet; the target can stands on the lower storey, below the start camera's view
CABINET = CabinetSpec((0.42, -0.3, 0.25), (0.78, 0.3, 0.85), frame=(0.03, 0.03, 0.03, 0.0), shelves=(0.55,))


def _scene(level=1, target=None, clutter=(), obstacles=(), index=0) -> SceneSpec:
    target = target or build_object("target", "can", "red", (0.03, 0.11), 0.15, 0.64, 0.0, 0.25, 0.0, "target")
    clutter = tuple(clutter) or (
        build_object("book1", "book", "red", (0.03, 0.15, 0.2), 0.4, 0.70, 0.2, 0.55, 0.0, "colour_distractor"),
        build_object("can2", "can", "blue", (0.03, 0.1), 0.3, 0.70, -0.2, 0.55, 0.0, "shape_distractor"),
    )
    return SceneSpec(level, index, (0, level, index, 0), CABINET, target, clutter, tuple(obstacles))


def _box(name, half, pos):
    return Primitive(name, "box", half, pos)


@pytest.fixture(scope="module")
def base():
    scene = _scene()
    return scene, certify(scene)


def test_constructed_scene_is_certified_with_its_measures(base):
    scene, c = base
    assert c.certified and c.failure is None, c.failure
    assert c.start_visibility < 0.05
    assert c.fv_solvable and c.best_fixed_view_visibility >= 0.3  # nothing hides it from outside
    assert c.best_view_visibility >= 0.3 and c.view_visibility_fraction > 0
    assert c.grasp_approach_deg is not None and 0.0 <= c.grasp_approach_deg <= 90.0
    world = World(scene)
    try:
        from compass_manip.robot.kinematics import PandaKinematics
        kin = PandaKinematics(world.robot)
        p_pre, p_grasp = (kin.T_world_tcp(np.array(c.path[k]))[:3, 3] for k in c.path_marks[1:3])
        view = world.visibility_from(kin.T_world_cam(np.array(c.path[c.path_marks[0]])), with_robot=False)
    finally:
        world.close()
    d = p_grasp - p_pre  # the yaw is the certified grasp's: its TCP moves that way from pre-grasp to grasp
    assert view >= 0.3  # the certified view, exactly
    assert abs(np.degrees(np.arctan2(d[1], d[0])) - c.grasp_yaw_deg) < 2.0 and abs(c.grasp_yaw_deg) <= 55.0
    assert c.lift_height >= 0.03
    assert c.n_colour_distractors == 1 and c.n_shape_distractors == 1 and c.n_objects == 3
    assert len(c.path) >= 4 and len(c.path_marks) == 4 and c.path_marks[-1] == len(c.path) - 1


def test_recorded_path_replays_without_contact(base):
    scene, c = base
    path = np.array(c.path)[: c.path_marks[2] + 1]  # home -> view -> pre-grasp -> grasp
    world = World(scene)
    try:
        run = execute(world, time_parameterize(path), ExecutorConfig(frame_rate=0.0, check_step=0.01),
                      finger_width=0.08)
        assert run.completed and not run.contacts
        assert np.allclose(run.q_end, path[-1])
    finally:
        world.close()


def test_start_visibility_threshold_just_above_and_below():
    # the target on the upper storey, in the start camera's view, partly behind a board
    t = build_object("target", "can", "red", (0.03, 0.11), 0.15, 0.64, 0.0, 0.55, 0.0, "target")
    board = build_object("board", "book", "blue", (0.02, 0.15, 0.085), 0.3, 0.55, 0.0, 0.55, 0.0, "occluder")
    scene = _scene(target=t, clutter=(board,))
    w = World(scene)
    v = w.target_visibility(w.robot.q_home)
    w.close()
    assert 0.05 < v < 0.5  # partly visible: a default certification must refuse it
    assert certify(scene).failure is CertFailure.TARGET_VISIBLE_AT_START
    assert certify(scene, CertifyConfig(max_start_visibility=v - 1e-3)).failure is CertFailure.TARGET_VISIBLE_AT_START
    above = certify(scene, CertifyConfig(max_start_visibility=v + 1e-3, physics=False))
    assert above.failure is not CertFailure.TARGET_VISIBLE_AT_START


def test_home_in_collision():
    scene = _scene(obstacles=[_box("base_block", (0.05, 0.05, 0.05), (0.3, 0.0, 0.63))], level=3)
    assert certify(scene).failure is CertFailure.HOME_IN_COLLISION


def test_no_grasp_when_the_target_is_too_wide():
    wide = build_object("target", "box", "red", (0.09, 0.09, 0.1), 0.2, 0.64, 0.0, 0.25, 0.0, "target")
    assert certify(_scene(target=wide)).failure is CertFailure.NO_GRASP


def test_no_view_when_no_pose_sees_enough():
    assert certify(_scene(), CertifyConfig(min_view_visibility=1.01)).failure is CertFailure.NO_VIEW_SEES_TARGET


def test_obstacles_that_remove_nothing_are_rejected_at_level_3():
    far = [_box("base_block", (0.05, 0.05, 0.05), (-0.8, -0.8, 0.05))]
    c = certify(_scene(level=3, obstacles=far))
    assert c.failure is CertFailure.OBSTACLES_TOO_WEAK
    assert c.views_removed_by_obstacles == 0.0 and c.grasps_removed_by_obstacles == 0.0


def test_a_target_too_heavy_to_lift_fails_in_physics():
    heavy = build_object("target", "can", "red", (0.03, 0.11), 15.0, 0.64, 0.0, 0.25, 0.0, "target")
    c = certify(_scene(target=heavy))
    assert c.failure is CertFailure.LIFT_FAILED
    assert c.grasp_approach_deg is not None


def test_no_path_when_the_planner_has_no_checks_left_and_the_budget_is_counted_not_timed():
    cfg = dict(physics=False, reject_fv_solvable_severe=False, reject_outside_visible_severe=False)
    c = certify(_scene(level=2), CertifyConfig(plan_checks=1, **cfg))
    assert c.failure is CertFailure.NO_PATH and c.plan_checks_max >= 1
    ok = certify(_scene(level=2), CertifyConfig(**cfg))
    assert ok.failure is None and 1 <= ok.plan_checks_max <= CertifyConfig().plan_checks


@pytest.mark.parametrize("bad", [0, -5, 2.5, True, 10**9])
def test_bad_plan_checks_are_refused_with_the_value(bad):
    with pytest.raises(CompassInputError, match=re.escape(repr(bad))):
        CertifyConfig(plan_checks=bad)


def test_outside_view_gate_flags_a_severe_scene_whose_target_stands_in_the_open():
    scene = _scene(level=2)  # a can in plain view of the opening, called severe
    c = certify(scene, CertifyConfig(physics=False, reject_fv_solvable_severe=False))
    assert c.failure is CertFailure.OUTSIDE_VIEW_SEES_TARGET and c.best_outside_view_visibility >= 0.3
    off = certify(scene, CertifyConfig(physics=False, reject_fv_solvable_severe=False,
                                       reject_outside_visible_severe=False))
    assert off.failure is not CertFailure.OUTSIDE_VIEW_SEES_TARGET  # measured, not gated
    assert off.best_outside_view_visibility == c.best_outside_view_visibility
    assert certify(_scene(level=1), CertifyConfig(physics=False)).best_outside_view_visibility is None  # severe only


def test_fixed_view_check_flags_an_easy_scene_and_passes_a_hidden_one(base):
    easy = base[1]
    assert easy.fv_solvable
    # the same target in a pocket: boards on all four sides, taller than the can, open at the top
    pocket = [_box(f"pocket{i}", h, p) for i, (h, p) in enumerate([
        ((0.005, 0.06, 0.08), (0.575, 0.0, 0.33)), ((0.005, 0.06, 0.08), (0.705, 0.0, 0.33)),
        ((0.06, 0.005, 0.08), (0.64, 0.065, 0.33)), ((0.06, 0.005, 0.08), (0.64, -0.065, 0.33))])]
    hidden = replace(_scene(level=2), cabinet=replace(CABINET, inner=tuple(pocket)))
    c = certify(hidden, CertifyConfig(reject_fv_solvable_severe=True))
    assert not c.fv_solvable and c.best_fixed_view_visibility < 0.3
    assert c.failure is not CertFailure.FIXED_VIEW_SEES_TARGET
    easy_severe = certify(_scene(level=2), CertifyConfig(reject_fv_solvable_severe=True))
    assert easy_severe.failure is CertFailure.FIXED_VIEW_SEES_TARGET


def test_certification_is_deterministic(base):
    scene, c = base
    again = certify(scene)
    assert again.failure is c.failure and again.path == c.path
    assert again.view_visibility_fraction == c.view_visibility_fraction
    assert again.free_config_fraction == c.free_config_fraction


def test_bad_arguments():
    with pytest.raises(CompassInputError, match="level 0"):
        certified_scene(0, 0)
    with pytest.raises(CompassInputError, match="index -1"):
        certified_scene(1, -1)
    with pytest.raises(CompassInputError, match="seed -3"):
        certified_scene(1, 0, -3)


def test_reference_set_holds_the_grid_and_every_fv_baseline_pose_outside_the_opening():
    from compass_manip.exploration.fixed_views import FixedViewsConfig, fixed_view_poses
    from compass_manip.sim.fixed_views import grid_views, reference_fixed_views

    task = _scene().task()
    ref = reference_fixed_views(task)
    fv = fixed_view_poses(task, FixedViewsConfig())
    assert len(ref) == 9 + len(fv) and len(fv) >= 9
    for T in list(grid_views(task.space)) + list(fv):  # the baseline's own views are all in the set
        assert any(np.allclose(T, R) for R in ref)
    x_opening = task.space.opening_min[0]
    assert all(R[0, 3] < x_opening - 0.1 for R in ref)  # every eye outside the opening plane


def test_coarse_view_visibility_is_refined_exactly_where_it_decides(base):
    scene, coarse = base  # the default: coarse rays (view_stride 3), refined near and above the threshold
    exact = certify(scene, CertifyConfig(view_stride=1))
    assert coarse.certified and exact.certified
    assert coarse.best_view_visibility == exact.best_view_visibility  # the best pose was refined
    assert coarse.view_visibility_fraction == exact.view_visibility_fraction
    assert coarse.path == exact.path  # the same good views, the same goals, the same plan
    # pose by pose: exact wherever the value can decide, within the margin elsewhere
    from compass_manip.sim import oracle
    from compass_manip.sim.view_search import search_views

    world = World(scene)
    try:
        ik, full = oracle.robot_ik(world.robot), oracle.ground_truth_checker(scene)
        cfg = CertifyConfig()
        v_c = search_views(world, cfg, np.random.default_rng(5), ik, full, None).vis
        v_e = search_views(world, CertifyConfig(view_stride=1), np.random.default_rng(5), ik, full, None).vis
    finally:
        world.close()
    near = np.abs(v_c - cfg.min_view_visibility) < cfg.view_refine_margin
    assert np.array_equal(v_c[near], v_e[near])  # refined: exact
    assert np.all(np.abs(v_c - v_e) < cfg.view_refine_margin)
    thr = cfg.min_view_visibility
    assert np.array_equal(v_c >= thr, v_e >= thr)  # every pose on the same side of the threshold
    assert (~near).sum() > len(v_c) // 2  # and most poses never needed the exact rays


def test_a_seed_whose_candidates_all_fail_gets_one_named_error_not_a_runtime_error():
    """Level 1 scene 4 of seed 0 rejects its first candidate (home clearance): with one attempt
    allowed the error names the level, index, seed and the rejections, and is a
    CompassInputError (one line in the CLI, a recorded failure in a sweep)."""
    from compass_manip.sim.certify import NoCertifiedScene

    with pytest.raises(NoCertifiedScene, match=r"level 1, index 4, seed 0 within 1 attempts \(1 candidates "
                                               r"rejected: HOME_CLEARANCE 1\); use another seed") as info:
        certified_scene(1, 4, 0, CertifyConfig(max_attempts=1), cache=False)
    assert isinstance(info.value, CompassInputError)
