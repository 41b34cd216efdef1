"""Grasp-aware INSPECT (`trial.grasp_views`) in a constructed scene, on the method's own map
and checker: the chosen view is reached without passing an invalid configuration (and free in
truth), and its frame leaves less of the grasp hypotheses' needed unknown space than the frame
of a random valid configuration near the start does."""
from types import SimpleNamespace

import numpy as np
import pytest

from _inspect_fixtures import empty_cabinet_world, observed_view

from compass_manip.mapping.observe import integrate_observation
from compass_manip.motion.timing import densify
from compass_manip.robot.model import Q_MAX, Q_MIN
from compass_manip.sim.grasp_only import oracle_detection
from compass_manip.trial.config import GraspTrialConfig
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.trial.grasp_map import GraspMap
from compass_manip.trial.grasp_views import GraspInspector, view_candidates
from compass_manip.types import Trajectory
from compass_manip.trial.inspect import InspectConfig


def test_view_candidates_look_along_the_axes_from_the_set_distance():
    rng = np.random.default_rng(0)
    cfg = InspectConfig(n_per_axis=5, n_around=3, axis_cone=0.3, view_distance=(0.3, 0.4))
    z, look = np.array([1.0, 0.0, 0.0]), np.array([0.6, 0.0, 0.4])
    T = view_candidates([(z, look)], np.array([0.6, 0.1, 0.4]), np.array([0.0, 1.0, 0.0]), cfg, rng)
    assert T.shape == (8, 4, 4)
    ax = T[:5]
    assert np.all(ax[:, :3, 2] @ z >= np.cos(0.3) - 1e-9)  # optical axes within the cone of the approach
    d = np.linalg.norm(ax[:, :3, 3] - look, axis=1)
    assert np.all((d >= 0.3 - 1e-9) & (d <= 0.4 + 1e-9))
    to_look = (look - ax[:, :3, 3]) / d[:, None]
    assert np.allclose(np.einsum("ij,ij->i", to_look, ax[:, :3, 2]), 1.0)  # looking at the point


def _remaining(inspector, q, det, hyps, occ):
    w = np.array([h.score for h in hyps])
    _, needed = inspector.needs(q, det, occ=occ, hyps=hyps)
    return float(sum(wi * len(n) / max(n0, 1) for wi, n, n0 in zip(w, needed, inspector.counts0)))


def test_grasp_view_is_valid_all_the_way_and_sees_more_of_the_needed_space_than_a_random_valid_view():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        det = SimpleNamespace(points_world=oracle_detection(world, view), T_world_cam=view.T_world_cam)
        gc = GraspTrialConfig()
        insp = GraspInspector(wm, world.camera.K, task, gc.target, gc.select, gc.inspect, np.random.default_rng(1))
        hyps, needed = insp.needs(q_view, det)
        assert hyps and min(len(n) for n in needed) > 0  # the grasps still need unseen space
        _own_space_decides(world, wm, task, q_view, det, gc, hyps, needed)
        for h in hyps:  # each keeps its candidate row, pinned for the next steps and the selection
            assert len(h.candidate) == 1 and np.allclose(h.candidate.T_world_tcp[0], h.T_world_tcp)
            assert h.candidate.score[0] == pytest.approx(h.score)
        assert len(insp.pinned) == min(len(hyps), gc.inspect.max_pinned)
        insp.counts0 = [len(n) for n in needed]
        p = insp(q_view, det)
        assert p.planned and p.path is not None and np.allclose(p.path[0], q_view)
        dense = densify(p.path, 0.005)
        assert np.all(wm.checker.are_valid(dense))  # never through an invalid configuration
        assert not any(world.in_collision(q) for q in dense[::10])  # and free in truth

        def after(q):
            occ = wm.occ.copy()
            integrate_observation(occ, world.render(q, rgb=False, seg=False).observation(), wm.spheres,
                                  wm.config.max_range)
            return _remaining(insp, q_view, det, hyps, occ)

        chosen = after(p.path[-1])
        near = q_view + np.random.default_rng(2).normal(0.0, 1.0, (200, 7)) * np.r_[np.full(4, 0.12), np.full(3, 0.5)]
        near = np.clip(near, Q_MIN + 1e-3, Q_MAX - 1e-3)
        near = near[np.asarray(wm.checker.are_valid(near), bool)][:5]
        assert len(near) == 5
        random_views = [after(q) for q in near]
        before = _remaining(insp, q_view, det, hyps, wm.occ)
        assert chosen < before and chosen < np.median(random_views)
    finally:
        world.close()


def _own_space_decides(world, wm, task, q_view, det, gc, hyps, base):
    """strict_safe (the space the GRASP stage's selection takes as the robot's own) decides which
    unknown voxels a hypothesis still needs: a smaller own space than the model's swept space
    needs more, and voxels the selection takes as its own are not needed (the grasp-only
    harness's selection keeps only the way grown by 2 cm, its INSPECT model 5 cm: INSPECT
    stopped on hypotheses needing nothing that the selection then refused)."""
    def needs(strict_safe):
        insp = GraspInspector(wm, world.camera.K, task, gc.target, gc.select, gc.inspect, np.random.default_rng(1),
                              strict_safe=strict_safe)
        return insp.needs(q_view, det, hyps=hyps)[1]

    assert all(np.array_equal(a, b) for a, b in zip(base, needs(lambda o: wm.swept)))
    none = needs(lambda o: np.zeros(o.shape, bool))
    key = lambda n: {tuple(v) for v in n}  # noqa: E731
    assert all(key(a) <= key(b) for a, b in zip(base, none)) and sum(map(len, none)) > sum(map(len, base))
    own = wm.swept.copy()
    own[tuple(base[0].T)] = True  # and the first hypothesis's needed voxels taken as the robot's own
    assert len(needs(lambda o: own)[0]) == 0


def test_grasp_map_integrates_frames_at_1cm_and_marks_the_way_but_not_seen_obstacles():
    world = empty_cabinet_world()
    try:
        gm = GraspMap(world.robot)
        assert gm.occ.resolution == 0.01
        q_home = np.asarray(world.robot.q_home)
        gm.start(world, None)
        gm.frame(world.render(q_home, rgb=False, seg=False), None)
        occ = gm.occ
        assert (occ.state == VoxelState.OCCUPIED).sum() > 100 and (occ.state == VoxelState.FREE).sum() > 1000
        q1 = q_home + np.r_[0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        gm.motion(Trajectory(np.array([0.0, 1.0]), np.stack([q_home, q1])), 0.0, 1.0)
        mid = gm.spheres.sphere_centers(((q_home + q1) / 2)[None])[0]  # a configuration on the way
        v = occ.world_to_voxel(mid)
        assert gm.swept_all[v[:, 0], v[:, 1], v[:, 2]].all()
        occ.state[v[0, 0], v[0, 1], v[0, 2]] = VoxelState.OCCUPIED  # seen occupied later: not the robot's
        assert not gm.swept[v[0, 0], v[0, 1], v[0, 2]] and gm.swept[v[1, 0], v[1, 1], v[1, 2]] == \
            (occ.state[v[1, 0], v[1, 1], v[1, 2]] != VoxelState.OCCUPIED)
    finally:
        world.close()


def test_up_candidates_stand_below_and_in_front_of_the_voxels_looking_up():
    from compass_manip.trial.grasp_views import up_candidates
    rng = np.random.default_rng(0)
    cfg = InspectConfig(n_up=40, up_elevation=0.6, up_cone=0.3, view_distance=(0.25, 0.4))
    look, shoulder = np.array([0.55, 0.05, 0.62]), np.array([0.0, 0.0, 0.333])
    T = up_candidates(look[None], np.array([0.9, 0.1, -0.3]), shoulder, cfg, rng)
    assert T.shape == (40, 4, 4)
    z = T[:, :3, 2]
    d = np.linalg.norm(T[:, :3, 3] - look, axis=1)
    assert np.all((d >= 0.25 - 1e-9) & (d <= 0.4 + 1e-9))
    assert np.allclose(np.einsum("ij,ij->i", (look - T[:, :3, 3]) / d[:, None], z), 1.0)  # looking at the point
    assert np.all(z[:, 2] > 0.0) and np.all(T[:, 2, 3] < look[2])  # from below, looking up
    assert np.all(T[:, 0, 3] < look[0])  # on the robot's side of the voxels
    h = np.array([0.9, 0.1, 0.0]) / np.linalg.norm([0.9, 0.1])
    up = np.cos(0.6) * h + np.array([0.0, 0.0, np.sin(0.6)])
    assert np.all(z[0::2] @ up >= np.cos(0.3) - 1e-9)  # even ones: the approach raised by up_elevation
    back = (look - shoulder) / np.linalg.norm(look - shoulder)
    assert np.all(z[1::2] @ back >= np.cos(0.3) - 1e-9)  # odd ones: from the shoulder's side
    assert up_candidates(np.zeros((0, 3)), h, shoulder, cfg, rng).shape == (0, 4, 4)


@pytest.fixture(scope="module")
def rail_view():
    """An open cabinet whose shelf at z = 0.62 m has a 5 cm face-frame rail below it, the
    method's model observed on the way to a view of the target, and one grasp hypothesis
    (approach +x) whose arm needs the unknown voxels behind the rail (x 0.47-0.56 m, z
    0.57-0.60 m): the space the forearm of a severe level's neck grasp needs."""
    from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
    from compass_manip.sim.world import World
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.80, 0.3, 0.95), shelves=(0.62,), rail=0.05)
    target = Primitive("target", "box", (0.02, 0.02, 0.06), (0.60, 0.0, 0.36), 0.2, (0.9, 0.05, 0.05, 1.0), True,
                       0.08)
    world = World(SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target))
    task, wm, q_view, view = observed_view(world)
    det = SimpleNamespace(points_world=oracle_detection(world, view), T_world_cam=view.T_world_cam)
    occ = wm.occ
    a = occ.world_to_voxel(np.array([[0.47, -0.08, 0.57]]))[0]
    b = occ.world_to_voxel(np.array([[0.56, 0.08, 0.60]]))[0] + 1
    box = np.zeros(occ.shape, bool)
    box[a[0]:b[0], a[1]:b[1], a[2]:b[2]] = True
    needed = np.argwhere(box & (occ.state == VoxelState.UNKNOWN))
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])  # approach (z) along +x
    T[:3, 3] = (0.6, 0.0, 0.38)
    hyp = SimpleNamespace(score=1.0, T_world_tcp=T)
    yield world, task, wm, q_view, det, [hyp], needed
    world.close()


def _inspector(rail_view, **over):
    from dataclasses import replace
    world, task, wm, q_view, det, hyps, needed = rail_view
    gc = GraspTrialConfig()
    # the INSPECT defaults (the grasp-only harness's); the trial keeps the older view choice
    insp = GraspInspector(wm, world.camera.K, task, gc.target, gc.select, replace(InspectConfig(), **over),
                          np.random.default_rng(1))
    insp.needs = lambda q, d, occ=None, hyps=None: (rail_view[5], [rail_view[6]])  # the hypothesis above
    return insp


def test_arm_voxels_behind_a_rail_get_a_view_from_below(rail_view):
    world, task, wm, q_view, det, hyps, needed = rail_view
    assert len(needed) > 50  # unseen from the views down at the target
    insp = _inspector(rail_view)
    p = insp(q_view, det)
    assert p.path is not None and insp.last["chosen_up"]  # a look up wins
    T = wm.kin.T_world_cam_batch(np.asarray(p.path)[-1:])[0]
    centre = wm.occ.voxel_to_world(needed).mean(axis=0)
    assert T[2, 3] < centre[2] - 0.03 and T[2, 2] > 0.0  # below the voxels, looking up
    assert np.all(wm.checker.are_valid(densify(np.asarray(p.path), 0.01)))
    flat = _inspector(rail_view, n_up=0)  # only the views along the approach and around: they see less
    flat(q_view, det)
    assert insp.last["best_gain"] > flat.last["best_gain"] + 100


def test_inspect_moves_out_of_a_start_the_checker_refuses(rail_view):
    world, task, wm, q_view, det, hyps, needed = rail_view
    occ, state = wm.occ, wm.occ.state.copy()
    try:  # a voxel seen occupied 3 mm from the hand (within the checker's 5 mm margin)
        c = wm.spheres.sphere_centers(q_view[None])[0]
        k = int(np.argmax(c[:, 2]))
        p0 = c[k] + np.array([0.0, 0.0, wm.spheres.radii[k] + 0.003 + 0.5 * np.sqrt(3) * occ.resolution])
        v = occ.world_to_voxel(p0[None])[0]
        occ.state[v[0], v[1], v[2]] = VoxelState.OCCUPIED
        wm._checker = None  # the map changed outside observe(): rebuild the checker
        chk = wm.checker
        assert not chk.is_valid(q_view)
        stuck = _inspector(rail_view, escape=False)
        assert stuck(q_view, det).path is None  # no plan starts there
        insp = _inspector(rail_view)
        p = insp(q_view, det)
        assert p.path is not None and insp.last["escaped"] and np.allclose(p.path[0], q_view)
        rest = densify(np.asarray(p.path)[1:], 0.01)
        assert chk.is_valid(p.path[1]) and np.all(chk.are_valid(rest))  # valid from the way out on
    finally:
        occ.state[...] = state
        wm._checker = None


def test_near_target_first_keeps_the_needed_voxels_next_to_the_target_while_any_is_there():
    from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
    from compass_manip.trial.grasp_views import near_target_first
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(1.0, 1.0, 1.0), resolution=0.01))
    points = np.array([[0.80, 0.50, 0.50], [0.82, 0.52, 0.60]])  # the target's points
    near_v = occ.world_to_voxel(np.array([[0.70, 0.50, 0.55]]))  # 10 cm in front: the hand's way in
    far_v = occ.world_to_voxel(np.array([[0.20, 0.50, 0.40], [0.25, 0.40, 0.40]]))  # the arm's, by the base
    needed = [np.vstack([near_v, far_v]), far_v]
    out = near_target_first(occ, needed, points, 0.2)
    assert [len(n) for n in out] == [1, 0]
    assert np.array_equal(out[0], near_v)
    # no hypothesis needs a voxel next to the target: all of them are aimed at
    only_far = near_target_first(occ, [far_v, far_v[:1]], points, 0.2)
    assert [len(n) for n in only_far] == [2, 1]
    # off (margin 0): unchanged
    assert [len(n) for n in near_target_first(occ, needed, points, 0.0)] == [3, 2]


def test_inspect_config_rejects_a_negative_near_first():
    from compass_manip.errors import CompassInputError
    with pytest.raises(CompassInputError, match="near_first"):
        InspectConfig(near_first=-0.1)
