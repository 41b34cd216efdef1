"""Kinematic execution with contact reports, and physics grasp-and-lift."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.oracle import find_grasp
from compass_manip.sim.executor import ExecutorConfig, execute
from compass_manip.sim.physics import grasp_and_lift
from compass_manip.sim.world import World
from compass_manip.types import Trajectory


@pytest.fixture(scope="module")
def world():
    w = World(certified_scene(3, 1, 0).scene)
    yield w
    w.close()


def test_free_path_has_no_contacts_and_emits_frames(world):
    q1 = Q_HOME + np.array([0.0, 0.0, 0.0, 0.0, 0.3, -0.2, 0.4])
    traj = Trajectory(np.array([0.0, 2.0]), np.stack([Q_HOME, q1]))
    res = execute(world, traj, ExecutorConfig(frame_rate=2.0), t0=10.0)
    assert res.completed and not res.contacts
    assert np.allclose(res.q_end, q1)
    assert [f.t for f in res.frames] == pytest.approx([10.5, 11.0, 11.5, 12.0])
    assert np.allclose(res.frames[-1].q, q1)
    assert res.t_end == pytest.approx(12.0)


def test_deliberate_collision_is_reported(world):
    # swing joint 1 into the obstacles beside the base
    q1 = Q_HOME.copy()
    q1[0] = 2.5
    q1[1] = 0.3
    traj = Trajectory(np.array([0.0, 3.0]), np.stack([Q_HOME, q1]))
    res = execute(world, traj, ExecutorConfig(frame_rate=0.0))
    assert not res.completed and res.contacts
    c = res.contacts[0]
    assert 0.0 < c.t < 3.0 and c.contact.depth >= 0.0
    assert not world.contacts(res.q_end, include_self=True)  # halted before the contact
    # and without stopping, every contact along the way is listed
    res2 = execute(world, traj, ExecutorConfig(frame_rate=0.0, stop_on_contact=False))
    assert res2.completed and len(res2.contacts) >= len(res.contacts)


def test_bad_trajectories_are_rejected(world):
    with pytest.raises(CompassInputError, match="strictly increasing"):
        execute(world, Trajectory(np.array([0.0, 0.0]), np.stack([Q_HOME, Q_HOME])))
    bad = Q_HOME.copy()
    bad[3] = 1.0
    with pytest.raises(CompassInputError, match=r"trajectory q\[1\]"):
        execute(world, Trajectory(np.array([0.0, 1.0]), np.stack([Q_HOME, bad])))
    with pytest.raises(CompassInputError, match="frame_rate"):
        ExecutorConfig(frame_rate=-1.0)


def test_physics_grasp_lifts_the_target():
    w = World(certified_scene(1, 1, 0).scene)
    try:
        g = find_grasp(w)
        approach = Trajectory(np.array([0.0, 1.5]), np.stack([g.q_pregrasp, g.q_grasp]))
        lift = Trajectory(np.array([0.0, 1.5]), np.stack([g.q_grasp, g.q_lift]))  # straight up
        out = grasp_and_lift(w, g.q_pregrasp, approach, lift)
        assert out.lifted and out.target_in_hand
        assert out.lift_height > 0.025
        assert 0.02 < out.finger_width < 0.075
        # closing on nothing (no approach): the target stays put
        empty = grasp_and_lift(w, g.q_pregrasp, Trajectory(np.array([0.0, 0.5]), np.stack([g.q_pregrasp] * 2)),
                               Trajectory(np.array([0.0, 0.5]), np.stack([g.q_pregrasp] * 2)))
        assert not empty.lifted and abs(empty.lift_height) < 0.01
    finally:
        w.close()
