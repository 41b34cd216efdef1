"""Physics mode: position-controlled arm and gripper for grasping and lifting.

The arm tracks joint targets with the position actuators of `robot.model`; the hand's
tendon actuator takes 0 (closed) .. 1 (open, 0.08 m). Movable scene objects are free
bodies, so a grasp either holds the target or it slips.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..robot.model import GRIPPER_MAX_WIDTH
from ..types import Trajectory
from .executor import check_trajectory, interpolate
from .world import World


@dataclass(frozen=True)
class GraspOutcome:
    """Result of a physical grasp-and-lift.

    lifted: the target rose by at least `min_lift` [m] and is still between the fingers;
    lift_height [m] of the target's centre; finger_width [m] after closing; t [s] of
    simulated time used.
    """

    lifted: bool
    lift_height: float
    finger_width: float
    target_in_hand: bool
    t: float


class PhysicsSession:
    """Steps a copy of the world's model state with actuators (2 ms timestep)."""

    def __init__(self, world: World, q: np.ndarray | None = None, gripper_open: float = 1.0):
        self.world = world
        self.model = world.model
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._arm_act = np.array([m.actuator(f"arm{i + 1}").id for i in range(7)])
        self._hand_act = m.actuator("hand/panda_hand_actuator").id
        self._fingers = [m.jnt_qposadr[m.joint(f"hand/panda_finger_joint{i}").id] for i in (1, 2)]
        self._finger_geoms = {m.geom("hand/panda_leftfinger_collision").id, m.geom("hand/panda_rightfinger_collision").id}
        q = world.q if q is None else np.asarray(q, dtype=float)
        self.data.qpos[:7] = q
        for a in self._fingers:
            self.data.qpos[a] = GRIPPER_MAX_WIDTH / 2 * gripper_open
        self.data.ctrl[self._arm_act] = q
        self.data.ctrl[self._hand_act] = gripper_open
        mujoco.mj_forward(self.model, self.data)
        self.t = 0.0

    def step(self, duration: float) -> None:
        """Advance the simulation by `duration` [s] with the current controls."""
        n = max(1, int(round(duration / self.model.opt.timestep)))
        mujoco.mj_step(self.model, self.data, nstep=n)
        self.t += n * self.model.opt.timestep

    def track(self, traj: Trajectory, settle: float = 0.3) -> None:
        """Follow a timed joint trajectory with the position actuators, then settle [s]."""
        traj = check_trajectory(traj)
        dt = self.model.opt.timestep
        ts = np.arange(traj.t[0], traj.t[-1] + dt / 2, dt)
        qs = interpolate(traj, ts)
        for q in qs:
            self.data.ctrl[self._arm_act] = q
            mujoco.mj_step(self.model, self.data)
        self.t += len(qs) * dt
        self.step(settle)

    def set_gripper(self, open_fraction: float, duration: float = 0.6) -> None:
        """Command the gripper (0 closed .. 1 open) and let it move for `duration` [s]."""
        self.data.ctrl[self._hand_act] = float(np.clip(open_fraction, 0.0, 1.0))
        self.step(duration)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[:7].copy()

    @property
    def finger_width(self) -> float:
        """Distance between the fingers [m]."""
        return float(sum(self.data.qpos[a] for a in self._fingers))

    def body_pos(self, name: str) -> np.ndarray:
        return self.data.xpos[self.model.body(name).id].copy()

    def touching(self, geom_names) -> int:
        """Number of finger pads in contact with a geom (name) or any of several geoms."""
        names = [geom_names] if isinstance(geom_names, str) else list(geom_names)
        geoms = {self.model.geom(n).id for n in names}
        pads = set()
        for i in range(self.data.ncon):
            c = self.data.contact[i]
            pair = {int(c.geom1), int(c.geom2)}
            if pair & geoms:
                pads |= pair & self._finger_geoms
        return len(pads)


def grasp_and_lift(world: World, q_pregrasp: np.ndarray, approach: Trajectory, lift: Trajectory,
                   min_lift: float = 0.03) -> GraspOutcome:
    """Start open at q_pregrasp, follow `approach`, close the gripper, follow `lift`.

    The target counts as lifted when its centre rose by >= min_lift [m] and both finger
    pads still touch it.
    """
    name = world.scene.target.name
    sim = PhysicsSession(world, q_pregrasp, gripper_open=1.0)
    sim.step(0.2)
    z0 = sim.body_pos(name)[2]
    sim.track(approach)
    sim.set_gripper(0.0, duration=0.8)
    width = sim.finger_width
    sim.track(lift, settle=0.5)
    dz = float(sim.body_pos(name)[2] - z0)
    in_hand = sim.touching([p.name for p in world.scene.target.parts]) == 2
    return GraspOutcome(bool(dz >= min_lift and in_hand), dz, width, in_hand, sim.t)
