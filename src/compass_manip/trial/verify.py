"""Look before moving: the grasp's manoeuvre is executed only through space seen free.

The grasp stage may *choose* a grasp optimistically (unknown space near the body or outside
the confined space taken as free, `GraspTrialConfig.near_body_free` / `outside_free`), but
before it *executes* one, `swept_unknown` lists the voxels its whole manoeuvre sweeps - the
transfer path, pre-grasp -> grasp, grasp -> lift, every sphere of the planner's model grown by
`VerifyConfig.inflate` along the joint paths densified to `step` [rad] - that are still
unknown: not seen free, not the robot's own space (its executed way, its base column, its
current posture), not the target's carve (the space around the target the fingers must
enter, `grasp.carve`, exempt for the approach, close and lift only: the transfer to the
pre-grasp must see it, `transfer_path`). While some are, `LookPlanner` plans a view of them (camera poses
looking at their centroid, and at the centroids of their nearest-neighbour groups, from
`view_distance` [m], solved by camera IK, plus configurations next to the current one; kept
when valid for the method's own checker, scored by the listed voxels each sees without a
voxel seen occupied in the way) and the machine moves there, its frames integrated as in
INSPECT; then the grasp is selected again on the updated map (the previous choice pinned
first, so the same grasp comes back unless a voxel it needs was seen occupied). A look that
saw none of the voxels it aimed at (hidden behind unseen space) is not repeated: the grasp is
selected again with those voxels no longer assumed free (near-body / outside rules). When the
budget (`max_views`, `max_rounds`) is spent with voxels still unknown, the grasp is refused
(`TrialFailure.GRASP_UNVERIFIED`). Nothing here reads ground truth.
"""
from __future__ import annotations

import enum
import time
from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..exploration.viewpoints import sample_direction_in_cone, view_pose
from ..grasp.candidates import propose_in_cone
from ..grasp.carve import target_carve
from ..mapping.distance import mark_robot
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..motion.planner import PlannerConfig
from ..motion.timing import densify
from ..robot.ik import PandaIK
from ..robot.model import Q_MAX, Q_MIN
from .inspect import InspectPlan, frustum_mask, plan_to_best, seen_counts


class LookOutcome(enum.Enum):
    """What executing a look view did: the arm moved there; nothing moved (no view planned,
    no path, or the time limit reached); the motion touched the scene."""

    MOVED = "moved"
    NONE = "none"
    COLLISION = "collision"


@dataclass(frozen=True)
class VerifyConfig:
    """max_views executed look views per grasp stage; max_rounds selections (the first and the
    re-selections after looking); inflate [m] added to every sphere (the checker's bound);
    step [rad] of the densified joint paths; view_distance [m] of the camera from a look
    point; n_dirs camera directions per look point (upper hemisphere and toward the base);
    n_groups look points besides the centroid; n_q7 camera-IK samples; n_samples
    configurations drawn next to the current one (sigma / wrist_sigma [rad]); max_range [m]
    of a counted voxel; n_way configurations of the arm's executed way with the wrist turned
    by way_sigma [rad]; n_rays voxels traced for occlusion on the n_occlusion best views;
    min_seen voxels a view must see; n_goals best views handed to the planner; strict_first:
    each round first selects with only the robot's own space taken as free besides the space
    seen free (a transfer through known-free space), and optimistically only when that fails;
    trust_outside_space: the unknown space outside the confined space's box (grown by its wall
    and the method's space_margin, down to the floor) and beyond the method's obstacle halo from
    anything seen needs no look either: the rule the exploration baselines move on
    (`exploration.world_model.assumed_free_mask` without `near_base_box`; COMPASS itself keeps
    Omega_safe around the base unsafe until seen). Weaker than "seen free"; off by default.
    assumed_only: only the swept voxels the grasp stage took as free by an assumption (the
    near-body / outside rules, `grasp_stage.assumed_unknown_free`) are looked at; the target's
    carve and the checker's margin around its bound are not (a look at the arm's own way:
    the space beside and in front of the base that the chosen manoeuvre crosses).
    refuse: when voxels stay unknown (no view plans, a look sees none of them, the budget is
    spent) the grasp is refused (`GRASP_UNVERIFIED`); False: it is executed as chosen, as
    without looking - the look is best effort, it only adds the blockers it shows (a
    manoeuvre whose swept voxels a look saw occupied is never executed: it is chosen again).
    With assumed_only the transfer's voxels are looked at together with the approach's and
    lift's (without it only once those are all seen), after trying a transfer through the
    space seen free and the robot's own (`grasp_stage.strict_transfer`). outward: a third of
    the look directions point away from the base (the camera between the base and the voxels,
    looking out at the space beside the body, e.g. a lateral wall the elbow would meet)."""

    strict_first: bool = True
    trust_outside_space: bool = False
    assumed_only: bool = False
    refuse: bool = True
    outward: bool = False
    max_views: int = 6
    max_rounds: int = 4
    inflate: float = 0.009
    step: float = 0.02
    view_distance: tuple[float, float] = (0.3, 0.6)
    n_dirs: int = 24
    n_groups: int = 3
    n_q7: int = 4
    n_samples: int = 300
    sigma: float = 0.15
    wrist_sigma: float = 0.6
    max_range: float = 0.9
    n_rays: int = 300
    n_occlusion: int = 30
    min_seen: int = 3
    n_way: int = 300
    way_sigma: float = 1.0
    n_goals: int = 5
    planner: PlannerConfig = PlannerConfig()

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, sigma=(0.0, 6.3, "rad"), wrist_sigma=(0.0, 6.3, "rad"), max_range=(0.05, 10.0, "m"),
                     way_sigma=(0.0, 6.3, "rad"))
        for name in ("max_views", "max_rounds", "n_dirs", "n_groups", "n_q7", "n_samples", "n_rays",
                     "n_occlusion", "min_seen", "n_goals", "n_way"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 10000:
                raise CompassInputError(f"VerifyConfig.{name} = {v!r} is not allowed; use an integer 0..10000")
        if self.max_rounds < 1:
            raise CompassInputError(f"VerifyConfig.max_rounds = {self.max_rounds} is not allowed; use >= 1")
        if not 0.0 <= self.inflate <= 0.05 or not 0.001 <= self.step <= 0.2:
            raise CompassInputError(f"inflate {self.inflate} m / step {self.step} rad not allowed; "
                                    "use 0..0.05 m and 0.001..0.2 rad")
        lo, hi = self.view_distance
        if not 0.1 <= lo <= hi <= 1.0:
            raise CompassInputError(f"view_distance {self.view_distance} m is not allowed; use 0.1 <= lo <= hi <= 1")


def manoeuvre(selection, step: float, transfer: bool = True) -> np.ndarray:
    """(m, 7) [rad]: the selection's transfer path (transfer=False: left out), pre-grasp ->
    grasp and grasp -> lift, each straight joint segment densified so no joint moves more
    than step [rad]."""
    path = np.asarray(selection.path, dtype=np.float64).reshape(-1, 7) if transfer else np.zeros((0, 7))
    full = np.vstack([path, selection.q_pregrasp, selection.q_grasp, selection.q_lift])
    return densify(full, step)


def transfer_path(selection, step: float) -> np.ndarray:
    """(m, 7) [rad]: the selection's transfer path from q_current to its pre-grasp, densified
    so no joint moves more than step [rad]. Checked without the target's carve: the fingers
    must enter the unseen space next to the target only on the approach, close and lift, and
    a transfer that passes through it (a neighbour's hidden side within the carve's reach) has
    to see it free first."""
    path = np.asarray(selection.path, dtype=np.float64).reshape(-1, 7)
    return densify(np.vstack([path, selection.q_pregrasp]), step)


def swept_mask(occ: OccupancyMap, spheres, Q: np.ndarray, inflate: float) -> np.ndarray:
    """(nx, ny, nz) bool: voxels whose centres lie inside a sphere of the model grown by
    inflate [m] at any configuration of Q (m, 7) [rad]."""
    out = np.zeros(occ.shape, bool)
    mark_robot(out, occ, spheres, Q, inflate)
    return out


def swept_unknown(occ: OccupancyMap, spheres, Q: np.ndarray, inflate: float, own: np.ndarray,
                  target=None, clearance: float = 0.0) -> np.ndarray:
    """(N, 3) voxel indices the arm sweeps along Q (m, 7) [rad] (`swept_mask`) that are
    unknown in occ and neither in `own` (the robot's own space, a mask of occ's shape) nor,
    given a `grasp.target.TargetModel`, in the target's carve within clearance [m]."""
    own = np.asarray(own, dtype=bool)
    if own.shape != occ.shape:
        raise CompassInputError(f"own has shape {own.shape}; the map's shape {occ.shape} is required")
    unknown = (occ.state == VoxelState.UNKNOWN) & ~own
    if target is not None:
        unknown &= ~target_carve(occ, target, clearance)
    return np.argwhere(swept_mask(occ, spheres, Q, inflate) & unknown)


def swept_occupied(occ: OccupancyMap, spheres, Q: np.ndarray, target, clearance: float, inflate: float = 0.0) -> int:
    """Voxels seen occupied that the arm's spheres (grown by inflate [m]) cover along Q (m, 7)
    [rad], the target's own (its carve within clearance [m]) left out: a manoeuvre chosen
    through unknown space that a look showed blocked."""
    occupied = (occ.state == VoxelState.OCCUPIED) & ~target_carve(occ, target, clearance)
    return int(np.count_nonzero(swept_mask(occ, spheres, Q, inflate) & occupied))


def look_points(centres: np.ndarray, n_groups: int, rng: np.random.Generator) -> np.ndarray:
    """(k, 3) [m]: the centroid of the voxel centres (N, 3) and of up to n_groups groups
    (the nearest third of the voxels to a voxel drawn at random)."""
    out = [centres.mean(axis=0)]
    for _ in range(n_groups if len(centres) > 1 else 0):
        seed = centres[rng.integers(len(centres))]
        d = np.linalg.norm(centres - seed, axis=1)
        out.append(centres[np.argsort(d)[: max(1, len(centres) // 3)]].mean(axis=0))
    return np.array(out)


def look_axis(k: int, toward_base: np.ndarray, outward: bool) -> np.ndarray:
    """(3,) the k-th look direction's cone axis: down (k even without outward), toward the base
    (`toward_base`, from the look point), and with outward every third one away from it."""
    m = k % (3 if outward else 2)
    return np.array([0.0, 0.0, -1.0]) if m == 0 else np.asarray(toward_base, float) * (1.0 if m == 1 else -1.0)


class RecordingProposer:
    """A proposer that keeps its last candidates, so the selected grasp's row can be pinned
    for the next selection (`chosen`)."""

    def __init__(self, base) -> None:
        self.base, self.last = base, None

    def propose(self, target, rng: np.random.Generator, toward: np.ndarray | None = None,
                max_angle: float | None = None):
        self.last = propose_in_cone(self.base, target, rng, toward, max_angle) if toward is not None \
            else self.base.propose(target, rng)
        return self.last

    def chosen(self, selection):
        """The row of the last candidates whose TCP pose is the selection's (None if none)."""
        if self.last is None or len(self.last) == 0 or selection.T_world_tcp is None:
            return None
        d = np.abs(self.last.T_world_tcp - selection.T_world_tcp[None]).reshape(len(self.last), -1).max(axis=1)
        i = int(np.argmin(d))
        return self.last.take([i]) if d[i] < 1e-9 else None


class LookPlanner:
    """Plans one look view of given voxel centres (module doc) on the method's world model
    `wm` (checker, kin) with camera intrinsics K (3,3); base_pos (3,) [m] of the robot."""

    def __init__(self, wm, K: np.ndarray, base_pos: np.ndarray, config: VerifyConfig,
                 rng: np.random.Generator) -> None:
        if not isinstance(rng, np.random.Generator):
            raise CompassInputError(f"rng {rng!r:.40} is not allowed; give an explicit np.random.Generator")
        self.wm, self.K, self.config, self.rng = wm, np.asarray(K, dtype=np.float64), config, rng
        self.base = np.asarray(base_pos, dtype=np.float64)
        self.ik = PandaIK(wm.kin)

    def __call__(self, q_current: np.ndarray, occ: OccupancyMap, centres: np.ndarray,
                 way: list[np.ndarray] | None = None) -> InspectPlan:
        """Plan from q_current (7,) [rad] to a view of the voxel centres (N,3) [m] on occ; way:
        joint paths (m,7) [rad] the arm moved along: n_way of their configurations with the
        wrist (joints 5-7) turned by way_sigma [rad] are candidates too."""
        t0 = time.perf_counter()
        cfg, rng, wm = self.config, self.rng, self.wm
        q = np.asarray(q_current, dtype=np.float64)
        centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
        if len(centres) == 0:
            return InspectPlan(None, 0, 0, time.perf_counter() - t0, planned=False)
        lo, hi = cfg.view_distance
        poses = []
        for p in look_points(centres, cfg.n_groups, rng):
            toward_base = self.base + np.array([0.0, 0.0, 0.3]) - p  # the camera out in front, looking back
            for k in range(cfg.n_dirs):  # view directions: down onto the voxels, toward the base (or away)
                axis = look_axis(k, toward_base, cfg.outward)
                d = sample_direction_in_cone(axis, 0.7, rng)
                poses.append(view_pose(p, d, rng.uniform(lo, hi), rng.uniform(-np.pi, np.pi)))
        Q = [s for T in poses for s in self.ik.solve(T, "cam", q, cfg.n_q7, retry=False).solutions[:2]]
        scale = np.r_[np.full(4, cfg.sigma), np.full(3, cfg.wrist_sigma)]
        near = np.clip(q + rng.normal(0.0, 1.0, (cfg.n_samples, 7)) * scale, Q_MIN + 1e-3, Q_MAX - 1e-3)
        parts = [np.array(Q).reshape(-1, 7), near]
        if way:
            W = np.vstack([np.asarray(w, dtype=np.float64).reshape(-1, 7) for w in way])
            W = W[rng.integers(len(W), size=cfg.n_way)]
            W[:, 4:] += rng.normal(0.0, cfg.way_sigma, (len(W), 3))
            parts.append(np.clip(W, Q_MIN + 1e-3, Q_MAX - 1e-3))
        Q = np.vstack(parts)
        Q = Q[np.asarray(wm.checker.are_valid(Q), dtype=bool)]
        if len(Q) == 0:
            return InspectPlan(None, 0, 0, time.perf_counter() - t0)
        T = wm.kin.T_world_cam_batch(Q)
        gain = frustum_mask(T, self.K, centres, cfg.max_range).sum(axis=1).astype(np.float64)
        top = np.argsort(-gain, kind="stable")[: cfg.n_occlusion]
        sub = centres[rng.choice(len(centres), min(len(centres), cfg.n_rays), replace=False)]
        seen = np.zeros_like(gain)
        seen[top] = seen_counts(occ, T[top], self.K, sub, cfg.max_range) * len(centres) / len(sub)
        return plan_to_best(q, Q, seen, cfg.min_seen, cfg.n_goals, wm.checker, cfg.planner, rng, t0)
