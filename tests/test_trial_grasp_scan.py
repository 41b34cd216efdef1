"""The trial's grasp on the grasp map: GRASP checks the hand near the target on the grasp
map's frames integrated again at 5 mm (the harness's fine local map), and the near-field scan
before INSPECT plans views valid for the method's checker that see unknown space around the
body, then hands over to INSPECT."""
from types import SimpleNamespace

import numpy as np
import pytest

from _ball_checker import BallChecker
from _inspect_fixtures import empty_cabinet_world, observed_view

from compass_manip.errors import CompassInputError
from compass_manip.grasp.select import GraspFailure, GraspSelection
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.motion.timing import densify
from compass_manip.sim.grasp_only import oracle_detection
from compass_manip.trial import grasp_stage
from compass_manip.trial.config import GraspTrialConfig
from compass_manip.trial.grasp_map import GraspMap
from compass_manip.trial.grasp_scan import NearFieldScanner, TrialScanConfig
from compass_manip.trial.inspect import InspectPlan
from compass_manip.trial.result import TrialFailure


def _fed_grasp_map(world, q_view, n=6):
    """A GraspMap fed the frames of the straight way from home to q_view."""
    gm = GraspMap(world.robot)
    q_home = np.asarray(world.robot.q_home)
    for s in np.linspace(0.0, 1.0, n):
        gm.frame(world.render(q_home + (q_view - q_home) * s, rgb=False, seg=False), None)
    return gm


def _unknown_in_box(occ, lo, hi):
    a = np.clip(occ.world_to_voxel(np.asarray(lo)[None])[0], 0, np.asarray(occ.shape))
    b = np.clip(occ.world_to_voxel(np.asarray(hi)[None])[0] + 1, 0, np.asarray(occ.shape))
    return int(np.count_nonzero(occ.state[a[0]:b[0], a[1]:b[1], a[2]:b[2]] == VoxelState.UNKNOWN))


def test_grasp_stage_checks_the_hand_on_the_fine_map_of_the_grasp_maps_frames(monkeypatch):
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        gm = _fed_grasp_map(world, q_view)
        det = SimpleNamespace(points_world=oracle_detection(world, view), T_world_cam=view.T_world_cam)
        seen = []

        def fake_select(target, occ, task_, q, spheres, config, rng, extra_safe=None, fine_map=None, q_via=None,
                        proposer=None, ik_sweeps=None):
            seen.append((occ, fine_map, q_via))
            return GraspSelection(None, 0.0, 0.0, None, None, None, None, float("nan"), False, 0.0, np.zeros(3), 0,
                                  {}, 0.25, 0.0, GraspFailure.NO_APPROACH_PATH)

        monkeypatch.setattr(grasp_stage, "select_grasp", fake_select)
        rng = np.random.default_rng(0)
        r = grasp_stage.run_grasp_stage(world, gm.occ, det, task, q_view, [], GraspTrialConfig(grasp_map=True,
                                        near_body_free=False), rng, 0.1, grasp_map=gm)
        grasp_stage.run_grasp_stage(world, gm.occ, det, task, q_view, [], GraspTrialConfig(
            grasp_map=True, near_body_free=False, fine_map=False, plan_via_home=True), rng, 0.1, grasp_map=gm)
        q_home = np.asarray(world.robot.q_home)
    finally:
        world.close()
    assert r.failure is TrialFailure.GRASP_NO_PATH
    (occ, fine, via0), (_, none, via1) = seen
    assert occ is gm.occ and none is None
    assert via0 is None and np.allclose(via1, q_home)  # plan_via_home hands the home posture to the selection
    assert fine.resolution == pytest.approx(occ.resolution / 2)
    pts = det.points_world
    assert np.all(fine.grid_min <= pts.min(0) - 0.2 + 1e-9) and np.all(fine.grid_max >= pts.max(0) + 0.2 - 1e-9)
    # the target's surface is occupied in the fine map: most points fall in or next to an occupied 5 mm cell
    idx = fine.world_to_voxel(pts)
    occupied = fine.state == VoxelState.OCCUPIED
    near = [occupied[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2, max(k - 1, 0):k + 2].any() for i, j, k in idx]
    assert np.mean(near) > 0.9
    assert len(gm.frames) == 6 and all(f.rgb is None for f in gm.frames)


def test_grasp_map_fine_map_needs_kept_frames():
    world = empty_cabinet_world()
    try:
        gm = GraspMap(world.robot, keep_frames=False)
        gm.frame(world.render(np.asarray(world.robot.q_home), rgb=False, seg=False), None)
        with pytest.raises(CompassInputError, match="keep_frames"):
            gm.fine_map(np.array([0.5, -0.1, 0.3]), np.array([0.7, 0.1, 0.5]))
    finally:
        world.close()
    assert gm.frames == []


def test_scan_view_is_valid_all_the_way_and_sees_unknown_space_near_the_body():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        gm = _fed_grasp_map(world, q_view)
        cfg = TrialScanConfig(max_views=2)
        handed = []
        s = NearFieldScanner(lambda: gm.occ, wm, world.camera.K, (world.camera.width, world.camera.height),
                             world.robot.q_home, world.robot.base_pos, cfg, np.random.default_rng(0),
                             then=lambda q, d: handed.append(q) or InspectPlan(None, 0, 0, 0.0, planned=False))
        base = np.asarray(world.robot.base_pos)
        lo, hi = base + cfg.candidates.box_min, base + cfg.candidates.box_max
        before = _unknown_in_box(gm.occ, lo, hi)
        p = s(q_view, None)
        assert p.path is not None and p.gain >= cfg.min_gain and np.allclose(p.path[0], q_view)
        dense = densify(p.path, 0.005)
        assert all(wm.checker.is_valid(q) for q in dense)  # planned on the method's checker
        assert not any(world.in_collision(q) for q in dense[::10])  # and free in truth here
        gm.frame(world.render(p.path[-1], rgb=False, seg=False), None)
        after = _unknown_in_box(gm.occ, lo, hi)
        s.views, s.stopped = cfg.max_views, None  # the budget is spent: INSPECT takes over
        out = s(p.path[-1], None)
    finally:
        world.close()
    assert after < before - cfg.min_gain // 2
    assert out.planned is False and len(handed) == 1 and s.stopped == "max_views"


def test_scan_ends_when_nothing_near_the_body_is_unknown():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        gm = _fed_grasp_map(world, q_view, n=2)
        gm.occ.state[...] = VoxelState.FREE  # everything seen
        handed = []
        s = NearFieldScanner(lambda: gm.occ, wm, world.camera.K, (world.camera.width, world.camera.height),
                             world.robot.q_home, world.robot.base_pos, TrialScanConfig(), np.random.default_rng(1),
                             then=lambda q, d: handed.append(q) or InspectPlan(None, 0, 0, 0.0, planned=False))
        out = s(q_view, None)
    finally:
        world.close()
    assert out.planned is False and len(handed) == 1 and s.views == 0 and s.stopped.startswith("best gain 0")


def test_scan_and_fine_map_configs_reject_bad_values():
    with pytest.raises(CompassInputError, match="max_views"):
        TrialScanConfig(max_views=21)
    with pytest.raises(CompassInputError, match="min_gain"):
        TrialScanConfig(min_gain=-1)
    with pytest.raises(CompassInputError, match="fine_margin"):
        GraspTrialConfig(fine_margin=0.0)
    with pytest.raises(CompassInputError, match="rng"):
        NearFieldScanner(lambda: None, None, np.eye(3), (320, 240), np.zeros(7), np.zeros(3), TrialScanConfig(), None)



def test_plan_via_goes_through_the_via_posture_and_fails_when_it_cannot_reach_it():
    from compass_manip.grasp.select import _plan_via
    from compass_manip.motion.planner import PlannerConfig
    from compass_manip.robot.model import Q_HOME

    q0 = np.array(Q_HOME, float)
    via, goal = q0.copy(), q0.copy()
    via[0] += 0.6
    goal[0] -= 0.6
    cfg = PlannerConfig(time_budget=0.5)
    res, path = _plan_via(q0, via, goal[None], BallChecker(q0 + 5.0, 0.1), cfg, np.random.default_rng(0))
    assert res.success and res.goal_index == 0 and res.plan_time_s > 0
    assert np.allclose(path[0], q0) and np.allclose(path[-1], goal)
    assert np.min(np.max(np.abs(path - via), axis=1)) < 1e-9  # the joined path passes the via posture
    blocked = BallChecker(via, 0.05)  # the via posture itself is invalid
    res, path = _plan_via(q0, via, goal[None], blocked, cfg, np.random.default_rng(0))
    assert not res.success and path is None


def test_scan_candidates_next_to_the_way_stay_near_it_and_within_the_limits():
    from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN

    way = np.stack([np.array(Q_HOME, float) + np.r_[d, np.zeros(6)] for d in (0.0, 0.3, -0.3)])
    cfg = TrialScanConfig(way_candidates=3000, way_sigma=0.05, wrist_sigma=0.4)
    s = NearFieldScanner(lambda: None, None, np.eye(3), (320, 240), np.array(Q_HOME, float), np.zeros(3), cfg,
                         np.random.default_rng(0), way_of=lambda: way)
    Q = s.near_way(way[0])
    assert Q.shape == (3000, 7) and np.all(Q >= Q_MIN) and np.all(Q <= Q_MAX)
    d = np.min(np.abs(Q[:, None, :4] - way[None, :, :4]).max(axis=2), axis=1)  # to the nearest way config
    assert np.percentile(d, 95) < 0.2  # joints 1-4 within a few way_sigma of a way configuration
    spread = np.std(Q[:, 4:] - way[np.argmin(np.abs(Q[:, None, :4] - way[None, :, :4]).max(axis=2), axis=1), 4:])
    assert 0.25 < spread < 0.45  # the wrist moves by about wrist_sigma (clipped at the limits)
    assert NearFieldScanner(lambda: None, None, np.eye(3), (320, 240), np.zeros(7), np.zeros(3),
                            TrialScanConfig(way_candidates=0), np.random.default_rng(0)).near_way(way[0]).shape == (0, 7)


def test_grasp_map_keeps_the_way_the_arm_moved():
    from compass_manip.robot.model import Q_HOME, RobotConfig

    gm = GraspMap(RobotConfig(), keep_frames=False)
    q0 = np.array(Q_HOME, float)
    gm.start(SimpleNamespace(q=q0), None)
    q1 = q0.copy()
    q1[0] += 0.5
    gm.motion(SimpleNamespace(q=np.stack([q0, q1])), 0.0, 1.0)
    W = gm.way
    assert np.allclose(W[0], q0) and np.allclose(W[-1], q1) and len(W) >= 1 + 0.5 / gm.sweep_step
    assert np.all(np.diff(W[1:, 0]) <= gm.sweep_step + 1e-9)  # sampled every sweep_step
    assert gm.swept.any()


def test_near_body_halo_keeps_the_assumption_away_from_seen_obstacles(monkeypatch):
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        gm = _fed_grasp_map(world, q_view, n=3)
        det = SimpleNamespace(points_world=oracle_detection(world, view), T_world_cam=view.T_world_cam)
        seen = []

        def fake_select(target, occ, task_, q, spheres, config, rng, extra_safe=None, fine_map=None, q_via=None,
                        proposer=None, ik_sweeps=None):
            seen.append(np.array(extra_safe))
            return GraspSelection(None, 0.0, 0.0, None, None, None, None, float("nan"), False, 0.0, np.zeros(3), 0,
                                  {}, 0.25, 0.0, GraspFailure.NO_APPROACH_PATH)

        monkeypatch.setattr(grasp_stage, "select_grasp", fake_select)
        for halo in (0.0, 0.08):
            grasp_stage.run_grasp_stage(world, gm.occ, det, task, q_view, [], GraspTrialConfig(
                near_body_halo=halo), np.random.default_rng(0), 0.1)
    finally:
        world.close()
    plain, halo = seen
    assert np.all(halo <= plain) and halo.sum() < plain.sum()  # only removes
    occupied = gm.occ.state == VoxelState.OCCUPIED
    near = np.zeros_like(occupied)  # voxels within one voxel of something seen occupied
    for ax in range(3):
        for d in (-1, 1):
            near |= np.roll(occupied, d, axis=ax)
    assert plain[near & ~occupied].any() and not halo[near & ~occupied].any()
    with pytest.raises(CompassInputError, match="near_body_halo"):
        GraspTrialConfig(near_body_halo=-0.1)


def test_grasp_map_integrates_its_frames_when_read_the_same_map_as_on_arrival():
    """Frames and motions wait until the map or the swept space is read (a trial that never
    reaches GRASP pays nothing for the 1 cm map); the map then equals integrating each frame
    as it came, in order, and the swept space marking each motion as it came; frames after a
    read wait for the next read."""
    from compass_manip.mapping.distance import mark_robot
    from compass_manip.mapping.observe import integrate_observation
    from compass_manip.mapping.occupancy import MapConfig, OccupancyMap

    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        q_home = np.asarray(world.robot.q_home)
        frames = [world.render(q_home + (q_view - q_home) * s, rgb=False, seg=False) for s in np.linspace(0, 1, 5)]
        gm = GraspMap(world.robot, keep_frames=False)
        eager = OccupancyMap(MapConfig())
        for f in frames[:3]:
            gm.frame(f, None)
            integrate_observation(eager, f.observation(), gm.spheres, gm.max_range)
        gm.motion(SimpleNamespace(q=np.stack([q_home, q_view])), 0.0, 1.0)
        gm.motion(SimpleNamespace(q=np.stack([q_view, q_home])), 1.0, 2.0)
        assert np.all(gm._occ.state == VoxelState.UNKNOWN) and len(gm._pending) == 3  # nothing integrated yet
        assert not gm._swept_all.any() and len(gm._unmarked) == 2  # nor marked
        marked = np.zeros(gm._occ.shape, bool)
        for a, b in ((q_home, q_view), (q_view, q_home)):  # one motion at a time, as on arrival
            mark_robot(marked, gm._occ, gm.spheres, densify(np.stack([a, b]), gm.sweep_step), gm.swept_margin)
        assert np.array_equal(gm.swept_all, marked) and marked.sum() > 1000 and not gm._unmarked
        assert np.array_equal(gm.occ.state, eager.state) and np.array_equal(gm.occ.logodds, eager.logodds)
        for f in frames[3:]:
            gm.frame(f, None)
            integrate_observation(eager, f.observation(), gm.spheres, gm.max_range)
        assert len(gm._pending) == 2
        assert np.array_equal(gm.swept_all & (eager.state != VoxelState.OCCUPIED), gm.swept)  # reads the map
        assert len(gm._pending) == 0 and np.array_equal(gm.occ.logodds, eager.logodds)
        assert np.count_nonzero(gm.occ.state != VoxelState.UNKNOWN) > 1000
    finally:
        world.close()


def test_survey_checker_adds_the_grasps_assumed_space_to_the_methods_own_and_nothing_else():
    from compass_manip.exploration.compass import CompassConfig, near_field_world
    from compass_manip.exploration.world_model import WorldModel
    from compass_manip.sim.grasp_only import near_body_unknown
    from compass_manip.sim.near_field import NearFieldScanConfig, scan_candidates
    from compass_manip.trial.grasp_scan import survey_checker

    world = empty_cabinet_world()
    try:
        task, q_home = world.scene.task(), np.asarray(world.robot.q_home)
        wm = WorldModel(q_home, near_field_world(CompassConfig()), world.robot, task)  # COMPASS's rules
        wm.observe(world.render(q_home, rgb=False, seg=False).observation())
        Q = scan_candidates(q_home, 300, np.random.default_rng(3), NearFieldScanConfig(yaw_range=0.6))
        own = np.asarray(wm.checker.are_valid(Q), dtype=bool)
        none = np.asarray(survey_checker(wm, lambda occ: np.zeros(occ.shape, bool)).are_valid(Q), dtype=bool)
        near = lambda occ: near_body_unknown(occ, wm.spheres, q_home, 0.6)  # noqa: E731
        survey = np.asarray(survey_checker(wm, near).are_valid(Q), dtype=bool)
        wm.occ.state[near(wm.occ)] = VoxelState.OCCUPIED  # the same space seen occupied: never free
        blocked = np.asarray(survey_checker(wm, near).are_valid(Q), dtype=bool)
    finally:
        world.close()
    assert np.array_equal(none, own)  # nothing assumed: the method's own verdicts
    assert np.all(survey | ~own) and survey.sum() >= own.sum() + 5  # more, and every one the method takes
    assert not blocked.any()


def test_scan_uses_the_checker_it_is_given():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        gm = _fed_grasp_map(world, q_view, n=2)
        refuse = SimpleNamespace(are_valid=lambda Q: np.zeros(len(Q), bool))
        s = NearFieldScanner(lambda: gm.occ, wm, world.camera.K, (world.camera.width, world.camera.height),
                             world.robot.q_home, world.robot.base_pos, TrialScanConfig(), np.random.default_rng(1),
                             checker_of=lambda: refuse)
        out = s(q_view, None)
    finally:
        world.close()
    assert out.planned is False and s.views == 0 and s.stopped == "no valid candidate"


def test_back_candidates_look_back_at_the_unknown_band_beside_the_base_from_in_front():
    from compass_manip.robot.ik import PandaIK
    from compass_manip.robot.spheres import panda_sphere_model
    from compass_manip.trial.grasp_scan import back_candidates

    world = empty_cabinet_world()
    try:
        gm = _fed_grasp_map(world, np.asarray(world.robot.q_home), n=1)
        kin = panda_sphere_model(world.robot).kinematics
        base, q_home = np.asarray(world.robot.base_pos, float), np.asarray(world.robot.q_home)
        cfg = TrialScanConfig(n_back=40)
        Q = back_candidates(gm.occ, base, cfg, PandaIK(kin), q_home, np.random.default_rng(2))
        T = kin.T_world_cam_batch(Q)
        none = back_candidates(gm.occ, base, TrialScanConfig(), PandaIK(kin), q_home, np.random.default_rng(2))
        gm.occ.state[...] = VoxelState.FREE  # nothing unknown in the band: nothing to look at
        seen = back_candidates(gm.occ, base, cfg, PandaIK(kin), q_home, np.random.default_rng(2))
    finally:
        world.close()
    assert len(Q) >= 5 and len(none) == 0 and len(seen) == 0
    eye_lo, eye_hi = base + np.asarray(cfg.back_eye[0]), base + np.asarray(cfg.back_eye[1])
    assert np.all((T[:, :3, 3] >= eye_lo - 1e-3) & (T[:, :3, 3] <= eye_hi + 1e-3))  # in front of the base
    s = np.linspace(0.25, 0.9, 66)
    P = T[:, None, :3, 3] + s[None, :, None] * T[:, None, :3, 2]  # along each optical axis
    (x0, y0, z0), (x1, y1, z1) = cfg.back_band
    rel = P - base
    inside = (rel[..., 0] >= x0 - 0.01) & (rel[..., 0] <= x1 + 0.01) & (np.abs(rel[..., 1]) >= y0 - 0.01) \
        & (np.abs(rel[..., 1]) <= y1 + 0.01) & (rel[..., 2] >= z0 - 0.01) & (rel[..., 2] <= z1 + 0.01)
    assert np.all(inside.any(axis=1))  # each camera looks at the band beside the base
    with pytest.raises(CompassInputError, match="n_back"):
        TrialScanConfig(n_back=-1)


def test_scan_goes_back_along_its_own_paths_before_inspect_when_asked():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        gm = _fed_grasp_map(world, q_view)
        handed = []
        then = lambda q, d: handed.append(q) or InspectPlan(None, 0, 0, 0.0, planned=False)  # noqa: E731
        runs = {}
        for back in (False, True):
            s = NearFieldScanner(lambda: gm.occ, wm, world.camera.K, (world.camera.width, world.camera.height),
                                 world.robot.q_home, world.robot.base_pos,
                                 TrialScanConfig(max_views=1, return_back=back), np.random.default_rng(0), then=then)
            p = s(q_view, None)
            runs[back] = (p, s(p.path[-1], None), s)
    finally:
        world.close()
    (p0, after0, _), (p1, after1, s1) = runs[False], runs[True]
    assert after0.planned is False  # off: INSPECT right after the scan
    assert after1.path is not None and np.allclose(after1.path[0], p1.path[-1]) and np.allclose(after1.path[-1], q_view)
    assert np.allclose(after1.path, p1.path[::-1])  # exactly the way it came
    assert s1.way_back(q_view) is None and len(handed) == 1  # once: then INSPECT
