"""The trial's GRASP state: the machine goes FOUND -> GRASP -> DONE (or FAILED with the
grasp's reason) and charges the grasp's time; find-only trials stop at FOUND; the stage
selects on the method's map and lifts a free-standing box in physics."""
from types import SimpleNamespace

import numpy as np
import pytest

from compass_manip.grasp.select import GraspFailure
from compass_manip.mapping.observe import integrate_observation
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.grasp_only import GraspOnlyConfig, near_field_configs, oracle_detection, oracle_view
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
from compass_manip.sim.world import World
from compass_manip.trial.config import GraspTrialConfig, TrialConfig
from compass_manip.trial.grasp_stage import _SELECT_FAILURE, GraspStageResult, run_grasp_stage
from compass_manip.trial.machine import TrialMachine, TrialState
from compass_manip.trial.result import TrialFailure

RED = (0.9, 0.05, 0.05, 1.0)


class _Frame:
    T_world_cam = np.eye(4)

    def observation(self):
        return self


class _Stubs:
    """A world, method, buffer and metrics that find the target in the first frame."""

    def __init__(self):
        self.world = SimpleNamespace(q=np.zeros(7), render=lambda q, t=0.0, rgb=True, seg=False: _Frame())
        self.method = SimpleNamespace(observe=lambda obs: None, occupancy=None,
                                      add_points_of_interest=lambda pts: None)
        det = SimpleNamespace(t=1.5)
        self.buffer = SimpleNamespace(push=lambda f: None, sync=lambda t_now=None: None, take_hints=lambda: np.zeros((0, 3)),
                                      best=lambda: SimpleNamespace(detection=det))
        self.metrics = SimpleNamespace(collisions=0, explored_fraction=lambda t, occ: None)


def _machine(grasp):
    s = _Stubs()
    return TrialMachine(s.world, s.method, s.buffer, s.metrics, TrialConfig(), grasp=grasp), s


@pytest.mark.parametrize("failure", [None, TrialFailure.GRASP_SLIP])
def test_machine_grasps_after_found_and_charges_its_time(failure):
    calls = []

    def grasp(q, detection, moved, look=None):
        calls.append((q, detection, moved))
        return GraspStageResult(failure, 7.25, None, None, q, 2 if failure else 0)

    m, s = _machine(grasp)
    out = m.run()
    assert len(calls) == 1 and calls[0][1].t == 1.5 and calls[0][2] == []
    assert out.states == (TrialState.FOUND, TrialState.GRASP, TrialState.DONE if failure is None else TrialState.FAILED)
    assert out.failure is failure and out.t_found == 1.5 and out.t_end == pytest.approx(7.25)
    assert out.grasp is not None and s.metrics.collisions == (2 if failure else 0)


def test_find_only_stops_at_found():
    m, _ = _machine(None)
    out = m.run()
    assert out.states == (TrialState.FOUND, TrialState.DONE) and out.failure is None and out.grasp is None


def test_every_selection_failure_has_a_trial_reason():
    assert set(_SELECT_FAILURE) == set(GraspFailure)
    assert {f.name for f in _SELECT_FAILURE.values()} <= {f.name for f in TrialFailure}


def test_grasp_stage_lifts_a_free_standing_box_from_the_methods_map():
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.80, 0.3, 0.80))  # an empty, open cabinet
    target = Primitive("target", "box", (0.02, 0.02, 0.06), (0.60, 0.0, 0.36), 0.2, RED, True, 0.08)
    scene = SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target)
    world = World(scene)
    try:
        rng = np.random.default_rng(0)
        q_view, _ = oracle_view(world, rng, GraspOnlyConfig())  # ORACLE START (test fixture)
        q_home = np.asarray(world.robot.q_home)
        occ, spheres = OccupancyMap(MapConfig()), panda_sphere_model(world.robot)
        path = np.stack([q_home + (q_view - q_home) * s for s in np.linspace(0.0, 1.0, 8)])
        looks = near_field_configs(world, rng, 12)  # the near field, as the trial's NFA scan sees it
        for q in [*looks, *path]:
            integrate_observation(occ, world.render(q, rgb=False, seg=False), spheres, world.camera.depth_max)
        moved = [path] + [np.stack([q_home, q]) for q in looks]
        view = world.render(q_view, rgb=False, seg=True)
        det = SimpleNamespace(points_world=oracle_detection(world, view), T_world_cam=view.T_world_cam)
        world.set_q(q_view)
        r = run_grasp_stage(world, occ, det, scene.task(), q_view, moved, GraspTrialConfig(), rng, 0.1)
    finally:
        world.close()
    assert r.failure is None, (r.selection.failure, r.selection.rejections, r.outcome and r.outcome.failure)
    assert 0.0 < r.gpq <= r.selection.score and r.n_collisions == 0
    assert r.lift_m > 0.7 * r.selection.lift_height and r.duration_s > 0.1 + 2.0  # charge + close, lift, hold
