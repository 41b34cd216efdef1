"""The trial's GRASP state: from the accepted detection to a grasp lifted in physics.

The target model is built from the accepted detection's points (seen from its camera) fused
with the method's own map; the grasp is selected against that map (`grasp.select`, the
paper's Eq. 6, or its ablation) with the robot's executed way marked as its own space (and,
with `near_body_free`, the unknown space the arm's links 0-4 sweep near home, the harness's
stand-in for a near-field scan: `sim.grasp_only.near_body_unknown`); voxels seen occupied
stay unsafe on the executed way too (marking the way's spheres safe outright let a grasp
approach through the cabinet's face frame that an INSPECT motion had passed within 2 cm of); the
selection is executed in the World's physics (`sim.grasp_exec`). Nothing here reads ground
truth: the physics decides whether the lift worked, as the real robot's sensors would.
The simulated clock advances by the selection (the trial's planning charge, or the measured
compute time) plus the simulated duration of the grasp's motions. With `verify` (look before
moving, `trial.verify`) a selection is executed only when every voxel its manoeuvre sweeps is
seen free or the robot's own; the stage first executes look views of the rest through the
machine (their motions advance the machine's clock) and re-checks or re-selects.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..errors import CompassInputError
from ..grasp.checks import GraspChecks
from ..motion.planner import plan
from ..robot.ik import PandaIK
from ..grasp.candidates import AntipodalProposer, GraspCandidates, PinnedProposer
from ..grasp.robot_space import base_volume_mask
from ..grasp.select import GraspFailure, GraspSelection, select_grasp
from ..exploration.world_model import assumed_free_mask, method_safe_voxels
from ..grasp.target import build_target_model
from ..mapping.distance import mark_robot
from ..mapping.occupancy import VoxelState
from ..robot.spheres import panda_sphere_model
from ..sim.grasp_exec import ExecFailure, GraspOutcome, execute_grasp
from ..sim.grasp_only import near_body_unknown
from .result import TrialFailure
from .inspect import InspectPlan
from .verify import LookOutcome, RecordingProposer, manoeuvre, swept_occupied, swept_unknown, transfer_path

_SELECT_FAILURE = {
    GraspFailure.NO_CANDIDATE: TrialFailure.GRASP_NO_CANDIDATE,
    GraspFailure.NO_APPROACH: TrialFailure.GRASP_NO_CANDIDATE,
    GraspFailure.NO_IK: TrialFailure.GRASP_NO_IK,
    GraspFailure.NO_APPROACH_PATH: TrialFailure.GRASP_NO_PATH,
    GraspFailure.NO_PATH: TrialFailure.GRASP_NO_PATH,
}
_EXEC_FAILURE = {
    ExecFailure.COLLISION: TrialFailure.GRASP_COLLISION,
    ExecFailure.MISSED: TrialFailure.GRASP_MISSED,
    ExecFailure.SLIP: TrialFailure.GRASP_SLIP,
    ExecFailure.DROP: TrialFailure.GRASP_DROP,
}


@dataclass(frozen=True, eq=False)
class GraspStageResult:
    """failure None when the target was lifted and held without collision; duration_s [s]
    charged to the simulated clock (selection + motions); selection / outcome (None when
    not reached); q_end (7,) [rad]; n_collisions of the arm with anything but the target;
    n_looks: look views executed before the grasp (`GraspTrialConfig.verify`); look_log: per
    check of a chosen manoeuvre, its unknown and occupied swept voxels and the view's outcome."""

    failure: TrialFailure | None
    duration_s: float
    selection: GraspSelection | None
    outcome: GraspOutcome | None
    q_end: np.ndarray
    n_collisions: int
    n_looks: int = 0
    look_log: tuple = ()

    @property
    def gpq(self) -> float | None:
        """The selected grasp's GPQ (None when none was selected)."""
        ok = self.selection is not None and self.selection.failure is None
        return float(self.selection.gpq) if ok else None

    @property
    def lift_m(self) -> float | None:
        return None if self.outcome is None or self.outcome.failure is ExecFailure.NOT_SELECTED \
            else float(self.outcome.hold_height)


def assumed_unknown_free(occ, config, spheres, q_home: np.ndarray, task, rules) -> np.ndarray:
    """(nx, ny, nz) bool: the unknown voxels of occ the grasp stage and INSPECT's hypotheses
    take as free besides the robot's own space: with `config.near_body_free` those links 0-4
    sweep near q_home (`sim.grasp_only.near_body_unknown`) farther than `near_body_halo` [m]
    from anything seen occupied; with `config.outside_free` and the method's rules (a
    `WorldModelConfig`, or None) the unknown space its own checker takes as free."""
    out = np.zeros(occ.shape, bool)
    if config.near_body_free:
        out |= method_safe_voxels(occ, out, near_body_unknown(occ, spheres, q_home, config.near_body_yaw),
                                  config.near_body_halo)
    if config.outside_free and rules is not None:
        out |= method_safe_voxels(occ, out, assumed_free_mask(occ, task, rules), rules.obstacle_halo)
    return out


def needs_look(unknown: np.ndarray, assumed: np.ndarray, verify) -> np.ndarray:
    """(N, 3) voxel indices of `unknown` (swept unknown voxels) a look must see before the
    manoeuvre runs: all of them, or with `verify.assumed_only` those the stage took as free by
    an assumption (`assumed`, a mask of the map's shape; `assumed_unknown_free`)."""
    unknown = np.asarray(unknown, dtype=np.int64).reshape(-1, 3)
    return unknown[assumed[tuple(unknown.T)]] if verify.assumed_only else unknown


def own_space(occ, spheres, moved: list[np.ndarray], config) -> np.ndarray:
    """(nx, ny, nz) bool: the robot's executed way (`moved`, joint paths (m,7) [rad], at most
    max_moved_configs of them, spheres grown by moved_margin [m]) less the voxels seen occupied."""
    own = np.zeros(occ.shape, bool)
    if moved:
        Q = np.vstack([np.asarray(p, dtype=np.float64).reshape(-1, 7) for p in moved])
        Q = Q[:: max(1, len(Q) // config.max_moved_configs)]
        mark_robot(own, occ, spheres, Q, config.moved_margin)
        own &= occ.state != VoxelState.OCCUPIED
    return own


def strict_transfer(occ, target, spheres, q: np.ndarray, q_pregrasp: np.ndarray, own: np.ndarray, config, fine,
                    rng: np.random.Generator) -> np.ndarray | None:
    """(m, 7) [rad]: a path from q to q_pregrasp planned by the selection's planner on its
    checker with only the robot's own space (`own`) taken as free besides the space seen free
    (no assumption about unknown space), or None when none plans."""
    checks = GraspChecks(occ, target, spheres, PandaIK(spheres.kinematics), config.select,
                         (spheres.sphere_centers(q[None])[0], spheres.radii + config.select.robot_clearance),
                         own, q, fine_map=fine)
    res = plan(q, np.asarray(q_pregrasp, dtype=np.float64)[None], checks.full, config.select.planner, rng)
    return np.asarray(res.path) if res.success else None


def run_grasp_stage(world, occupancy, detection, task, q_current: np.ndarray, moved: list[np.ndarray],
                    config, rng: np.random.Generator, planning_charge_s: float | None,
                    grasp_map=None, pinned=None, method_rules=None, looker=None, look=None,
                    method_swept=None, ik_sweeps=None) -> GraspStageResult:
    """Select and execute a grasp of the detected target from q_current (7,) [rad].

    occupancy: the method's map; detection: the accepted `perception.detector.Detection`;
    moved: joint paths (m,7) [rad] the robot followed (its own space in the map); config: the
    trial's `GraspTrialConfig`; planning_charge_s: the fixed clock charge of the selection
    [s], or None to charge its measured compute time; grasp_map: the trial's
    `trial.grasp_map.GraspMap` when `occupancy` is its map: with `config.fine_map` its frames
    are integrated again at 5 mm around the target's points (`fine_margin` [m]) and the
    hand's checks near the target use that map, as in the grasp-only harness; pinned: a
    `grasp.candidates.GraspCandidates` checked before the proposer's own (INSPECT's grasp
    hypotheses, `trial.grasp_views.GraspInspector.pinned`), or None; method_rules: the
    method's `exploration.world_model.WorldModelConfig`: with `config.outside_free` the
    unknown space its validity checker takes as free (outside the confined space, away from
    seen obstacles) is free for the grasp too. With `config.verify` (`trial.verify`, look
    before moving): looker, a `trial.verify.LookPlanner`, and look, the machine's
    `look(InspectPlan) -> trial.verify.LookOutcome` (it executes the view, feeds its
    frames to the maps and advances the clock; `moved` grows by the view's path);
    method_swept: `method_swept()` -> the method's own space on occupancy's grid (its world
    model's swept space: the way grown by its swept_margin, the start posture's shell), taken
    as the robot's own with `config.method_swept`, as INSPECT counts it and the method moves;
    ik_sweeps: INSPECT's `grasp.ik_memo.IKSweeps` (`GraspInspector.ik_sweeps`), so the selection
    does not solve again the IK INSPECT solved (the same selection), or None."""
    if rng is None:
        raise CompassInputError("run_grasp_stage needs an explicit np.random.Generator (rng)")
    q = np.asarray(q_current, dtype=np.float64)
    points = np.asarray(detection.points_world, dtype=np.float64).reshape(-1, 3)
    if len(points) < 10:
        return GraspStageResult(TrialFailure.GRASP_NO_CANDIDATE, 0.0, None, None, q, 0)
    verify = config.verify
    if verify is not None and (looker is None or look is None):
        raise CompassInputError("GraspTrialConfig.verify needs a looker and the machine's look callback")
    spheres = panda_sphere_model(world.robot)
    charge, n_views, chosen, sel, log = 0.0, 0, None, None, []
    q_home = np.asarray(world.robot.q_home)

    def own_now():
        own = own_space(occupancy, spheres, moved, config)
        if config.method_swept and method_swept is not None:
            own |= np.asarray(method_swept(), dtype=bool) & (occupancy.state != VoxelState.OCCUPIED)
        return own

    def model():
        return build_target_model(points, detection.T_world_cam[:3, 3], task.target, occupancy, config.target)

    stuck = np.zeros(occupancy.shape, bool)  # voxels a look aimed at and did not see: no longer assumed free
    for round_ in range(1 if verify is None else verify.max_rounds):
        target, own = model(), own_now()
        assumed = assumed_unknown_free(occupancy, config, spheres, q_home, task, method_rules) & ~stuck
        extra = own | assumed
        fine, t_fine = None, 0.0
        if grasp_map is not None and config.fine_map and grasp_map.frames:
            t0 = time.perf_counter()
            fine = grasp_map.fine_map_around(points, config.fine_margin, config.select.field_upsample)
            t_fine = time.perf_counter() - t0
        first = GraspCandidates.concat([c for c in (chosen, pinned) if c is not None])
        proposer = RecordingProposer(AntipodalProposer(config.select.candidates) if len(first) == 0 else
                                     PinnedProposer(AntipodalProposer(config.select.candidates), first))
        sel = None
        if verify is not None and verify.strict_first:  # through known-free space first
            sel = select_grasp(target, occupancy, task, q, spheres, config.select, rng, proposer=proposer,
                               extra_safe=own, fine_map=fine, ik_sweeps=ik_sweeps)
            charge += sel.time_s + t_fine if planning_charge_s is None else planning_charge_s
        if sel is None or sel.failure is not None:
            sel = select_grasp(target, occupancy, task, q, spheres, config.select, rng, proposer=proposer,
                               extra_safe=extra, fine_map=fine, q_via=q_home if config.plan_via_home else None,
                               ik_sweeps=ik_sweeps)
            charge += sel.time_s + t_fine if planning_charge_s is None else planning_charge_s
        if sel.failure is not None:
            return GraspStageResult(_SELECT_FAILURE[sel.failure], charge, sel, None, q, 0, n_views, tuple(log))
        if verify is None:
            break
        chosen = proposer.chosen(sel)
        Q_grasp, blocked0, t_ref = manoeuvre(sel, verify.step, transfer=False), None, None

        def transfer_unknown(sel, own):  # the transfer's swept voxels a look must see
            return needs_look(swept_unknown(occupancy, spheres, transfer_path(sel, verify.step), verify.inflate, own),
                              assumed, verify)

        def through_seen(sel, own, target):  # sel with a transfer through seen-free and own space, if one plans
            path = strict_transfer(occupancy, target, spheres, q, sel.q_pregrasp, own, config, fine, rng)
            log[-1]["strict_path"] = path is not None
            return sel if path is None else replace(sel, path=path)

        aimed, unseen = None, False
        while True:  # the grasp's own motions first, then a transfer through space seen free
            own = own_now() | base_volume_mask(spheres, occupancy)
            mark_robot(own, occupancy, spheres, q[None], config.select.robot_clearance)
            if verify.trust_outside_space and method_rules is not None:  # the baselines' rule, not Omega_safe's
                rule = replace(method_rules, near_base_box=None)
                own |= method_safe_voxels(occupancy, own, assumed_free_mask(occupancy, task, rule), rule.obstacle_halo)
            target = model()
            unknown = needs_look(swept_unknown(occupancy, spheres, Q_grasp, verify.inflate, own, target,
                                               config.select.clearance), assumed, verify)
            blocked = swept_occupied(occupancy, spheres, Q_grasp, target, config.select.clearance)
            blocked0 = blocked if blocked0 is None else blocked0  # what the selection accepted (hand on the fine map)
            blocked = max(0, blocked - blocked0)
            t_occ = swept_occupied(occupancy, spheres, transfer_path(sel, verify.step), target, config.select.clearance)
            t_ref = (sel.path, t_occ) if t_ref is None or t_ref[0] is not sel.path else t_ref  # as planned
            blocked += max(0, t_occ - t_ref[1])  # a look showed the transfer blocked too
            log.append({"round": round_, "unknown_grasp": int(len(unknown)), "occupied": int(blocked)})
            if blocked:
                break
            if aimed is not None and np.all(occupancy.state[tuple(aimed.T)] == VoxelState.UNKNOWN):
                log[-1]["unseen"] = int(len(aimed))
                if verify.refuse:  # the last look saw none of them: choose again without them
                    stuck[tuple(aimed.T)] = unseen = True
                break  # (best effort: executed as chosen)
            if verify.assumed_only:  # best effort: the transfer's assumed voxels are looked at with the grasp's
                t_unknown = transfer_unknown(sel, own)
                if len(t_unknown):
                    strict = through_seen(sel, own, target)
                    if strict is not sel:
                        sel, t_unknown = strict, t_unknown[:0]
                unknown = np.unique(np.vstack([unknown, t_unknown]), axis=0)
                log[-1]["unknown_all"] = int(len(unknown))
                if len(unknown) == 0:
                    break
            elif len(unknown) == 0:
                sel = through_seen(sel, own, target)
                unknown = transfer_unknown(sel, own)
                log[-1]["unknown_all"] = int(len(unknown))
                if len(unknown) == 0:
                    break
            if n_views >= verify.max_views:
                break
            aimed = unknown
            p = looker(q, occupancy, occupancy.voxel_to_world(unknown), moved)
            charge += p.plan_time_s if planning_charge_s is None else planning_charge_s
            done = look(p)
            log[-1].update(view=done.value, gain=p.gain, n_valid=p.n_valid)
            if done is LookOutcome.MOVED:  # back along the way it came (its own space): the manoeuvre starts here
                n_views += 1
                done = look(InspectPlan(np.asarray(p.path)[::-1].copy(), 0, 0, 0.0), count=False)
            if done is LookOutcome.COLLISION:
                return GraspStageResult(TrialFailure.COLLISION, charge, sel, None, q, 0, n_views, tuple(log))
            if done is not LookOutcome.MOVED:  # no view sees them: refuse rather than move through the unknown
                if not verify.refuse:
                    break  # best effort: executed as chosen
                return GraspStageResult(TrialFailure.GRASP_UNVERIFIED, charge, sel, None, q, 0, n_views, tuple(log))
        if not blocked and (len(unknown) == 0 or not verify.refuse):
            break
        if not (blocked or unseen) or round_ == verify.max_rounds - 1:  # the look budget is spent
            return GraspStageResult(TrialFailure.GRASP_UNVERIFIED, charge, sel, None, q, 0, n_views, tuple(log))
    outcome = execute_grasp(world, sel, q, config.execute)
    failure = None if outcome.failure is None else _EXEC_FAILURE[outcome.failure]
    q_end = sel.q_lift if outcome.failure is None else q
    return GraspStageResult(failure, charge + outcome.t, sel, outcome, np.asarray(q_end), len(outcome.collisions),
                            n_views, tuple(log))
