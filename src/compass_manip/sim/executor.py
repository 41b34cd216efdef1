"""Kinematic execution of timed joint trajectories with ground-truth contact checks.

The arm follows the trajectory exactly (no dynamics); every `check_step` [rad] of joint
motion the robot is tested against the scene with MuJoCo's collision detection, and camera
frames are rendered at `frame_rate` [Hz] of simulated time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError
from ..robot.model import check_q
from ..types import Frame, Trajectory
from .world import Contact, World


@dataclass(frozen=True)
class ExecutorConfig:
    """frame_rate [Hz] of camera frames along the motion (0 = none); check_step [rad]
    largest joint step between two collision checks; stop_on_contact ends the motion at the
    first contact (the arm stays at the last contact-free state)."""

    frame_rate: float = 5.0
    check_step: float = 0.005
    stop_on_contact: bool = True
    include_self: bool = True
    render_rgb: bool = True
    render_seg: bool = True
    raycast_depth: bool = False

    def __post_init__(self) -> None:
        if not (self.frame_rate >= 0 and np.isfinite(self.frame_rate)):
            raise CompassInputError(f"frame_rate {self.frame_rate} Hz is not allowed; use a finite value >= 0")
        if not (0 < self.check_step <= 0.5):
            raise CompassInputError(f"check_step {self.check_step} rad is not allowed; use 0 < step <= 0.5")


@dataclass(frozen=True)
class TimedContact:
    t: float  # simulated time [s]
    q: np.ndarray  # configuration [rad] at which the contact was found
    contact: Contact


@dataclass(frozen=True, eq=False)
class ExecutionResult:
    """completed: the whole trajectory ran; t_end [s] and q_end [rad] where the arm stopped."""

    completed: bool
    t_end: float
    q_end: np.ndarray
    contacts: tuple[TimedContact, ...]
    frames: tuple[Frame, ...]


def check_trajectory(traj: Trajectory) -> Trajectory:
    t = np.asarray(traj.t, dtype=float)
    q = np.asarray(traj.q, dtype=float)
    if t.ndim != 1 or q.ndim != 2 or q.shape != (len(t), 7) or len(t) < 1:
        raise CompassInputError(f"trajectory needs t (n,) and q (n, 7) with n >= 1, got {t.shape} and {q.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise CompassInputError("trajectory times must be finite and strictly increasing")
    for i, qi in enumerate(q):
        check_q(qi, name=f"trajectory q[{i}]")
    return Trajectory(t=t, q=q)


def sample_times(traj: Trajectory, check_step: float) -> np.ndarray:
    """Times [s] at which the trajectory moves at most `check_step` [rad] per joint between samples."""
    ts = [traj.t[:1]]
    for i in range(len(traj.t) - 1):
        n = max(1, int(np.ceil(np.max(np.abs(traj.q[i + 1] - traj.q[i])) / check_step)))
        ts.append(np.linspace(traj.t[i], traj.t[i + 1], n + 1)[1:])
    return np.concatenate(ts)


def interpolate(traj: Trajectory, t: np.ndarray) -> np.ndarray:
    """Joint positions (len(t), 7) [rad] by linear interpolation between trajectory samples."""
    return np.stack([np.interp(t, traj.t, traj.q[:, j]) for j in range(traj.q.shape[1])], axis=1)


def execute(world: World, traj: Trajectory, cfg: ExecutorConfig | None = None, t0: float = 0.0,
            finger_width: float | None = None) -> ExecutionResult:
    """Move the arm along `traj` (times relative to its first sample, offset by t0 [s]).

    Reports every ground-truth robot-scene (and self) contact; with stop_on_contact the
    arm halts at the last contact-free sample.
    """
    cfg = cfg or ExecutorConfig()
    traj = check_trajectory(traj)
    ts = sample_times(traj, cfg.check_step)
    qs = interpolate(traj, ts)
    period = 1.0 / cfg.frame_rate if cfg.frame_rate > 0 else np.inf
    next_frame = traj.t[0] + period
    contacts: list[TimedContact] = []
    frames: list[Frame] = []
    q_last_free = qs[0]
    t_last = traj.t[0]
    completed = True
    for t, q in zip(ts, qs):
        found = world.contacts(q, finger_width, include_self=cfg.include_self)
        if found:
            contacts.extend(TimedContact(float(t - traj.t[0] + t0), q.copy(), c) for c in found)
            if cfg.stop_on_contact:
                completed = False
                break
        else:
            q_last_free = q
        t_last = t
        while t >= next_frame - 1e-9:
            q_frame = interpolate(traj, np.array([next_frame]))[0]
            frames.append(_frame(world, q_frame, next_frame - traj.t[0] + t0, cfg))
            next_frame += period
    q_end = q_last_free if not completed else qs[-1]
    world.set_q(q_end, finger_width)
    return ExecutionResult(completed, float(t_last - traj.t[0] + t0), q_end.copy(), tuple(contacts), tuple(frames))


def _frame(world: World, q: np.ndarray, t: float, cfg: ExecutorConfig) -> Frame:
    world.set_q(q)
    return world.render(t=t, rgb=cfg.render_rgb, seg=cfg.render_seg, raycast=cfg.raycast_depth)
