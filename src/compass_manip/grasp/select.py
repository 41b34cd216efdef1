"""The paper's constrained grasp selection (Eq. 6) and its Grasp Pose Quality (GPQ).

    max_g s_g  s.t.  IK(e_g) in Q_free,  angle(z_g, n) <= delta,  FK(tau(q_cur, q_grasp)) in M_free

Q_free and M_free are taken against the map with unknown space unsafe and the target's own
volume carved (`carve.py`). The path constraint covers the whole manoeuvre: a planned path
from q_current to the pre-grasp, the straight approach along the gripper's z, and the lift
(arm and held target). The desired approach n comes from the confined space's opening (the
hand enters against `outward`) made perpendicular to the target's long axis when it has one.
Candidates are tried by score (ties: the higher free lift, the smaller approach angle in 10 deg
bins, then the higher grasp point), up to `max_checked` past the hand's checks, a pinned
proposer's own candidates (INSPECT's hypotheses, `n_pinned`) first; among the feasible
ones of the best score the planner takes any goal it reaches.

With `constrained=False` (the paper's ablation) the highest-scored candidate with any IK
solution inside the joint limits is taken (ties broken at random), whatever the map and the
approach angle say; the way to its pre-grasp is still planned, as the paper's MoveIt does it:
on the map with unknown space free (occupied voxels stay obstacles). Approach and lift are
not checked.
"""
from __future__ import annotations

import math
import time
from collections import Counter
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..mapping.distance import DistanceField
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..motion.planner import DEFAULT_MAX_CHECKS, PlannerConfig, PlanResult, plan
from ..motion.primitives import DistanceGrid
from ..motion.validity import ValidityChecker, ValidityConfig
from ..robot.ik import PandaIK
from ..robot.model import check_q
from ..robot.spheres import SphereModel
from ..task import Task
from .candidates import AntipodalProposer, CandidateConfig, GraspCandidates, GraspProposer, propose_in_cone
from .carve import grasp_field
from .checks import (GraspChecks, first_clear, hand_clear, lift_steps, offset_pose,  # noqa: F401 (re-exported)
                     pregrasp_steps, rigid_hand_spheres)
from .robot_space import base_volume, base_volume_mask  # noqa: F401 (re-exported)
from .target import TargetModel


#: Edge checks one planner call of the selection may make: 2 x the shared planner's default,
#: with `max_failed_plans` = 3 instead of 6, so a field's failed calls spend the same 120,000
#: checks at most. On the level-3 scenes 12 and 19 of seed 0 every one of the 12 calls of
#: 20,000 checks failed (`NO_PATH`) while the first goal group was reached with 20,762 and
#: 32,133 checks (`benchmarks/diag_select_failures.py`): a narrow way out of the cabinet
#: takes more than one short search. 60,000 x 2 selected them too, but lost level 2 scene 3,
#: whose grasp main reaches only with its third goal group (docs/grasping_log.md, branch gmod).
SELECT_MAX_CHECKS = 2 * DEFAULT_MAX_CHECKS


class Rejection(Enum):
    """Why one candidate was rejected."""

    APPROACH_ANGLE = "approach more than delta from the desired direction"
    HAND_IN_COLLISION = "the hand collides with the map at the grasp pose"
    HAND_APPROACH_BLOCKED = "the hand collides with the map on its way in from the pre-grasp"
    HAND_LIFT_BLOCKED = "the hand collides with the map on its way up"
    NO_IK = "no IK solution within the joint limits"
    IK_IN_COLLISION = "every IK solution collides with the map"
    PREGRASP_BLOCKED = "no collision-free pre-grasp next to the grasp configuration"
    APPROACH_BLOCKED = "the straight approach from the pre-grasp collides"
    LIFT_BLOCKED = "the lift collides (arm or held target)"
    NO_PATH = "no collision-free path from the current configuration"


class GraspFailure(Enum):
    """Why no grasp was selected."""

    NO_CANDIDATE = "no force-closure candidate on the target"
    NO_APPROACH = "no candidate within delta of the desired approach"
    NO_IK = "no candidate has a collision-free IK solution"
    NO_APPROACH_PATH = "no candidate has a free pre-grasp, approach and lift"
    NO_PATH = "no collision-free path to any feasible candidate"


@dataclass(frozen=True)
class GraspSelectConfig:
    """constrained: apply Eq. 6's constraints (False: the paper's ablation); max_approach_angle
    delta [rad]; pregrasp_distances [m] back along the approach and lift_heights [m], each
    tried in order per candidate (the first free one is taken: a shelf board above the
    target may leave less than the full lift, and unseen space behind an occluder may
    leave less than the full pre-grasp); clearance [m]
    of the target carve; robot_clearance [m] added to the robot's spheres at q_current when
    its own volume is marked safe; n_q7 IK samples; max_ik_solutions tried per candidate;
    max_feasible feasible candidates gathered before planning; max_checked candidates checked
    at most; max_joint_step [rad] between grasp and pre-grasp/lift configurations (a straight
    approach); voxel_extent: unsafe voxels are cubes (the checker subtracts half a voxel
    diagonal) rather than points at their centres; field_upsample: the checked field's grid
    near the target is this many times finer than the map's (`checks.GraspChecks`); plan_margin
    [m] kept by the planned path to the pre-grasp; exact_fallback: when no candidate passes
    the arm's checks and the path on the field that is exact only near the target, the wrist
    and the base, run those checks again on a field exact in the whole box (the selection
    then equals one made on that field throughout); max_failed_plans: a search on one field
    stops after this many planner calls that found no path (each spends the planner's
    budget; None: no limit); planner: settings of that path."""

    constrained: bool = True
    max_approach_angle: float = math.radians(50.0)
    pregrasp_distances: tuple[float, ...] = (0.10, 0.06)
    lift_heights: tuple[float, ...] = (0.10, 0.07, 0.04)
    clearance: float = 0.055
    robot_clearance: float = 0.02
    n_q7: int = 24
    max_ik_solutions: int = 3
    max_feasible: int = 4
    max_checked: int = 400
    max_joint_step: float = 0.6
    voxel_extent: bool = True
    field_upsample: int = 2
    plan_margin: float = 0.005
    exact_fallback: bool = True
    max_failed_plans: int | None = 3
    candidates: CandidateConfig = field(default_factory=CandidateConfig)
    planner: PlannerConfig = field(default_factory=lambda: PlannerConfig(max_checks=SELECT_MAX_CHECKS))

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, robot_clearance=(0.0, 0.2, "m"), max_joint_step=(1e-3, 6.3, "rad"),
                     plan_margin=(0.0, 0.1, "m"))
        if not 0.0 < self.max_approach_angle <= math.pi:
            raise CompassInputError(f"max_approach_angle {self.max_approach_angle} rad is not allowed; use (0, pi]")
        if not self.pregrasp_distances or not all(0.02 <= d <= 0.3 for d in self.pregrasp_distances):
            raise CompassInputError(f"pregrasp_distances {self.pregrasp_distances} m not allowed; "
                                    "use values in 0.02..0.3 m")
        if not self.lift_heights or not all(0.0 <= h <= 0.3 for h in self.lift_heights):
            raise CompassInputError(f"lift_heights {self.lift_heights} m not allowed; use values in 0..0.3 m")
        if not 0.0 <= self.clearance <= 0.1:
            raise CompassInputError(f"clearance {self.clearance} m is not allowed; use 0..0.1 m")
        if self.max_failed_plans is not None and not 1 <= self.max_failed_plans <= 1000:
            raise CompassInputError(f"max_failed_plans {self.max_failed_plans} is not allowed; use 1..1000 or None")
        if not 1 <= self.max_feasible <= 100 or not 1 <= self.max_checked <= 100000:
            raise CompassInputError("max_feasible must be 1..100 and max_checked 1..100000")


@dataclass(frozen=True, eq=False)
class GraspSelection:
    """The selected grasp and how it was found.

    T_world_tcp (4,4), width [m] and score s of the chosen candidate (None on failure);
    q_grasp, q_pregrasp, q_lift (7,) [rad]; pregrasp_distance / lift_height [m] of the
    chosen pre-grasp and lift (0 on failure); path (n,7) [rad] from q_current to q_pregrasp;
    approach_angle [rad] between z_g and n; ik_free: q_grasp is free in the map;
    gpq = s * 1[ik_free] * cos(approach_angle); n desired approach; n_candidates proposed;
    rejections: count per `Rejection`; time_s selection wall time [s] (plan_time_s of it
    in the planner); failure: None on success; stage_times [s] per stage (unsafe: the map's
    unsafe space in the checked box, field: the checked field, candidates, hand: the rigid
    hand's checks, ik: IK and configuration checks, plan: the path)."""

    T_world_tcp: np.ndarray | None
    width: float
    score: float
    q_grasp: np.ndarray | None
    q_pregrasp: np.ndarray | None
    q_lift: np.ndarray | None
    path: np.ndarray | None
    approach_angle: float
    ik_free: bool
    gpq: float
    n: np.ndarray
    n_candidates: int
    rejections: dict
    time_s: float
    plan_time_s: float
    failure: GraspFailure | None
    pregrasp_distance: float = 0.0
    lift_height: float = 0.0
    stage_times: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.failure is None


def _plan_via(q_current: np.ndarray, q_via: np.ndarray, goals: np.ndarray, checker, config: PlannerConfig,
              rng: np.random.Generator):
    """(PlanResult of the second leg with plan_time_s of both, the joined path or None):
    q_current -> q_via, then q_via -> any of goals (k,7) [rad], each on `checker`."""
    first = plan(q_current, np.asarray(q_via, dtype=np.float64)[None], checker, config, rng)
    if not first.success:
        return first, None
    second = plan(first.path[-1], goals, checker, config, rng)
    second = PlanResult(second.path, second.failure, second.goal_index, first.plan_time_s + second.plan_time_s,
                        first.n_checks + second.n_checks)
    path = np.vstack([first.path, second.path[1:]]) if second.success else None
    return second, path


def desired_approach(target: TargetModel, task: Task, tilt: float = math.radians(20.0),
                     elongation: float = 1.3) -> np.ndarray:
    """Unit approach direction n from the confined space's opening and the target's axes.

    The hand enters the space against its `outward` direction. An upright target (long axis
    within 30 deg of vertical) is grasped across that axis, from the opening and tilted down
    by `tilt` [rad]: an arm reaching into a cabinet over the things in front of the target
    pitches down, and coming in level is still within delta. Any other elongated target
    gets the opening direction made perpendicular to its long axis, so the fingers close
    across it, not along it."""
    a = -np.asarray(task.space.outward, dtype=np.float64)
    a /= np.linalg.norm(a)
    m = target.axes[:, 0]
    if target.extents[0] > elongation * target.extents[1]:
        if abs(m[2]) > math.cos(math.radians(30.0)):
            h = a - (a @ np.array([0.0, 0.0, 1.0])) * np.array([0.0, 0.0, 1.0])
            if np.linalg.norm(h) > 1e-6:
                h /= np.linalg.norm(h)
                return math.cos(tilt) * h - math.sin(tilt) * np.array([0.0, 0.0, 1.0])
        p = a - (a @ m) * m
        if np.linalg.norm(p) > 0.2:
            a = p / np.linalg.norm(p)
    return a


def n_pinned(proposer) -> int:
    """How many of a proposer's first candidates are pinned (`candidates.PinnedProposer`: the
    grasp hypotheses INSPECT found and looked at, the best-scored candidates that passed the
    checks with unknown space free); 0 for any other proposer. The selection checks them
    first: the candidates the hypothesis search ranked above them failed those looser
    checks already, and the cap on the candidates checked (`max_checked`) must not drop
    the grasp the views were taken for."""
    pins = getattr(proposer, "pinned", None)
    return 0 if pins is None else len(pins)


def approach_angles(cands: GraspCandidates, n: np.ndarray) -> np.ndarray:
    """(M,) angle [rad] between each candidate's approach (TCP z) and n."""
    return np.arccos(np.clip(cands.approach @ n, -1.0, 1.0))


def gpq(score: float, ik_free: bool, angle: float) -> float:
    """The paper's Grasp Pose Quality s * 1[IK(e) in Q_free] * cos(angle(z_g, n))."""
    return float(score) * float(bool(ik_free)) * math.cos(angle)


def select_grasp(target: TargetModel, occ: OccupancyMap, task: Task, q_current: np.ndarray,
                 spheres: SphereModel, config: GraspSelectConfig | None = None,
                 rng: np.random.Generator | None = None, proposer: GraspProposer | None = None,
                 safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
                 ik: PandaIK | None = None, extra_safe: np.ndarray | None = None,
                 fine_map: OccupancyMap | None = None, q_via: np.ndarray | None = None,
                 ik_sweeps=None) -> GraspSelection:
    """Select a grasp of `target` (Eq. 6) against the map `occ` from q_current (7,) [rad].

    spheres: the robot's sphere model with the fingers open (the approach width);
    proposer: candidates (default `AntipodalProposer`: the plug-in point for a learned
    network); safe_spheres: extra robot volume known to be free, (centres (S,3), radii (S,))
    [m] (e.g. the arm's spheres along its past path); the robot's spheres at q_current are
    always marked safe, and so is the space around the base column (`base_volume`);
    extra_safe: a voxel mask of the map's shape the caller takes as free (e.g. a
    `robot_space.RobotSpaceMask` kept as the robot moved); fine_map: an occupancy map
    `field_upsample` times finer than occ over a box around the target, integrated from the
    same depth frames (`field.local_fine_map`): the checks near the target use its labels;
    q_via (7,) [rad]: when the planner finds no path from q_current to a group of feasible
    pre-grasps, it tries q_current -> q_via -> pre-grasp (e.g. the home posture: a wrist deep
    in a storey after INSPECT may have no direct way to an approach from the opening), on the
    same checker. rng: explicit generator (required). ik_sweeps: a `grasp.ik_memo.IKSweeps`
    shared with earlier checks (INSPECT's hypotheses): IK they solved is not solved again.
    """
    t0 = time.perf_counter()
    if rng is None:
        raise CompassInputError("select_grasp needs an explicit np.random.Generator (rng)")
    config = config or GraspSelectConfig()
    q_current = check_q(q_current, "q_current")
    q_via = None if q_via is None else check_q(q_via, "q_via")
    proposer = proposer or AntipodalProposer(config.candidates)
    ik = ik or PandaIK(spheres.kinematics)
    n = desired_approach(target, task)
    cur = spheres.sphere_centers(q_current[None])[0]
    safe_c, safe_r = cur, spheres.radii + config.robot_clearance
    base = base_volume_mask(spheres, occ)
    if extra_safe is not None and np.shape(extra_safe) != occ.shape:
        raise CompassInputError(f"extra_safe has shape {np.shape(extra_safe)}; the map's shape {occ.shape} is required")
    extra_safe = base if extra_safe is None else base | np.asarray(extra_safe, dtype=bool)
    if safe_spheres is not None:
        safe_c = np.vstack([safe_c, np.asarray(safe_spheres[0]).reshape(-1, 3)])
        safe_r = np.r_[safe_r, np.asarray(safe_spheres[1]).reshape(-1)]
    checks = GraspChecks(occ, target, spheres, ik, config, (safe_c, safe_r), extra_safe, q_current,
                         fine_map=fine_map, ik_sweeps=ik_sweeps)
    field_, checker = checks.fine, checks.full
    stages = dict(checks.times)
    t_stage = time.perf_counter()
    # with the constraints, sample approaches only inside the cone they allow
    cands = propose_in_cone(proposer, target, rng, n, config.max_approach_angle) if config.constrained \
        else proposer.propose(target, rng)
    stages["candidates_s"] = time.perf_counter() - t_stage
    t_stage = time.perf_counter()
    rejections: Counter = Counter()
    ik_rej: Counter = Counter()  # the IK stage's rejections (of the last field it ran on)
    plan_time = 0.0

    pre_of = np.zeros(len(cands))
    lift_of = np.zeros(len(cands))

    def done(failure, idx=None, qs=None, path=None):
        now = time.perf_counter()
        if "hand_s" in stages:
            stages["ik_s"] = max(0.0, now - t_stage - plan_time - stages.get("exact_field_s", 0.0))
        else:
            stages["hand_s"], stages["ik_s"] = now - t_stage, 0.0
        stages["plan_s"] = plan_time
        if failure is not None:
            return GraspSelection(None, 0.0, 0.0, None, None, None, None, float("nan"), False, 0.0, n, len(cands),
                                  {**rejections, **ik_rej}, time.perf_counter() - t0, plan_time, failure,
                                  stage_times=dict(stages))
        T = cands.T_world_tcp[idx]
        ang = float(approach_angles(cands.take([idx]), n)[0])
        free = bool(checks.valid(np.asarray(qs[0])[None])[0])
        s = float(cands.score[idx])
        return GraspSelection(T, float(cands.width[idx]), s, *qs, path, ang, free, gpq(s, free, ang), n,
                              len(cands), {**rejections, **ik_rej}, time.perf_counter() - t0, plan_time, None,
                              float(pre_of[idx]), float(lift_of[idx]), dict(stages))

    if len(cands) == 0:
        return done(GraspFailure.NO_CANDIDATE)
    ang = approach_angles(cands, n)
    if not config.constrained:
        # the paper's planner (MoveIt on the OctoMap) takes unknown space as free
        loose = grasp_field(occ, target, config.clearance, safe_spheres=(safe_c, safe_r),
                            extra_safe=(occ.state == VoxelState.UNKNOWN) | extra_safe)
        plan_checker = ValidityChecker(spheres, grid=DistanceGrid.from_distance_field(loose),
                                       config=ValidityConfig(voxel_extent=config.voxel_extent))
        order = rng.permutation(len(cands))
        order = order[np.argsort(-cands.score[order], kind="stable")]
        for idx in order[: config.max_checked]:
            r = ik.solve(cands.T_world_tcp[idx], "tcp", q_current, config.n_q7, None)
            if not r.success:
                rejections[Rejection.NO_IK] += 1
                continue
            q_g = r.solutions[0]
            pre_of[idx], lift_of[idx] = config.pregrasp_distances[0], config.lift_heights[0]
            q_pre = checks.near(offset_pose(cands.T_world_tcp[idx], -pre_of[idx]), q_g, None)
            q_lift = checks.near(offset_pose(cands.T_world_tcp[idx], up=lift_of[idx]), q_g, None)
            if q_pre is None or q_lift is None:
                rejections[Rejection.NO_IK] += 1
                continue
            res = plan(q_current, q_pre[None], plan_checker, config.planner, rng)
            plan_time += res.plan_time_s
            if not res.success:
                rejections[Rejection.NO_PATH] += 1
                return done(GraspFailure.NO_PATH)
            return done(None, idx, (q_g, q_pre, q_lift), res.path)
        return done(GraspFailure.NO_IK)

    within = np.nonzero(ang <= config.max_approach_angle)[0]
    rejections[Rejection.APPROACH_ANGLE] = len(cands) - len(within)
    if len(within) == 0:
        return done(GraspFailure.NO_APPROACH)
    local = rigid_hand_spheres(spheres)  # the checks run on the fine field near the target
    ok = hand_clear(field_, cands.T_world_tcp[within], local, config.voxel_extent)
    rejections[Rejection.HAND_IN_COLLISION] = int(np.count_nonzero(~ok))
    within = within[ok]
    # the first (longest) free straight approach, then the first (highest) free lift
    pre = first_clear(field_, cands.T_world_tcp[within], local, pregrasp_steps(config.pregrasp_distances),
                      config.voxel_extent)
    rejections[Rejection.HAND_APPROACH_BLOCKED] = int(np.count_nonzero(np.isnan(pre)))
    within, pre = within[~np.isnan(pre)], pre[~np.isnan(pre)]
    lift = first_clear(field_, cands.T_world_tcp[within], local, lift_steps(config.lift_heights), config.voxel_extent)
    rejections[Rejection.HAND_LIFT_BLOCKED] = int(np.count_nonzero(np.isnan(lift)))
    keep = ~np.isnan(lift)
    pre_of[within[keep]], lift_of[within[keep]] = pre[keep], lift[keep]
    hand_pre, hand_lift = pre_of.copy(), lift_of.copy()  # the hand's longest free pre-grasp / highest lift
    within = within[keep]
    if len(within) == 0:
        return done(GraspFailure.NO_APPROACH_PATH)
    # ties of s: the higher free lift first, then the approach nearer n (10 deg bins), then the higher grasp point;
    # a pinned proposer's own candidates (INSPECT's hypotheses, whose way in was looked at) before all others
    z = cands.T_world_tcp[within, 2, 3]
    pinned = (within < n_pinned(proposer)).astype(np.int64)
    order = within[np.lexsort((-z, np.round(ang[within] / math.radians(10.0)), -lift_of[within],
                               -cands.score[within], -pinned))]
    stages["hand_s"] = time.perf_counter() - t_stage
    t_stage = time.perf_counter()

    def search(chk):
        """IK, configuration and path checks of the ordered candidates on one checked field;
        (the selection or None, n_free_ik); rejections go to ik_rej."""
        nonlocal plan_time
        lift_clear = {h: chk.held_target_clear(h) for h in config.lift_heights}
        feasible: list[tuple[int, tuple]] = []
        n_free_ik = 0
        failed = [0]  # planner calls that found no path (`max_failed_plans`)

        def try_plan(group):
            nonlocal plan_time
            goals = np.array([qs[1] for _, qs in group])
            res = plan(q_current, goals, chk.plan, config.planner, rng)
            plan_time += res.plan_time_s
            path = res.path
            if not res.success and q_via is not None:  # back out to the via posture first, then in
                res, path = _plan_via(q_current, q_via, goals, chk.plan, config.planner, rng)
                plan_time += res.plan_time_s
            if res.success:
                idx, qs = group[res.goal_index]
                return done(None, idx, qs, path)
            ik_rej[Rejection.NO_PATH] += len(group)
            failed[0] += 1
            return None

        reduced: list[tuple[int, tuple]] = []  # feasible only at a shorter pre-grasp / lower lift than the hand's

        def level_done():
            """Plan to the score level's full candidates, then to its reduced ones."""
            for group in (feasible, reduced):
                if group:
                    out = try_plan(group)
                    if out is not None:
                        return out
            return None

        level = None
        for idx in order[: config.max_checked]:
            if config.max_failed_plans is not None and failed[0] >= config.max_failed_plans:
                return None, n_free_ik  # the planner's budget is spent on this field
            if level is not None and cands.score[idx] < level and (feasible or reduced):
                out = level_done()  # the best score level is complete: plan to it first
                if out is not None:
                    return out, n_free_ik
                feasible, reduced = [], []
            level = cands.score[idx]
            if idx not in solved:  # the first IK does not depend on the field: once per candidate
                solved[idx] = chk.ik_first(cands.T_world_tcp[idx], q_current)
            qs, why, d_pre, h_lift = chk.check_shorter(cands.T_world_tcp[idx], q_current, hand_pre[idx], hand_lift[idx],
                                                       lift_clear, solved[idx])
            why = None if why is None else Rejection[why]
            if why is not None:
                ik_rej[why] += 1
                n_free_ik += why not in (Rejection.NO_IK, Rejection.IK_IN_COLLISION)
                continue
            n_free_ik += 1
            pre_of[idx], lift_of[idx] = d_pre, h_lift  # a shorter pre-grasp or lower lift may be what the arm allows
            if d_pre < hand_pre[idx] or h_lift < hand_lift[idx]:
                if len(reduced) < config.max_feasible:  # ties of s: the full pre-grasp and lift first
                    reduced.append((int(idx), qs))
                continue
            feasible.append((int(idx), qs))
            if len(feasible) >= config.max_feasible:
                out = try_plan(feasible)
                if out is not None:
                    return out, n_free_ik
                feasible = []
        out = level_done()
        if out is not None:
            return out, n_free_ik
        return None, n_free_ik

    solved: dict = {}  # candidate index -> its first IK result (shared by both fields)
    out, n_free_ik = search(checks)
    if out is None and config.exact_fallback and set(ik_rej) != {Rejection.NO_IK}:
        # the field is exact only near the target, the wrist and the base: before giving up,
        # the arm's checks and the path again on a field exact everywhere in the box (not
        # when every candidate had no IK solution at all: that does not depend on the field)
        t_ex = time.perf_counter()
        checks = GraspChecks(occ, target, spheres, ik, config, (safe_c, safe_r), extra_safe, q_current,
                             fine_map=fine_map, exact_everywhere=True, reuse=checks)
        stages["exact_field_s"] = time.perf_counter() - t_ex
        ik_rej.clear()
        out, n_free_ik = search(checks)
    if out is not None:
        return out
    if ik_rej[Rejection.NO_PATH]:
        return done(GraspFailure.NO_PATH)
    if n_free_ik:
        return done(GraspFailure.NO_APPROACH_PATH)
    return done(GraspFailure.NO_IK)
