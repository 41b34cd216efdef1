"""Near-Field Awareness scan (paper Sec. III-B-1): body joints held, wrist joints sampled,
greedy choice of the wrist configuration that sees the most still-unknown volume of a
safety box Omega_safe around the base and arm, until the gain falls below a threshold.

Our variant re-runs the greedy step on the map after each executed view (the paper
computes all waypoints up front from the initial map and a virtual coverage update): the
real observations replace the virtual update, and each move is validated on the map as it
is then, so the wrist only enters space it has seen or occupied.

Candidates are reachable by construction, as MUE-RRT's nodes are: each sampled wrist
configuration is pulled back along its straight joint segment from the current
configuration to the last state before the first invalid one (an RRT extend towards the
sample), and the gain is scored on these reachable candidates. The chosen one is then
re-checked as the plan (counted for MPSR); a sample behind unseen space no longer becomes
a committed view whose motion fails.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..mapping.self_occlusion import robot_view_gains
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..robot.model import Q_MAX, Q_MIN

#: Joints 5-7 (0-based 4..6) are the wrist; joints 1-4 the body.
WRIST = slice(4, 7)


@dataclass(frozen=True)
class NFAConfig:
    """enabled; wrist_range [rad] of the wrist samples around the start posture; n_candidates
    wrist samples per step; min_gain [voxels] of unknown Omega_safe
    volume below which the scan ends; max_views per scan; safe_box_min / safe_box_max [m]:
    Omega_safe relative to the robot base; rays (nu, nv) per candidate view; max_range [m]
    of the gain's rays; reach_tries: best candidates whose straight wrist motion is checked
    per step (at edge_resolution [rad]; a straight joint segment keeps the step deterministic);
    min_motion [rad]: reachable candidates that move the wrist less than this are dropped;
    backoff [rad]: a candidate pulled back stops this far (largest joint change) before the
    first invalid state, so that it does not rest at the edge of unseen space that may turn
    out occupied (the arm would then be stuck in a configuration its map calls invalid);
    self_occlusion: the gain leaves out the rays the arm's own body blocks
    (`mapping.self_occlusion`)"""

    enabled: bool = True
    wrist_range: float = 1.2
    n_candidates: int = 160
    min_gain: int = 40
    max_views: int = 8
    safe_box_min: tuple[float, float, float] = (-0.35, -0.6, 0.0)
    safe_box_max: tuple[float, float, float] = (0.75, 0.6, 1.15)
    rays: tuple[int, int] = (20, 15)
    max_range: float = 1.0
    reach_tries: int = 8
    edge_resolution: float = 0.005
    min_motion: float = 0.05
    backoff: float = 0.15
    scan_resolution: float = 0.02
    self_occlusion: bool = True

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, wrist_range=(0.0, 6.3, "rad"), max_range=(0.05, 10.0, "m"),
                     edge_resolution=(1e-4, 0.5, "rad"), min_motion=(0.0, 3.2, "rad"), backoff=(0.0, 3.2, "rad"),
                     scan_resolution=(1e-4, 0.5, "rad"))
        if self.n_candidates < 1 or self.max_views < 0 or self.min_gain < 0:
            raise CompassInputError("NFAConfig needs n_candidates >= 1, max_views >= 0, min_gain >= 0")
        if not np.all(np.asarray(self.safe_box_max) > np.asarray(self.safe_box_min)):
            raise CompassInputError(f"safe_box_max {self.safe_box_max} must exceed safe_box_min {self.safe_box_min}")


def wrist_candidates(q_body: np.ndarray, n: int, rng: np.random.Generator, wrist_range: float = np.inf
                     ) -> np.ndarray:
    """n configurations (n, 7) [rad]: joints 1-4 from q_body, joints 5-7 uniform within
    +-wrist_range [rad] of q_body's (and within their limits)."""
    q = np.asarray(q_body, float)
    Q = np.repeat(q[None], n, axis=0)
    lo = np.maximum(Q_MIN[WRIST], q[WRIST] - wrist_range)
    hi = np.minimum(Q_MAX[WRIST], q[WRIST] + wrist_range)
    Q[:, WRIST] = rng.uniform(lo, hi, (n, 3))
    return Q


def reachable_candidates(checker, q_now: np.ndarray, Q: np.ndarray, resolution: float, min_motion: float,
                         backoff: float = 0.0) -> np.ndarray:
    """Each row of Q (n, 7) [rad] pulled back along the straight segment from q_now to
    backoff [rad] (largest joint change) before its first invalid state (scanned at
    resolution [rad]); rows that then move less than min_motion [rad] are dropped."""
    q_now = np.asarray(q_now, float)
    out = []
    for q in np.asarray(Q, float):
        s = checker.first_invalid(q_now, q, resolution)
        if s is not None:
            span = float(np.max(np.abs(q - q_now)))
            n = max(1, int(np.ceil(span / resolution)))
            s = max(0.0, s - 1.0 / n - backoff / span)
            q = q_now + s * (q - q_now)
        if np.max(np.abs(q - q_now)) >= min_motion:
            out.append(q)
    return np.array(out).reshape(-1, 7)


def safe_box_map(occ: OccupancyMap, box_min: np.ndarray, box_max: np.ndarray, out: OccupancyMap | None = None,
                 keep_occupied: bool = False) -> OccupancyMap:
    """A map whose unknown voxels are those of occ inside the world box (others FREE), so
    that information gain counts only the unknown volume of Omega_safe. keep_occupied:
    voxels seen occupied outside the box stay OCCUPIED, so that they still stop the gain's
    rays (a wall or face frame just outside the box hides what lies behind it; freed, the
    gain counts voxels behind it that no camera on this side can see)."""
    out = out if out is not None else OccupancyMap(occ.config)
    lo = np.clip(occ.world_to_voxel(np.asarray(box_min)[None])[0], 0, np.asarray(occ.shape))
    hi = np.clip(occ.world_to_voxel(np.asarray(box_max)[None])[0] + 1, 0, np.asarray(occ.shape))
    if keep_occupied:
        out.state[...] = VoxelState.FREE
        out.state[occ.state == VoxelState.OCCUPIED] = VoxelState.OCCUPIED
    else:
        out.state[...] = VoxelState.FREE
    sl = tuple(slice(a, b) for a, b in zip(lo, hi))
    out.state[sl] = occ.state[sl]
    return out


def nfa_step(world, q_body: np.ndarray, base_pos: np.ndarray, config: NFAConfig, K: np.ndarray,
             rng: np.random.Generator, scratch: OccupancyMap | None = None, checker=None, screen: bool = False):
    """One greedy NFA step on the world model's current map, its candidates checked on
    checker (default world.checker). screen: a candidate whose motion the creep guard refuses
    is passed over before it is planned (no attempt), not refused after.

    Returns (path (m, 7) or None, best gain [voxels], plans attempted, plans succeeded,
    scratch map for reuse). None when no valid, reachable candidate gains >= min_gain.
    """
    checker = world.checker if checker is None else checker
    q_now = world.q
    Q = wrist_candidates(q_body, config.n_candidates, rng, config.wrist_range)
    Q = reachable_candidates(checker, q_now, Q, config.scan_resolution, config.min_motion,
                             config.backoff)
    if len(Q) == 0:
        return None, 0, 0, 0, scratch
    base = np.asarray(base_pos, float)
    scratch = safe_box_map(world.occ, base + config.safe_box_min, base + config.safe_box_max, scratch)
    T = world.kin.T_world_cam_batch(Q)
    gains = robot_view_gains(world, scratch, Q, T, K, config.max_range, config.rays,
                             self_occlusion=config.self_occlusion)
    order = np.argsort(-gains, kind="stable")
    attempted = succeeded = screened = 0
    for i in order[: config.reach_tries]:
        if gains[i] < config.min_gain:
            break
        q_goal = Q[i]
        if not checker.edge_valid(q_now, q_goal, config.edge_resolution):
            # invalid between two scan steps: the candidate is pulled back at the fine step
            fine = reachable_candidates(checker, q_now, q_goal[None], config.edge_resolution, config.min_motion,
                                        config.backoff)
            if len(fine) == 0:
                continue
            q_goal = fine[0]
        path = np.stack([q_now, q_goal])
        if screen and world.creeps(path):
            screened += 1
            continue
        attempted += 1
        if checker.edge_valid(q_now, q_goal, config.edge_resolution) and (screen or not world.creeps(path)):
            succeeded += 1
            return path, int(gains[i]), attempted, succeeded, scratch
    if screened and not attempted:
        attempted = 1  # the step was asked for and no motion to a view worth taking was found
    return None, int(gains[order[0]]), attempted, succeeded, scratch
