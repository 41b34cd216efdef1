"""Grasp hypotheses for active sensing: the grasps that would pass if the unknown space were
free, and the unknown voxels each of them needs to see.

The constrained selection (`select.py`) takes unknown space as unsafe, so before the hand's
way in has been seen every candidate fails. `grasp_hypotheses` runs the same candidates and
approach-cone checks with unknown space taken as free (occupied voxels and the target's
neighbours still block): the hand at the grasp, the longest free pre-grasp and the highest
free lift on the fine field, then IK with a free pre-grasp, approach and lift
(`checks.GraspChecks.check_shorter`: shorter pre-grasps and lower lifts too, as the selection). The best `n_hypotheses` by score are kept with their joint
configurations. `needed_voxels` lists, per hypothesis, the voxels that the whole arm's
spheres (grown by `inflate`, the checker's conservative bound) occupy along its pre-grasp ->
grasp -> lift motion and that the strict selection counts as unsafe and unknown: exactly
what a camera has to see before that grasp can pass. Nothing here reads ground truth.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..mapping.distance import voxels_in_spheres
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..robot.ik import PandaIK
from ..robot.spheres import SphereModel
from ..task import Task
from .candidates import AntipodalProposer, GraspCandidates, GraspProposer, propose_in_cone
from .carve import grasp_unsafe
from .checks import GraspChecks, first_clear, hand_clear, lift_steps, pregrasp_steps, rigid_hand_spheres
from .select import approach_angles, desired_approach
from .target import TargetModel


@dataclass(frozen=True)
class HypothesisConfig:
    """n_hypotheses kept (best score first); max_checked candidates solved by IK at most;
    inflate [m] added to every arm sphere when its voxels are listed (the validity
    checker's bound loses up to one fine voxel diagonal); n_interp configurations per
    straight segment (pre-grasp -> grasp, grasp -> lift); a hypothesis is kept only when
    its TCP lies min_separation [m] from every kept one's or its approach turns by more
    than min_turn [rad] (near-duplicates need the same voxels)."""

    n_hypotheses: int = 12
    max_checked: int = 400
    inflate: float = 0.009
    n_interp: int = 4
    min_separation: float = 0.02
    min_turn: float = 0.26

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, min_separation=(0.0, 1.0, "m"), min_turn=(0.0, 3.1416, "rad"))
        if not 1 <= self.n_hypotheses <= 200 or not 1 <= self.max_checked <= 10000:
            raise CompassInputError(f"n_hypotheses {self.n_hypotheses} / max_checked {self.max_checked} not "
                                    "allowed; use 1..200 and 1..10000")
        if not 0.0 <= self.inflate <= 0.05 or not 1 <= self.n_interp <= 50:
            raise CompassInputError(f"inflate {self.inflate} m / n_interp {self.n_interp} not allowed; "
                                    "use 0..0.05 m and 1..50")


@dataclass(frozen=True, eq=False)
class GraspHypothesis:
    """A grasp feasible with unknown space free: T_world_tcp (4,4), score s, q_grasp /
    q_pregrasp / q_lift (7,) [rad], pregrasp_distance / lift_height [m]; candidate: its row of the
    proposer's `GraspCandidates` (contacts, width), so a later selection can check it again."""

    T_world_tcp: np.ndarray
    score: float
    q_grasp: np.ndarray
    q_pregrasp: np.ndarray
    q_lift: np.ndarray
    pregrasp_distance: float
    lift_height: float
    candidate: GraspCandidates | None = None

    def motion(self, n_interp: int) -> np.ndarray:
        """(2 n_interp + 1, 7) [rad]: pre-grasp -> grasp -> lift, straight in joint space."""
        s = np.linspace(0.0, 1.0, n_interp + 1)[:, None]
        a = self.q_pregrasp + s * (self.q_grasp - self.q_pregrasp)
        b = self.q_grasp + s[1:] * (self.q_lift - self.q_grasp)
        return np.vstack([a, b])


def _near_one(T: np.ndarray, kept: list, config: HypothesisConfig) -> bool:
    """True when the TCP pose T (4,4) nearly repeats a kept hypothesis (position and approach)."""
    for h in kept:
        if np.linalg.norm(T[:3, 3] - h.T_world_tcp[:3, 3]) < config.min_separation \
                and T[:3, 2] @ h.T_world_tcp[:3, 2] > np.cos(config.min_turn):
            return True
    return False


def grasp_hypotheses(target: TargetModel, occ: OccupancyMap, task: Task, q_current: np.ndarray,
                     spheres: SphereModel, select_config, config: HypothesisConfig, rng: np.random.Generator,
                     safe_spheres: tuple[np.ndarray, np.ndarray], extra_safe: np.ndarray | None = None,
                     ik: PandaIK | None = None, proposer: GraspProposer | None = None,
                     stats: dict | None = None, fine_map: OccupancyMap | None = None,
                     ik_sweeps=None) -> list[GraspHypothesis]:
    """The best grasps (by score, then the higher grasp point) that pass the selection's
    checks with unknown space taken as free (module doc). select_config: the
    `select.GraspSelectConfig` whose cone, pre-grasp distances and lift heights apply;
    stats: if a dict, filled with the count of candidates dropped per check (the names of
    `select.Rejection`, with unknown space free); fine_map: the selection's fine local map
    (`select_grasp(fine_map=...)`), so the hypotheses are checked as the selection will check
    them; ik_sweeps: a `grasp.ik_memo.IKSweeps` kept across calls (the IK asked before is not
    solved again; the same hypotheses)."""
    stats = {} if stats is None else stats
    if rng is None:
        raise CompassInputError("grasp_hypotheses needs an explicit np.random.Generator (rng)")
    q_current = np.asarray(q_current, dtype=np.float64)
    ik = ik or PandaIK(spheres.kinematics)
    proposer = proposer or AntipodalProposer(select_config.candidates)
    optimistic = occ.state == VoxelState.UNKNOWN
    if extra_safe is not None:
        optimistic = optimistic | np.asarray(extra_safe, dtype=bool)
    checks = GraspChecks(occ, target, spheres, ik, select_config, safe_spheres, optimistic, q_current,
                         fine_map=fine_map, ik_sweeps=ik_sweeps)
    n = desired_approach(target, task)
    cands = propose_in_cone(proposer, target, rng, n, select_config.max_approach_angle)
    if len(cands) == 0:
        return []
    idx = np.nonzero(approach_angles(cands, n) <= select_config.max_approach_angle)[0]
    stats["APPROACH_ANGLE"] = len(cands) - len(idx)
    local = rigid_hand_spheres(spheres)
    T = cands.T_world_tcp[idx]
    ok = hand_clear(checks.fine, T, local, select_config.voxel_extent)
    stats["HAND_IN_COLLISION"] = int(np.count_nonzero(~ok))
    idx, T = idx[ok], T[ok]
    pre = first_clear(checks.fine, T, local, pregrasp_steps(select_config.pregrasp_distances),
                      select_config.voxel_extent)
    lift = first_clear(checks.fine, T, local, lift_steps(select_config.lift_heights), select_config.voxel_extent)
    keep = ~np.isnan(pre) & ~np.isnan(lift)
    stats["HAND_APPROACH_BLOCKED"] = int(np.count_nonzero(np.isnan(pre)))
    stats["HAND_LIFT_BLOCKED"] = int(np.count_nonzero(~np.isnan(pre) & np.isnan(lift)))
    idx, pre, lift = idx[keep], pre[keep], lift[keep]
    order = np.lexsort((-cands.T_world_tcp[idx, 2, 3], -cands.score[idx]))
    lift_clear = {h: checks.held_target_clear(h) for h in select_config.lift_heights}
    out: list[GraspHypothesis] = []
    for k in order[: config.max_checked]:
        i = idx[k]
        qs, why, d_pre, h_lift = checks.check_shorter(cands.T_world_tcp[i], q_current, pre[k], lift[k], lift_clear)
        if why is not None:
            stats[why] = stats.get(why, 0) + 1
        elif not _near_one(cands.T_world_tcp[i], out, config):
            out.append(GraspHypothesis(cands.T_world_tcp[i].copy(), float(cands.score[i]), *map(np.asarray, qs),
                                       float(d_pre), float(h_lift), cands.take([i])))
            if len(out) >= config.n_hypotheses:
                break
    return out


def needed_voxels(occ: OccupancyMap, hypotheses: list[GraspHypothesis], spheres: SphereModel,
                  strict_unsafe: np.ndarray, config: HypothesisConfig) -> list[np.ndarray]:
    """Per hypothesis, (N_h, 3) voxel indices that its arm (every sphere, grown by
    `inflate`) occupies along pre-grasp -> grasp -> lift and that are unknown and unsafe
    for the strict selection (`strict_unsafe`, e.g. `strict_unsafe_mask`)."""
    strict_unknown = np.asarray(strict_unsafe, dtype=bool) & (occ.state == VoxelState.UNKNOWN)
    out = []
    for h in hypotheses:
        Q = h.motion(config.n_interp)
        C = spheres.sphere_centers(Q).reshape(-1, 3)
        R = np.tile(spheres.radii + config.inflate, len(Q))
        out.append(voxels_in_spheres(strict_unknown, occ.grid_min, occ.resolution, C, R))
    return out


def strict_unsafe_mask(occ: OccupancyMap, target: TargetModel, clearance: float,
                       safe_spheres: tuple[np.ndarray, np.ndarray] | None,
                       extra_safe: np.ndarray | None) -> np.ndarray:
    """The strict selection's unsafe space (`carve.grasp_unsafe`)."""
    return grasp_unsafe(occ, target, clearance, safe_spheres, extra_safe)
