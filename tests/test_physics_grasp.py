"""Physics fidelity of grasp execution on an upright can (the targets' usual shape): it stays
put on its board while the arm moves near it, and a side grasp lifts it and holds it still
for the whole hold (no creep of the target down the fingers)."""
from types import SimpleNamespace

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import rot_y
from compass_manip.robot.ik import ik_tcp
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.grasp_exec import ExecFailure, GraspExecConfig, execute_grasp
from compass_manip.sim.physics import PhysicsSession
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
from compass_manip.sim.world import World
from compass_manip.types import Trajectory

RED = (0.9, 0.05, 0.05, 1.0)
CAN = np.array([0.62, 0.0, 0.36])  # centre [m]: radius 3.2 cm, 12 cm tall, on the board at 0.30 m


def can_scene() -> SceneSpec:
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.85, 0.3, 0.80))
    target = Primitive("target", "cylinder", (0.032, 0.06), tuple(CAN), 0.0, RED, True, 0.3)
    return SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target)


def side_grasp(z_above_centre: float = 0.03):
    """A grasp across the can's axis at z_above_centre [m] over its centre: approach through the
    opening (+x, tilted 20 deg down), closing line horizontal; pre-grasp 10 cm back along the
    approach, lift 10 cm up (IK from home)."""
    R = rot_y(np.radians(20.0)) @ np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # x, y, z_g
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, CAN + [0.0, 0.0, z_above_centre]
    qs = []
    for offset in (-0.10 * R[:, 2], [0.0, 0.0, 0.0], [0.0, 0.0, 0.10]):
        Ti = T.copy()
        Ti[:3, 3] += offset
        q = ik_tcp(Ti, qs[-1] if qs else Q_HOME).best
        assert q is not None
        qs.append(q)
    return SimpleNamespace(failure=None, q_pregrasp=qs[0], q_grasp=qs[1], q_lift=qs[2], lift_height=0.10,
                           path=np.stack([Q_HOME, qs[0]]))


def test_can_on_a_board_stays_put_while_the_arm_moves_to_a_pregrasp_next_to_it():
    world = World(can_scene())
    try:
        sel = side_grasp()
        sim = PhysicsSession(world, Q_HOME)
        sim.step(0.2)
        p0 = sim.body_pos("target")
        sim.track(Trajectory(np.array([0.0, 3.0]), sel.path), settle=0.5)
        # then sideways past the can, 2 cm clear of its side, and back
        q_near = sel.q_pregrasp + np.array([0.15, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        sim.track(Trajectory(np.array([0.0, 1.5, 3.0]), np.stack([sel.q_pregrasp, q_near, sel.q_pregrasp])), 1.0)
        assert sim.touching("target") == 0
        assert np.linalg.norm(sim.body_pos("target") - p0) < 1e-3
    finally:
        world.close()


def test_a_side_grasp_on_a_can_lifts_it_and_holds_it_still():
    world = World(can_scene())
    try:
        o = execute_grasp(world, side_grasp())
    finally:
        world.close()
    assert o.failure is None, (o.failure, o.collisions, o.lift_height, o.hold_height)
    assert 0.062 < o.finger_width < 0.066  # closed on the 6.4 cm can
    assert o.lift_height > 0.095
    assert abs(o.hold_height - o.lift_height) < 1e-3  # no creep during the 2 s hold
    by_phase = {p.phase: p for p in o.phases}
    assert [p.phase for p in o.phases] == ["transfer", "approach", "close", "lift", "hold"]
    assert by_phase["transfer"].moved < 1e-3 and by_phase["approach"].moved < 2e-3  # not pushed before closing
    assert by_phase["close"].pads == 2 and by_phase["hold"].pads == 2
    assert by_phase["transfer"].touched_by == ()
    assert set(by_phase["hold"].touched_by) == {"hand/panda_leftfinger_collision", "hand/panda_rightfinger_collision"}


def test_an_arm_pressing_on_a_board_is_a_collision_however_shallow():
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.85, 0.3, 0.80), shelves=(0.54,))  # board 0.52-0.54 m: stops the lift
    scene = SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=can_scene().target)
    sel = side_grasp()
    sel.path = sel.q_pregrasp[None]  # start at the pre-grasp, under the board
    world = World(scene)
    try:
        by_force = execute_grasp(world, sel, config=GraspExecConfig(contact_depth=1.0))  # depth never counts
        ignored = execute_grasp(world, sel, config=GraspExecConfig(contact_depth=1.0, contact_force=1e9))
    finally:
        world.close()
    assert by_force.failure is ExecFailure.COLLISION
    assert any(c.phase == "lift" and c.other_geom == "cab_shelf0" for c in by_force.collisions)
    assert ignored.failure is not ExecFailure.COLLISION and not ignored.collisions
    assert ignored.lift_height < 0.07  # the board held the hand down


def test_fingers_closed_narrower_than_min_width_are_a_miss():
    world = World(can_scene())
    try:  # the 6.4 cm can is held, but a hand that expects >= 7 cm between its fingers calls it a miss
        o = execute_grasp(world, side_grasp(), config=GraspExecConfig(min_width=0.07))
    finally:
        world.close()
    assert o.failure is ExecFailure.MISSED and 0.062 < o.finger_width < 0.066


@pytest.mark.parametrize("bad", [{"contact_force": -1.0}, {"contact_depth": -0.001}, {"min_width": -0.01}])
def test_negative_contact_thresholds_are_refused(bad):
    with pytest.raises(CompassInputError, match="contact"):
        GraspExecConfig(**bad)
