"""INSPECT views between FOUND and GRASP: look at the hand's way in before selecting a grasp.

At FOUND the camera has looked at the target from above and in front; the space in front of
the target at its height, where the hand comes in, lies below the camera's frustum and
stays unknown, so every hand pose at the grasp collides with the map (measured on 4 level-1
scenes: the blocking unknown voxels lay 6-13 cm in front of the target, at its height).
`plan_inspect_view` samples configurations near the current one (joints perturbed with
`sigma` [rad], the wrist joints with `wrist_sigma`), keeps those valid for the method's own
checker, scores each by the unknown voxels of the corridor box (the target's points grown
`corridor` [m] toward the opening, `side` [m] sideways and up to `above` [m] above the
target) inside its camera frustum, and plans (the shared planner, same checker) to the best
few (with `occlusion`, the best by that count re-scored by the voxels they see past the
obstacles already seen). Nothing here reads ground truth: the map, the checker and the detection's points are
the method's.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types
from ..grasp.hypotheses import HypothesisConfig
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..motion.planner import PlannerConfig, plan
from ..robot.model import Q_MAX, Q_MIN


@dataclass(frozen=True)
class InspectConfig:
    """n_views INSPECT views (0: off); n_samples configurations sampled per view; sigma /
    wrist_sigma [rad] joint perturbation (joints 1-4 / 5-7); corridor / side / above [m]
    of the corridor box; max_range [m] of a counted voxel from the camera; n_goals best
    views handed to the planner; min_gain unknown corridor voxels a view must see;
    occlusion: the n_occlusion best views by frustum count are re-scored by the corridor
    voxels (n_rays of them sampled) they see without a voxel seen occupied in the way.
    mode: "grasp" (`trial.grasp_views`: views chosen for the unknown voxels the grasp
    hypotheses' arms need; n_samples / sigma / wrist_sigma then add configurations near
    the current one to the camera-IK views) or "corridor" (this module: the corridor box);
    hypotheses: their `grasp.hypotheses.HypothesisConfig`; n_axes hypotheses (best score
    first) each get n_per_axis camera poses within axis_cone [rad] of their approach, and
    n_around look at all needed voxels from within around_cone [rad] of the mean approach,
    backed off view_distance [m]; n_q7 camera IK samples; done_unknown: INSPECT stops when
    a hypothesis needs at most this many unknown voxels; min_fraction of the hypotheses'
    weight a grasp-mode view must see; max_pinned: the grasp mode keeps the candidates of up
    to this many hypotheses found so far and checks them again at every step and in the GRASP
    stage's selection (0: each step draws afresh, as before). n_up camera poses look up at the
    needed voxels (`trial.grasp_views.up_candidates`): half from below, their optical axes
    within up_cone [rad] of the mean approach's horizontal direction raised by up_elevation
    [rad], half within up_cone of the direction from the robot's shoulder to the voxels (the
    space behind an opening's top rail that the forearm needs is seen only from there); the
    best n_occlusion of them are re-scored with occlusion besides the best n_occlusion of the
    other views. plan_groups: when no path reaches the n_goals best views, the next n_goals
    are tried, up to this many planner calls per step (1: the best group only). escape: when
    the current configuration is invalid for the method's checker (the grasp-only harness's
    oracle view stands within the checker's margin of the rail it looks past, and no plan can
    start there), the grasp mode first moves out along `exploration.escape.escape_path`, the
    short way out every method takes, and plans from there (False: no plan, as before).
    near_first [m] (0: off): the grasp mode aims its views at the needed voxels inside the
    detection points' box grown by near_first (the hand's way in, which only a view into the
    confined space sees) while any hypothesis still needs one there, and at all of them
    after (`trial.grasp_views.near_target_first`); the stop rule counts all of them."""

    n_views: int = 6
    mode: str = "grasp"
    hypotheses: HypothesisConfig = field(default_factory=HypothesisConfig)
    n_axes: int = 6
    n_per_axis: int = 8
    axis_cone: float = 0.5
    n_around: int = 24
    around_cone: float = 0.9
    view_distance: tuple[float, float] = (0.25, 0.5)
    n_q7: int = 4
    done_unknown: int = 0
    min_fraction: float = 0.02
    max_pinned: int = 48
    n_up: int = 32
    up_elevation: float = 0.6
    up_cone: float = 0.5
    plan_groups: int = 3
    escape: bool = True
    near_first: float = 0.0
    n_samples: int = 300
    sigma: float = 0.12
    wrist_sigma: float = 0.5
    corridor: float = 0.2
    side: float = 0.08
    above: float = 0.1
    max_range: float = 0.9
    n_goals: int = 5
    min_gain: int = 5
    occlusion: bool = True
    n_occlusion: int = 30
    n_rays: int = 300
    planner: PlannerConfig = field(default_factory=PlannerConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if isinstance(self.n_views, bool) or not isinstance(self.n_views, int) or not 0 <= self.n_views <= 20:
            raise CompassInputError(f"n_views {self.n_views!r} is not allowed; use an integer 0..20")
        if isinstance(self.max_pinned, bool) or not isinstance(self.max_pinned, int) or not 0 <= self.max_pinned <= 1000:
            raise CompassInputError(f"max_pinned {self.max_pinned!r} is not allowed; use an integer 0..1000")
        if not 1 <= self.n_samples <= 10000 or not 1 <= self.n_goals <= 100 or self.min_gain < 0:
            raise CompassInputError(f"n_samples {self.n_samples} / n_goals {self.n_goals} / min_gain "
                                    f"{self.min_gain} not allowed; use 1..10000, 1..100 and >= 0")
        if self.mode not in ("grasp", "corridor"):
            raise CompassInputError(f"mode {self.mode!r} is not allowed; use 'grasp' or 'corridor'")
        if isinstance(self.plan_groups, bool) or not isinstance(self.plan_groups, int) \
                or not 1 <= self.plan_groups <= 20 or not 0 <= self.n_up <= 1000:
            raise CompassInputError(f"plan_groups {self.plan_groups!r} / n_up {self.n_up} not allowed; "
                                    "use an integer 1..20 and 0..1000")
        lo, hi = self.view_distance
        if not 0.1 <= lo <= hi <= 1.0 or not 0 <= self.n_axes <= 100 or not 0 <= self.n_per_axis <= 100 \
                or not 0 <= self.n_around <= 1000 or not 1 <= self.n_q7 <= 100 or self.done_unknown < 0:
            raise CompassInputError(f"view_distance {self.view_distance} m / n_axes {self.n_axes} / n_per_axis "
                                    f"{self.n_per_axis} / n_around {self.n_around} / n_q7 {self.n_q7} / done_unknown "
                                    f"{self.done_unknown} not allowed; use 0.1 <= lo <= hi <= 1 m, 0..100, 0..100, "
                                    "0..1000, 1..100, >= 0")
        for name in ("sigma", "wrist_sigma", "corridor", "side", "above", "max_range", "axis_cone", "around_cone",
                     "min_fraction", "up_elevation", "up_cone", "near_first"):
            if not 0.0 <= getattr(self, name) <= 2.0:
                raise CompassInputError(f"{name} {getattr(self, name)} is not allowed; use 0..2")


@dataclass(frozen=True, eq=False)
class InspectPlan:
    """path (m,7) [rad] to the chosen view or None; gain: unknown corridor voxels in its
    frustum; n_valid sampled configurations valid for the checker; plan_time_s [s];
    planned: the planner was called (False: INSPECT stopped with nothing left to plan for);
    n_calls: planner calls made (`plan_to_best` tries further groups of views)."""

    path: np.ndarray | None
    gain: int
    n_valid: int
    plan_time_s: float
    planned: bool = True
    n_calls: int = 1


def corridor_unknown(occ: OccupancyMap, points: np.ndarray, outward: np.ndarray,
                     config: InspectConfig) -> np.ndarray:
    """(N,3) [m] centres of the unknown voxels in the corridor box: the points' box grown by
    `corridor` toward the opening (horizontal `outward`), `side` sideways, `above` up."""
    h = np.asarray(outward, dtype=np.float64) * np.array([1.0, 1.0, 0.0])
    h /= max(np.linalg.norm(h), 1e-9)
    lo, hi = points.min(0) - config.side, points.max(0) + config.side
    lo[2], hi[2] = points[:, 2].min(), points[:, 2].max() + config.above
    lo = np.minimum(lo, lo + config.corridor * h)
    hi = np.maximum(hi, hi + config.corridor * h)
    shape = np.asarray(occ.shape)
    a = np.clip(occ.world_to_voxel(lo[None])[0], 0, shape - 1)
    b = np.clip(occ.world_to_voxel(hi[None])[0], 0, shape - 1) + 1
    sub = occ.state[a[0]:b[0], a[1]:b[1], a[2]:b[2]] == VoxelState.UNKNOWN
    return occ.voxel_to_world(np.argwhere(sub) + a)


def frustum_counts(T_world_cam: np.ndarray, K: np.ndarray, points: np.ndarray, max_range: float) -> np.ndarray:
    """(M,) number of points (N,3) [m] inside each camera's (M,4,4) image and range."""
    if len(points) == 0:
        return np.zeros(len(T_world_cam), dtype=np.int64)
    return frustum_mask(T_world_cam, K, points, max_range).sum(axis=1)


def frustum_mask(T_world_cam: np.ndarray, K: np.ndarray, points: np.ndarray, max_range: float) -> np.ndarray:
    """(M,N) True where point n (N,3) [m] lies inside camera m's (M,4,4) image and range."""
    P = np.einsum("mji,mnj->mni", T_world_cam[:, :3, :3], points[None] - T_world_cam[:, None, :3, 3])
    z = P[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K[0, 0] * P[..., 0] / z + K[0, 2]
        v = K[1, 1] * P[..., 1] / z + K[1, 2]
    return (z > 0.05) & (z < max_range) & (u >= 0) & (u < 2 * K[0, 2]) & (v >= 0) & (v < 2 * K[1, 2])


def seen_counts(occ: OccupancyMap, T_world_cam: np.ndarray, K: np.ndarray, points: np.ndarray,
                max_range: float) -> np.ndarray:
    """(M,) number of points (N,3) [m] each camera (M,4,4) sees: inside its image and range,
    and no voxel seen occupied on the straight ray to it (sampled every voxel, the last
    voxel before the point excluded)."""
    mask = frustum_mask(T_world_cam, K, points, max_range)
    occupied = occ.state == VoxelState.OCCUPIED
    shape, step = np.asarray(occ.shape), occ.resolution
    out = np.zeros(len(T_world_cam), dtype=np.int64)
    for m in range(len(T_world_cam)):
        pts = points[mask[m]]
        if len(pts) == 0:
            continue
        eye = T_world_cam[m, :3, 3]
        d = pts - eye
        length = np.linalg.norm(d, axis=1)
        s = np.arange(1, int(np.ceil(length.max() / step)) + 1)[None, :] * step
        P = eye + (d / length[:, None])[:, None, :] * s[..., None]
        v = occ.world_to_voxel(P.reshape(-1, 3)).reshape(len(pts), s.shape[1], 3)
        ok = np.all((v >= 0) & (v < shape), axis=-1) & (s < length[:, None] - step)
        vc = np.clip(v, 0, shape - 1)
        blocked = (occupied[vc[..., 0], vc[..., 1], vc[..., 2]] & ok).any(axis=1)
        out[m] = int(np.count_nonzero(~blocked))
    return out


def plan_inspect_view(checker, kin, occ: OccupancyMap, K: np.ndarray, points: np.ndarray, outward: np.ndarray,
                      q_current: np.ndarray, config: InspectConfig, rng: np.random.Generator) -> InspectPlan:
    """Plan from q_current (7,) [rad] to the sampled view that sees the most unknown voxels
    of the corridor in front of the target's points (N,3) [m] (module doc); `checker` is the
    method's validity checker, `kin` its kinematics, K (3,3) the camera intrinsics."""
    t0 = time.perf_counter()
    q_current = np.asarray(q_current, dtype=np.float64)
    target = corridor_unknown(occ, np.asarray(points, dtype=np.float64).reshape(-1, 3), outward, config)
    if len(target) < config.min_gain or not checker.is_valid(q_current):
        return InspectPlan(None, 0, 0, time.perf_counter() - t0, planned=False)
    scale = np.r_[np.full(4, config.sigma), np.full(3, config.wrist_sigma)]
    Q = np.clip(q_current + rng.normal(0.0, 1.0, (config.n_samples, 7)) * scale, Q_MIN + 1e-3, Q_MAX - 1e-3)
    Q = Q[np.asarray(checker.are_valid(Q), dtype=bool)]
    if len(Q) == 0:
        return InspectPlan(None, 0, 0, time.perf_counter() - t0)
    T = kin.T_world_cam_batch(Q)
    gain = frustum_counts(T, np.asarray(K, dtype=np.float64), target, config.max_range)
    if config.occlusion:  # the best by frustum count, re-scored by the corridor voxels they see unoccluded
        top = np.argsort(-gain, kind="stable")[: config.n_occlusion]
        sub = target[rng.choice(len(target), min(len(target), config.n_rays), replace=False)]
        seen = seen_counts(occ, T[top], np.asarray(K, dtype=np.float64), sub, config.max_range)
        gain = np.zeros_like(gain)
        gain[top] = np.round(seen * len(target) / len(sub)).astype(np.int64)
    return plan_to_best(q_current, Q, gain, config.min_gain, config.n_goals, checker, config.planner, rng, t0)


def plan_to_best(q: np.ndarray, Q: np.ndarray, score: np.ndarray, min_score: float, n_goals: int, checker,
                 planner: PlannerConfig, rng: np.random.Generator, t0: float, n_groups: int = 1) -> InspectPlan:
    """Plan from q (7,) [rad] to any of the n_goals best-scored views among Q (n,7) [rad]
    that score at least min_score; when no path reaches them, to any of the next n_goals, up to
    n_groups planner calls (an `InspectPlan` with planned=False when no view scores enough,
    path None when no path is found; gain the reached view's score rounded, plan_time_s since
    t0, a `time.perf_counter()` value)."""
    order = np.argsort(-score, kind="stable")
    order = order[score[order] >= min_score][: n_goals * n_groups]
    if len(order) == 0:
        return InspectPlan(None, 0, len(Q), time.perf_counter() - t0, planned=False)
    n_calls = 0
    for start in range(0, len(order), n_goals):
        group = order[start: start + n_goals]
        res = plan(q, Q[group], checker, planner, rng)
        n_calls += 1
        if res.success:
            return InspectPlan(res.path, int(round(score[group[res.goal_index]])), len(Q),
                               time.perf_counter() - t0, n_calls=n_calls)
    return InspectPlan(None, 0, len(Q), time.perf_counter() - t0, n_calls=n_calls)
