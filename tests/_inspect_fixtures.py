"""Shared set-ups of the INSPECT tests (`test_trial_inspect.py`, `test_trial_grasp_views.py`):
an empty open cabinet with a small box target, the method's world model observed along a
straight way from home to a view that sees the target, and stand-ins for the machine's parts."""
from types import SimpleNamespace

import numpy as np

from compass_manip.exploration.world_model import WorldModel
from compass_manip.sim.grasp_only import GraspOnlyConfig, oracle_view
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
from compass_manip.sim.world import World


def empty_cabinet_world() -> World:
    """An empty, open cabinet (x 0.45..0.80 m, y +-0.3 m, z 0.30..0.80 m) with a 4 x 4 x 12 cm
    red box standing in it."""
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.80, 0.3, 0.80))
    target = Primitive("target", "box", (0.02, 0.02, 0.06), (0.60, 0.0, 0.36), 0.2, (0.9, 0.05, 0.05, 1.0), True, 0.08)
    return World(SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target))


def observed_view(world: World, n_frames: int = 8):
    """(task, world model, q_view (7,) [rad], the view's frame with labels): a view that sees
    the target (chosen with ground truth: a test fixture), the model fed n_frames frames on the
    straight joint way from home to it and that way marked as the robot's."""
    q_view, _ = oracle_view(world, np.random.default_rng(0), GraspOnlyConfig())
    task = world.scene.task()
    q_home = np.asarray(world.robot.q_home)
    wm = WorldModel(q_home, robot=world.robot, task=task)
    path = np.stack([q_home + (q_view - q_home) * s for s in np.linspace(0.0, 1.0, n_frames)])
    for q in path:
        wm.observe(world.render(q, rgb=False, seg=False).observation())
    wm.add_swept(path)
    return task, wm, q_view, world.render(q_view, rgb=False, seg=True)


def machine_parts():
    """(world, method, buffer, metrics) stand-ins for `TrialMachine`: the buffer holds a
    detection at t = 1.5 s with 20 points, so the machine goes straight to FOUND."""
    world = SimpleNamespace(q=np.zeros(7), render=lambda q, t=0.0, rgb=True, seg=False: SimpleNamespace(
        T_world_cam=np.eye(4), observation=lambda: None))
    method = SimpleNamespace(observe=lambda obs: None, occupancy=None, add_points_of_interest=lambda pts: None)
    det = SimpleNamespace(t=1.5, points_world=np.ones((20, 3)), T_world_cam=np.eye(4))
    buffer = SimpleNamespace(push=lambda f: None, sync=lambda t_now=None: None, take_hints=lambda: np.zeros((0, 3)),
                             best=lambda: SimpleNamespace(detection=det))
    metrics = SimpleNamespace(collisions=0, explored_fraction=lambda t, occ: None, plans_attempted=0,
                              plans_succeeded=0)
    return world, method, buffer, metrics
