"""Executing a selected grasp in the physics mode of the World: move to the pre-grasp,
approach along the gripper's z, close, lift, hold, with ground-truth collision monitoring.

Reuses `physics.PhysicsSession` (position-controlled arm and tendon gripper) as it is; the
phase-by-phase tracking with contact monitoring lives here. A collision is any penetrating
contact (deeper than `contact_depth`) of a robot geom with a geom other than the target (the
base resting on the floor excepted), or a shallower one that pushes with more than
`contact_force` (an arm pressing on a board at 0.2 mm with 60-80 N is a collision too).
Success: the target rose by at least `min_lift_fraction` of the commanded lift (the
selection's `lift_height`) after the lift and after the hold, both finger pads still touch
it after the hold, and nothing but the target was touched. `GraspOutcome.phases` records
where the target was at the end of each phase and what touched it.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import mujoco
import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..motion.timing import TimingConfig, time_parameterize
from ..types import Trajectory
from .executor import check_trajectory, interpolate
from .physics import PhysicsSession
from .world import World


class ExecFailure(Enum):
    """Why a grasp-and-lift failed in physics."""

    NOT_SELECTED = "no grasp was selected"
    COLLISION = "the arm touched something other than the target"
    MISSED = "the fingers closed without holding the target"
    SLIP = "the target did not rise with the hand"
    DROP = "the target was lifted but lost during the hold"


@dataclass(frozen=True)
class GraspExecConfig:
    """velocity_scale of the Panda limits to the pre-grasp, approach_scale for the approach
    and lift; close_time / hold_time [s]; min_lift_fraction of the selection's commanded
    lift the target must rise (after the lift and after the hold) for success; contact_depth
    [m]: penetration counted as a collision, contact_force [N]: normal force of a shallower
    contact counted as one; min_width [m]: fingers closed narrower than this hold nothing (a
    miss even if both pads graze the target, e.g. on a can's rim; the thinnest part grasped
    here, a bottle's neck, is 2.2 cm); check_every physics steps between contact checks;
    settle [s] after each motion."""

    velocity_scale: float = 0.5
    approach_scale: float = 0.15
    close_time: float = 1.0
    hold_time: float = 2.0
    min_lift_fraction: float = 0.7
    contact_depth: float = 0.0005
    contact_force: float = 1.0
    min_width: float = 0.005
    check_every: int = 5
    settle: float = 0.3

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        for k in ("velocity_scale", "approach_scale"):
            v = getattr(self, k)
            if not 0.0 < v <= 1.0:
                raise CompassInputError(f"GraspExecConfig.{k} = {v} is not allowed; use (0, 1]")
        if not (self.close_time > 0 and self.hold_time >= 0 and 0.0 < self.min_lift_fraction <= 1.0
                and self.check_every >= 1 and self.contact_depth >= 0 and self.contact_force >= 0
                and self.min_width >= 0):
            raise CompassInputError("close_time > 0, hold_time >= 0, 0 < min_lift_fraction <= 1, check_every >= 1, "
                                    "contact_depth >= 0, contact_force >= 0 and min_width >= 0 are required")
        check_ranges(self, close_time=(0.0, 60.0, "s"), hold_time=(0.0, 60.0, "s"), settle=(0.0, 60.0, "s"),
                     min_width=(0.0, 0.08, "m"))  # huge contact_depth / contact_force: never counted


@dataclass(frozen=True)
class Collision:
    phase: str       # "transfer", "approach", "close", "lift", "hold"
    robot_geom: str
    other_geom: str
    depth: float     # [m]


@dataclass(frozen=True)
class PhaseTrace:
    """The target at the end of one phase: its position [m] (world), its displacement [m]
    from where it stood before the transfer, the finger pads touching it (0-2) and the
    robot geoms that touched it during the phase (names, sorted)."""

    phase: str
    target_pos: tuple[float, float, float]
    moved: float
    pads: int
    touched_by: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class GraspOutcome:
    """lift_height [m] of the target after the lift, hold_height [m] after the hold;
    finger_width [m] after closing; held: both pads touch the target at the end; collisions
    (first per geom pair); t [s] simulated; failure None on success; phases: the target at
    the end of the transfer, approach, close, lift and hold (`PhaseTrace`)."""

    lift_height: float
    hold_height: float
    finger_width: float
    held: bool
    collisions: tuple[Collision, ...]
    t: float
    failure: ExecFailure | None
    phases: tuple[PhaseTrace, ...] = ()

    @property
    def success(self) -> bool:
        return self.failure is None


class _Monitor:
    def __init__(self, world: World, sim: PhysicsSession, depth: float, force: float):
        m = world.model
        self.world, self.sim, self.depth, self.force = world, sim, depth, force
        self._f = np.zeros(6)
        self.robot = world.is_robot_geom
        self.skip = {int(g) for g in world.target_geoms}
        self.floor, self.base = m.geom("floor").id, m.geom("link0").id
        self.seen: dict[tuple[int, int], Collision] = {}
        self.touches: dict[str, set[str]] = {}  # phase -> robot geoms that touched the target

    def check(self, phase: str) -> None:
        d = self.sim.data
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            r1, r2 = self.robot[g1], self.robot[g2]
            if r1 == r2:
                continue
            rg, og = (g1, g2) if r1 else (g2, g1)
            if og in self.skip:
                if c.dist < 0:
                    self.touches.setdefault(phase, set()).add(self.world._geom_name(rg))
                continue
            if c.dist >= 0 or (rg == self.base and og == self.floor):
                continue
            if c.dist > -self.depth:  # shallow: a collision only if it pushes
                mujoco.mj_contactForce(self.sim.model, d, i, self._f)
                if self._f[0] <= self.force:
                    continue
            if (rg, og) not in self.seen:
                self.seen[(rg, og)] = Collision(phase, self.world._geom_name(rg), self.world._geom_name(og),
                                                float(-c.dist))


def _run(sim: PhysicsSession, mon: _Monitor, traj: Trajectory | None, phase: str, duration: float,
         every: int) -> None:
    """Track traj (or hold the controls for duration [s]), checking contacts every few steps."""
    m, d = sim.model, sim.data
    dt = m.opt.timestep
    if traj is not None:
        traj = check_trajectory(traj)
        ts = np.arange(traj.t[0], traj.t[-1] + dt / 2, dt)
        qs = interpolate(traj, ts)
    else:
        qs = [None] * max(1, int(round(duration / dt)))
    for k, q in enumerate(qs):
        if q is not None:
            d.ctrl[sim._arm_act] = q
        mujoco.mj_step(m, d)
        if k % every == 0:
            mon.check(phase)
    sim.t += len(qs) * dt


def _timed(path: np.ndarray, scale: float) -> Trajectory:
    return time_parameterize(np.asarray(path, dtype=np.float64),
                             TimingConfig(velocity_scale=scale, acceleration_scale=scale, jerk_scale=scale))


def execute_grasp(world: World, selection, q_start: np.ndarray | None = None,
                  config: GraspExecConfig | None = None) -> GraspOutcome:
    """Execute a `grasp.select.GraspSelection` in physics from q_start (default: the start
    of its path): transfer along its path to the pre-grasp, approach, close, lift, hold."""
    config = config or GraspExecConfig()
    if selection is None or selection.failure is not None or selection.q_grasp is None:
        return GraspOutcome(0.0, 0.0, 0.0, False, (), 0.0, ExecFailure.NOT_SELECTED)
    path = np.asarray(selection.path, dtype=np.float64)
    q0 = path[0] if q_start is None else np.asarray(q_start, dtype=np.float64)
    sim = PhysicsSession(world, q0, gripper_open=1.0)
    mon = _Monitor(world, sim, config.contact_depth, config.contact_force)
    name = world.scene.target.name
    parts = [world.model.geom(int(g)).name for g in world.target_geoms]  # the target's geoms
    every = config.check_every
    _run(sim, mon, None, "transfer", 0.2, every)
    p0 = sim.body_pos(name)
    z0 = p0[2]
    phases: list[PhaseTrace] = []

    def trace(phase: str) -> None:
        p = sim.body_pos(name)
        phases.append(PhaseTrace(phase, tuple(float(v) for v in p), float(np.linalg.norm(p - p0)),
                                 sim.touching(parts), tuple(sorted(mon.touches.get(phase, ())))))

    if len(path) > 1:
        _run(sim, mon, _timed(path, config.velocity_scale), "transfer", 0.0, every)
    _run(sim, mon, None, "transfer", config.settle, every)
    trace("transfer")
    _run(sim, mon, _timed(np.stack([selection.q_pregrasp, selection.q_grasp]), config.approach_scale),
         "approach", 0.0, every)
    _run(sim, mon, None, "approach", config.settle, every)
    trace("approach")
    sim.data.ctrl[sim._hand_act] = 0.0
    _run(sim, mon, None, "close", config.close_time, every)
    trace("close")
    width = sim.finger_width
    grasped = sim.touching(parts) == 2 and width >= config.min_width
    _run(sim, mon, _timed(np.stack([selection.q_grasp, selection.q_lift]), config.approach_scale),
         "lift", 0.0, every)
    _run(sim, mon, None, "lift", config.settle, every)
    trace("lift")
    lift = float(sim.body_pos(name)[2] - z0)
    _run(sim, mon, None, "hold", config.hold_time, every)
    trace("hold")
    hold = float(sim.body_pos(name)[2] - z0)
    held = sim.touching(parts) == 2
    collisions = tuple(mon.seen.values())
    need = config.min_lift_fraction * float(getattr(selection, "lift_height", 0.0) or 0.1)
    if collisions:
        failure = ExecFailure.COLLISION
    elif not grasped:
        failure = ExecFailure.MISSED
    elif lift < need:
        failure = ExecFailure.SLIP
    elif hold < need or not held:
        failure = ExecFailure.DROP
    else:
        failure = None
    return GraspOutcome(lift, hold, width, held, collisions, sim.t, failure, tuple(phases))
