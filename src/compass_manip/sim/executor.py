"""Kinematic execution of timed joint trajectories with ground-truth contact checks.

The arm follows the trajectory exactly (no dynamics); every `check_step` [rad] of joint
motion the robot is tested against the scene with MuJoCo's collision detection, and camera
frames are rendered at `frame_rate` [Hz] of simulated time (with `advance`, the samples that
the clearance at a tested sample proves contact-free are not tested: `sim.advance`; the
reported contacts are those of a test at every sample), or, with a `KeyframeRule`, at
the contact-check samples where the camera has moved or turned enough since the last frame
(`sim.keyframes`; the motion's start pose is the first reference, its last sample is left
to the caller, which renders the end of every motion).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, real_number
from ..robot.kinematics import MAX_FINGER_WIDTH
from ..robot.model import Q_MAX, Q_MIN, check_q
from ..types import Frame, Trajectory
from .advance import AdvanceConfig, MotionBound, clearance_model
from .keyframes import KeyframeRule, KeyframeTracker
from .world import Contact, World


@dataclass(frozen=True)
class ExecutorConfig:
    """frame_rate [Hz] of camera frames along the motion (0 = none); check_step [rad]
    largest joint step between two collision checks; stop_on_contact ends the motion at the
    first contact (the arm stays at the last contact-free state); keyframes: a
    `KeyframeRule` that replaces frame_rate (None: frames at frame_rate); advance: the
    conservative advancement of the contact checks (`sim.advance`; None: a test at every
    sample, the same contacts)."""

    frame_rate: float = 5.0
    check_step: float = 0.005
    stop_on_contact: bool = True
    include_self: bool = True
    render_rgb: bool = True
    render_seg: bool = True
    raycast_depth: bool = False
    keyframes: KeyframeRule | None = None
    advance: AdvanceConfig | None = None

    def __post_init__(self) -> None:
        if self.advance is not None and not isinstance(self.advance, AdvanceConfig):
            raise CompassInputError(f"ExecutorConfig.advance = {self.advance!r:.40} is not allowed; "
                                    "use an AdvanceConfig or None")
        if self.keyframes is not None and not isinstance(self.keyframes, KeyframeRule):
            raise CompassInputError(f"ExecutorConfig.keyframes = {self.keyframes!r:.40} is not allowed; "
                                    "use a KeyframeRule or None")
        rate = real_number(self.frame_rate, "ExecutorConfig.frame_rate", "a finite value 0..1000 Hz")
        if not 0.0 <= rate <= 1000.0:
            raise CompassInputError(f"frame_rate {self.frame_rate} Hz is not allowed; use a finite value 0..1000 Hz")
        step = real_number(self.check_step, "ExecutorConfig.check_step", "1e-4..0.5 rad")
        if not (1e-4 <= step <= 0.5):
            raise CompassInputError(f"check_step {self.check_step} rad is not allowed; use 1e-4..0.5 rad")
        for name in ("stop_on_contact", "include_self", "render_rgb", "render_seg", "raycast_depth"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise CompassInputError(f"ExecutorConfig.{name} = {getattr(self, name)!r:.40} is not allowed; "
                                        "use True or False")


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
    """traj with float t (n,) [s] and q (n, 7) [rad], or CompassInputError: n >= 1, times
    finite and strictly increasing, every q finite and within the joint limits."""
    try:
        t = np.asarray(traj.t, dtype=float)
        q = np.asarray(traj.q, dtype=float)
    except AttributeError as exc:
        raise CompassInputError(f"trajectory {traj!r:.60} is not a Trajectory (needs t and q)") from exc
    except (TypeError, ValueError) as exc:
        raise CompassInputError("trajectory t and q must be arrays of numbers ([s], [rad])") from exc
    if t.ndim != 1 or q.ndim != 2 or q.shape != (len(t), 7) or len(t) < 1:
        raise CompassInputError(f"trajectory needs t (n,) and q (n, 7) with n >= 1, got {t.shape} and {q.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise CompassInputError("trajectory times must be finite and strictly increasing")
    ok = np.all((q >= Q_MIN - 1e-9) & (q <= Q_MAX + 1e-9), axis=1)  # NaN fails too
    for i in np.flatnonzero(~ok)[:1]:
        check_q(q[i], name=f"trajectory q[{i}]")  # raises, naming the first bad sample
    return Trajectory(t=t, q=q)


def sample_times(traj: Trajectory, check_step: float) -> np.ndarray:
    """Times [s] at which the trajectory moves at most `check_step` [rad] per joint between
    samples: each segment's `np.linspace(t_i, t_i+1, n + 1)[1:]` (the same numbers), for all
    segments at once."""
    t = np.asarray(traj.t, dtype=float)
    if len(t) < 2:
        return t[:1].copy()
    n = np.maximum(1, np.ceil(np.max(np.abs(np.diff(traj.q, axis=0)), axis=1) / check_step).astype(np.int64))
    seg = np.repeat(np.arange(len(n)), n)
    k = (np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n) + 1).astype(float)
    step = (t[1:] - t[:-1]) / n  # linspace: k * (delta / div) + start, the end point exact
    out = k * step[seg] + t[:-1][seg]
    out[np.cumsum(n) - 1] = t[1:]
    return np.concatenate([t[:1], out])


def interpolate(traj: Trajectory, t: np.ndarray) -> np.ndarray:
    """Joint positions (len(t), 7) [rad] by linear interpolation between trajectory samples."""
    return np.stack([np.interp(t, traj.t, traj.q[:, j]) for j in range(traj.q.shape[1])], axis=1)


def execute(world: World, traj: Trajectory, config: ExecutorConfig | None = None, t0: float = 0.0,
            finger_width: float | None = None) -> ExecutionResult:
    """Move the arm along `traj` (times relative to its first sample, offset by t0 [s]).

    Reports every ground-truth robot-scene (and self) contact; with stop_on_contact the
    arm halts at the last contact-free sample. Bad input (config, trajectory, a non-finite
    t0, a finger_width outside 0..MAX_FINGER_WIDTH m) raises CompassInputError before the
    world is touched.
    """
    config = ExecutorConfig() if config is None else config
    if not isinstance(config, ExecutorConfig):
        raise CompassInputError(f"config {config!r:.60} is not allowed; give an ExecutorConfig or None")
    t0 = real_number(t0, "t0", "a finite start time [s]")
    if finger_width is not None:
        finger_width = real_number(finger_width, "finger_width", f"0..{MAX_FINGER_WIDTH} m or None")
        if not 0.0 <= finger_width <= MAX_FINGER_WIDTH:
            raise CompassInputError(f"finger_width {finger_width} m is not allowed; use 0..{MAX_FINGER_WIDTH} m or None")
    traj = check_trajectory(traj)
    ts = sample_times(traj, config.check_step)
    qs = interpolate(traj, ts)
    keyframes = None
    if config.keyframes is not None:
        world.set_q(qs[0], finger_width)
        keyframes = KeyframeTracker(config.keyframes, traj.t[0], world.T_world_cam())
    period = 1.0 / config.frame_rate if config.frame_rate > 0 and keyframes is None else np.inf
    next_frame = traj.t[0] + period
    contacts: list[TimedContact] = []
    frames: list[Frame] = []
    q_last_free = qs[0]
    t_last = traj.t[0]
    completed = True
    bound = None
    if config.advance is not None and len(ts) > 2:
        world.set_q(qs[0], finger_width)  # the fingers' state sets the geoms' motion rates
        bound = MotionBound(clearance_model(world, config.include_self, config.advance), qs)
    proven, next_try, backoff = -1, 0, 1  # samples <= proven are contact-free, proven untested
    for k, (t, q) in enumerate(zip(ts, qs)):
        if k <= proven:
            found = []
            if keyframes is not None:
                world.set_q(q, finger_width)
        else:
            found = world.contacts(q, finger_width, include_self=config.include_self)
            if not found and bound is not None and next_try <= k < len(ts) - 1:
                proven = bound.proven_until(k)
                if proven > k:
                    backoff = 1
                else:  # close to something: test the next samples one by one for a while
                    next_try, backoff = k + backoff, min(2 * backoff, config.advance.backoff_max)
        if found:
            contacts.extend(TimedContact(float(t - traj.t[0] + t0), q.copy(), c) for c in found)
            if config.stop_on_contact:
                completed = False
                break
        else:
            q_last_free = q
        t_last = t
        if keyframes is not None and t < traj.t[-1] and keyframes.due(t, world.T_world_cam()):
            frames.append(world.render(t=t - traj.t[0] + t0, rgb=config.render_rgb, seg=config.render_seg,
                                       raycast=config.raycast_depth))
        while t >= next_frame - 1e-9:
            q_frame = interpolate(traj, np.array([next_frame]))[0]
            frames.append(_frame(world, q_frame, next_frame - traj.t[0] + t0, config))
            next_frame += period
    q_end = q_last_free if not completed else qs[-1]
    world.set_q(q_end, finger_width)
    return ExecutionResult(completed, float(t_last - traj.t[0] + t0), q_end.copy(), tuple(contacts), tuple(frames))


def _frame(world: World, q: np.ndarray, t: float, config: ExecutorConfig) -> Frame:
    world.set_q(q)
    return world.render(t=t, rgb=config.render_rgb, seg=config.render_seg, raycast=config.raycast_depth)
