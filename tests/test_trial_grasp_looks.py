"""Looks at the arm's space outside the confined space when INSPECT ends (`trial.grasp_looks`):
the poses aim at the given voxels from in front of the base, the looks are valid for the
method's checker and planned on it, they stop at their budget, and the arm then goes back the
way it came before INSPECT is asked again."""
from types import SimpleNamespace

import numpy as np
import pytest

from _inspect_fixtures import empty_cabinet_world, observed_view

from compass_manip.errors import CompassInputError
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.robot.ik import PandaIK
from compass_manip.task import ConfinedSpace
from compass_manip.trial.grasp_looks import BaseLookConfig, BaseLooks, look_poses, outside_space, way_back
from compass_manip.trial.inspect import InspectConfig, InspectPlan, frustum_mask


def test_outside_space_keeps_the_cabinet_and_its_opening_band_inside():
    space = ConfinedSpace((0.45, -0.3, 0.3), (0.8, 0.3, 0.8), (0.45, -0.3, 0.3), (0.45, 0.3, 0.8), (-1.0, 0.0, 0.0))
    p = np.array([[0.6, 0.0, 0.5],  # in the cabinet
                  [0.35, 0.0, 0.5],  # 10 cm in front of the opening: still the cabinet's
                  [0.25, 0.0, 0.5],  # 20 cm in front: outside
                  [0.1, 0.32, 0.5],  # beside the base
                  [0.6, 0.33, 0.5],  # 3 cm past the side wall: within `side`
                  [0.9, 0.0, 0.5]])  # behind the back wall (not on the open side): outside
    assert outside_space(p, space, 0.15, 0.05).tolist() == [False, False, True, True, False, True]
    assert outside_space(p, space, 0.0, 0.0).tolist() == [False, True, True, True, True, True]


def test_look_poses_aim_at_the_weighted_voxels_from_eye_points_in_front_of_the_base():
    base = np.array([0.0, 0.1, 0.0])
    looks = np.array([[0.1, 0.45, 0.5], [0.15, -0.3, 0.4], [5.0, 5.0, 5.0]])
    cfg = BaseLookConfig(max_looks=1, n_poses=200)
    T = look_poses(looks, np.array([1.0, 3.0, 0.0]), base, 0.0, cfg, np.random.default_rng(0))
    assert 100 <= len(T) <= 200
    eye = T[:, :3, 3] - base
    assert np.all((eye >= np.asarray(cfg.eye[0]) - 1e-9) & (eye <= np.asarray(cfg.eye[1]) + 1e-9))
    # each optical axis passes through one of the two weighted points (never the zero-weight one)
    d = [np.linalg.norm(np.cross(T[:, :3, 2], p - T[:, :3, 3]), axis=1) for p in looks]
    hit = np.stack(d) < 1e-9
    assert np.all(hit.any(axis=0)) and not hit[2].any()
    assert 0.6 < hit[1].mean() < 0.9  # drawn by weight (3:1)
    rng_yaw = look_poses(looks[:1], np.ones(1), base, np.pi / 2, cfg, np.random.default_rng(0))
    rel = rng_yaw[:, :3, 3] - base  # the eye box turns with the base: in front is +y now
    assert np.all(rel[:, 1] >= 0.25 - 1e-9)
    assert len(look_poses(looks, np.zeros(3), base, 0.0, cfg, np.random.default_rng(0))) == 0
    with pytest.raises(CompassInputError, match="max_looks"):
        BaseLookConfig(max_looks=11)
    with pytest.raises(CompassInputError, match="n_solutions"):
        BaseLookConfig(n_solutions=0)


def test_way_back_reverses_the_executed_paths_to_where_they_started():
    a = np.array([[0.0] * 7, [0.1] * 7, [0.2] * 7])
    b = np.array([[0.2] * 7, [0.4] * 7])
    W = way_back([a, b], b[-1])
    assert np.allclose(W, [[0.4] * 7, [0.2] * 7, [0.1] * 7, [0.0] * 7])
    assert way_back([a, b], a[0]) is None and way_back([], a[0]) is None


class _FakeInspector:
    """INSPECT's surface the looks use: the method's world model, IK, K, config, and `needs`
    returning one hypothesis whose needed voxels are `vox` (those still unknown on the map)."""

    def __init__(self, wm, K, vox):
        self.wm, self.K, self.ik, self.config = wm, K, PandaIK(wm.kin), InspectConfig(n_views=20)
        self.vox, self.calls, self.pinned, self.ik_sweeps = vox, [], "pinned", "sweeps"

        self.last_hypotheses = [SimpleNamespace(score=1.0)]

    def needs(self, q, detection, hyps=None):
        assert hyps is self.last_hypotheses or hyps == self.last_hypotheses  # recounted, never drawn anew
        v = self.vox[self.wm.occ.state[tuple(self.vox.T)] == VoxelState.UNKNOWN]
        return hyps, [v]

    def __call__(self, q, detection):
        self.calls.append(np.array(q))
        return InspectPlan(None, 0, 0, 0.0, planned=False)


def _band_beside_base(occ, base):
    """Unknown voxel indices of a block beside the base (x 0..0.2, y 0.25..0.4, z 0.35..0.6 m)."""
    c = occ.voxel_centers().reshape(-1, 3) - base
    m = (c[:, 0] >= 0.0) & (c[:, 0] <= 0.2) & (c[:, 1] >= 0.25) & (c[:, 1] <= 0.4) & (c[:, 2] >= 0.35) \
        & (c[:, 2] <= 0.6)
    idx = np.argwhere(m.reshape(occ.shape) & (occ.state == VoxelState.UNKNOWN))
    return idx


def test_looks_aim_at_the_needed_voxels_outside_stop_at_their_budget_and_go_back():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        base = np.asarray(world.robot.base_pos, float)
        vox = _band_beside_base(wm.occ, base)
        ins = _FakeInspector(wm, world.camera.K, vox)
        looks = BaseLooks(ins, task, BaseLookConfig(max_looks=2), np.random.default_rng(3))
        p1 = looks(q_view, None)
        q = q_view
        plans = [p1]
        while plans[-1].path is not None and len(plans) < 6:
            q = np.asarray(plans[-1].path)[-1]
            plans.append(looks(q, None))
        valid_ends = [bool(wm.checker.is_valid(np.asarray(p.path)[-1])) for p in plans if p.path is not None]
        seen = [frustum_mask(wm.kin.T_world_cam_batch(np.asarray(p.path)[-1:]), world.camera.K,
                             wm.occ.voxel_to_world(vox), 1.5)[0].mean() for p in plans[:looks.looks]]
    finally:
        world.close()
    assert len(vox) > 100
    assert looks.looks == 2 and looks.stopped == "max_looks" and looks.returned
    assert len(plans) == 4 and plans[3].planned is False  # 2 looks, the way back, INSPECT once more (ended)
    assert all(valid_ends)  # the looks' ends are valid for the method's checker
    assert min(seen) > 0.2  # each look's camera frames the voxels it was aimed at
    back = np.asarray(plans[2].path)
    executed = np.vstack([plans[0].path, plans[1].path])
    assert np.allclose(back[0], executed[-1]) and np.allclose(back[-1], q_view)
    assert np.allclose(back, way_back([np.asarray(plans[0].path), np.asarray(plans[1].path)], executed[-1]))
    assert len(ins.calls) == 2 and np.allclose(ins.calls[1], q_view)  # INSPECT again from where it ended
    assert looks.pinned == "pinned" and looks.ik_sweeps == "sweeps"


def test_no_look_when_the_needed_voxels_lie_in_the_cabinet_or_looks_are_off():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        c = wm.occ.voxel_centers().reshape(-1, 3)
        inside = ~outside_space(c, task.space, 0.15, 0.05).reshape(wm.occ.shape)
        vox = np.argwhere(inside & (wm.occ.state == VoxelState.UNKNOWN))
        ins = _FakeInspector(wm, world.camera.K, vox)
        looks = BaseLooks(ins, task, BaseLookConfig(max_looks=3), np.random.default_rng(0))
        p = looks(q_view, None)
        off = BaseLooks(_FakeInspector(wm, world.camera.K, _band_beside_base(wm.occ, np.asarray(world.robot.base_pos))),
                        task, BaseLookConfig(max_looks=0), np.random.default_rng(0))
        p_off = off(q_view, None)
    finally:
        world.close()
    assert len(vox) > 100
    assert p.planned is False and looks.looks == 0 and looks.stopped.startswith("outside share")
    assert p_off.planned is False and off.looks == 0 and off.log == []


def test_looks_come_when_inspect_has_spent_its_calls():
    calls = []

    class Busy:
        pinned = ik_sweeps = None

        def __call__(self, q, d):
            calls.append(1)
            return InspectPlan(np.zeros((2, 7)), 5, 1, 0.0)

    looks = BaseLooks(Busy(), SimpleNamespace(robot_base_pos=(0.0, 0.0, 0.0)), BaseLookConfig(max_looks=1),
                      np.random.default_rng(0), inner_budget=lambda: 3)
    looks.look = lambda q, d: looks.log.append("look") or None  # no look plans: the calls go back to INSPECT
    out = [looks(np.zeros(7), None) for _ in range(5)]
    assert len(calls) == 3 + 1 and looks.log == ["look"]  # 3 of INSPECT's, the look step, then INSPECT again
    assert out[3].planned is False and out[4].path is not None


def test_look_poses_take_given_eye_points_when_asked():
    eyes = np.array([[0.3, 0.0, 0.8], [0.4, 0.1, 0.9]])
    looks = np.array([[0.1, 0.35, 0.5]])
    T = look_poses(looks, np.ones(1), np.zeros(3), 0.0, BaseLookConfig(n_poses=50), np.random.default_rng(1), eyes)
    d = np.linalg.norm(T[:, None, :3, 3] - eyes[None], axis=2).min(axis=1)
    assert len(T) == 50 and np.all(d < 1e-9)  # every eye is one of the given points
    assert np.allclose(np.einsum("ij,ij->i", T[:, :3, 2], (looks[0] - T[:, :3, 3])),
                       np.linalg.norm(looks[0] - T[:, :3, 3], axis=1))  # looking straight at the voxel
