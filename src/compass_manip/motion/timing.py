"""Time parameterisation of joint paths and path lengths.

A planned path is a polyline in joint space whose straight segments were checked for
collisions, so the trajectory must stay on those segments. Each segment is timed with
`ruckig` from rest to rest with phase synchronisation: all joints share one normalised
jerk-limited profile, so the arm moves along the straight segment and stops at every
waypoint. Limits are the Panda's datasheet velocity [rad/s], acceleration [rad/s^2] and
jerk [rad/s^3] limits (robot/model.py), optionally scaled down.
"""
from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, real_number
from ..robot.kinematics import check_Q
from ..robot.model import N_ARM_JOINTS, QD_MAX, QDD_MAX, QDDD_MAX
from ..types import Trajectory


@dataclass(frozen=True)
class TimingConfig:
    """Scaling of the Panda limits (0 < scale <= 1) and the sampling step dt [s]."""

    velocity_scale: float = 1.0
    acceleration_scale: float = 1.0
    jerk_scale: float = 1.0
    dt: float = 0.004

    def __post_init__(self) -> None:
        for name in ("velocity_scale", "acceleration_scale", "jerk_scale", "dt"):
            real_number(getattr(self, name), f"TimingConfig.{name}")
        for name in ("velocity_scale", "acceleration_scale", "jerk_scale"):
            v = getattr(self, name)
            if not (math.isfinite(float(v)) and 0.0 < v <= 1.0):
                raise CompassInputError(f"TimingConfig.{name} = {v} is not allowed; use 0 < scale <= 1")
        if not (math.isfinite(float(self.dt)) and 1e-4 <= self.dt <= 0.1):
            raise CompassInputError(f"TimingConfig.dt = {self.dt} s is not allowed; use 1e-4..0.1 s")


def _check_path(path: np.ndarray, within_limits: bool = False) -> np.ndarray:
    """path as float64 (n>=1, 7) [rad], finite; with within_limits, inside the Panda's joint
    limits (a path to be timed and executed on the arm)."""
    try:
        path = np.asarray(path, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"path must be an (n, 7) array of joint angles [rad], got {path!r:.80}") from exc
    if path.ndim != 2 or path.shape[1] != N_ARM_JOINTS or path.shape[0] < 1:
        raise CompassInputError(f"path must have shape (n>=1, 7) [rad], got {path.shape}")
    if not np.all(np.isfinite(path)):
        raise CompassInputError("path contains NaN or inf joint angles")
    if within_limits:
        check_Q(path, "path")
    return path


#: Most states `densify` returns (a guard against paths in the wrong unit, e.g. degrees).
MAX_DENSE_STATES = 10_000_000


def _segments(path: np.ndarray, config: TimingConfig) -> tuple[np.ndarray, list]:
    """Waypoints without consecutive duplicates and one ruckig trajectory per segment."""
    from ruckig import InputParameter, Result, Ruckig, Synchronization
    from ruckig import Trajectory as RuckigTrajectory

    path = _check_path(path, within_limits=True)
    keep = np.ones(len(path), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(path, axis=0)) > 1e-12, axis=1)
    wps = path[keep]
    otg = Ruckig(N_ARM_JOINTS)
    inp = InputParameter(N_ARM_JOINTS)
    inp.max_velocity = (QD_MAX * config.velocity_scale).tolist()
    inp.max_acceleration = (QDD_MAX * config.acceleration_scale).tolist()
    inp.max_jerk = (QDDD_MAX * config.jerk_scale).tolist()
    inp.synchronization = Synchronization.Phase
    zero = [0.0] * N_ARM_JOINTS
    inp.current_velocity = zero
    inp.current_acceleration = zero
    inp.target_velocity = zero
    inp.target_acceleration = zero
    segments = []
    for a, b in zip(wps[:-1], wps[1:]):
        inp.current_position = a.tolist()
        inp.target_position = b.tolist()
        traj = RuckigTrajectory(N_ARM_JOINTS)
        try:
            result = otg.calculate(inp, traj)
        except (ValueError, RuntimeError) as exc:  # ruckig reports some failures as unknown codes
            raise CompassInputError(f"ruckig could not time the segment {a} -> {b} [rad]: {exc}") from exc
        if result not in (Result.Working, Result.Finished):
            raise CompassInputError(f"ruckig could not time the segment {a} -> {b}: {result}")
        segments.append(traj)
    return wps, segments


def segment_durations(path: np.ndarray, config: TimingConfig | None = None) -> np.ndarray:
    """Duration [s] of each rest-to-rest segment between distinct consecutive waypoints."""
    _, segments = _segments(path, config or TimingConfig())
    return np.array([s.duration for s in segments])


def time_parameterize(path: np.ndarray, config: TimingConfig | None = None) -> Trajectory:
    """Time a joint path (n,7) [rad] rest-to-rest through every waypoint with ruckig.

    Consecutive duplicate waypoints are merged. Returns a `Trajectory` sampled every
    `config.dt` seconds (or less) within each segment and exactly at every waypoint, so
    its duration [s] is the sum of `segment_durations`.
    """
    config = config or TimingConfig()
    wps, segments = _segments(path, config)
    ts, qs, t_end = [np.zeros(1)], [wps[:1]], 0.0
    for traj, b in zip(segments, wps[1:]):
        T = traj.duration
        n = max(1, int(np.ceil(T / config.dt - 1e-9)))
        tau = np.linspace(0.0, T, n + 1)[1:]
        q_seg = np.array([traj.at_time(float(tk))[0] for tk in tau]).reshape(n, N_ARM_JOINTS)
        q_seg[-1] = b  # land exactly on the waypoint
        ts.append(t_end + tau)
        qs.append(q_seg)
        t_end += T
    return Trajectory(t=np.concatenate(ts), q=np.concatenate(qs))


def joint_path_length(path: np.ndarray) -> float:
    """Sum of Euclidean joint-space segment lengths of a path (n,7) [rad]."""
    path = _check_path(path)
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))


def densify(path: np.ndarray, max_step: float) -> np.ndarray:
    """Insert states along each straight segment so no joint moves more than max_step [rad]."""
    path = _check_path(path)
    max_step = real_number(max_step, "max_step", "a finite step > 0 [rad]")
    if not max_step > 0.0:
        raise CompassInputError(f"max_step = {max_step} rad is not allowed; use > 0")
    steps = np.maximum(1, np.ceil(np.max(np.abs(np.diff(path, axis=0)), axis=1, initial=0.0) / max_step))
    if steps.sum() > MAX_DENSE_STATES:
        raise CompassInputError(f"densify would create {steps.sum():.3g} states (max_step {max_step} rad); at most "
                                f"{MAX_DENSE_STATES}: is the path in radians?")
    out = [path[:1]]
    for a, b, n in zip(path[:-1], path[1:], steps.astype(np.int64)):
        s = np.linspace(0.0, 1.0, n + 1)[1:, None]
        out.append(a + s * (b - a))
    return np.concatenate(out)


def ee_path_length(path: np.ndarray, kinematics, max_step: float = 0.01) -> float:
    """Length [m] of the TCP's trace along a joint path (n,7) [rad].

    `kinematics` is a `PandaKinematics` (batch `T_world_tcp_batch(Q (m,7)) -> (m,4,4)`).
    Segments are densified to `max_step` [rad] per joint because the TCP moves on a curve
    between waypoints.
    """
    Q = densify(path, max_step)
    T = np.asarray(kinematics.T_world_tcp_batch(Q))
    p = T[..., :3, 3].reshape(-1, 3)
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
