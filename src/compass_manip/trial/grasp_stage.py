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
compute time) plus the simulated duration of the grasp's motions.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError
from ..grasp.candidates import AntipodalProposer, PinnedProposer
from ..grasp.select import GraspFailure, GraspSelection, select_grasp
from ..exploration.world_model import assumed_free_mask, mark_configs, method_safe_voxels
from ..grasp.target import build_target_model
from ..mapping.occupancy import VoxelState
from ..robot.spheres import panda_sphere_model
from ..sim.grasp_exec import ExecFailure, GraspOutcome, execute_grasp
from ..sim.grasp_only import near_body_unknown
from .result import TrialFailure

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
    not reached); q_end (7,) [rad]; n_collisions of the arm with anything but the target."""

    failure: TrialFailure | None
    duration_s: float
    selection: GraspSelection | None
    outcome: GraspOutcome | None
    q_end: np.ndarray
    n_collisions: int

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
        out |= method_safe_voxels(occ, out, near_body_unknown(occ, spheres, q_home), config.near_body_halo)
    if config.outside_free and rules is not None:
        out |= method_safe_voxels(occ, out, assumed_free_mask(occ, task, rules), rules.obstacle_halo)
    return out


def run_grasp_stage(world, occupancy, detection, task, q_current: np.ndarray, moved: list[np.ndarray],
                    config, rng: np.random.Generator, planning_charge_s: float | None,
                    grasp_map=None, pinned=None, method_rules=None) -> GraspStageResult:
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
    seen obstacles) is free for the grasp too."""
    if rng is None:
        raise CompassInputError("run_grasp_stage needs an explicit np.random.Generator (rng)")
    q_current = np.asarray(q_current, dtype=np.float64)
    points = np.asarray(detection.points_world, dtype=np.float64).reshape(-1, 3)
    if len(points) < 10:
        return GraspStageResult(TrialFailure.GRASP_NO_CANDIDATE, 0.0, None, None, q_current, 0)
    target = build_target_model(points, detection.T_world_cam[:3, 3], task.target, occupancy, config.target)
    spheres = panda_sphere_model(world.robot)
    extra = np.zeros(occupancy.shape, bool)
    if moved:  # the robot's way is its own space, except where a voxel was seen occupied since
        Q = np.vstack([np.asarray(p, dtype=np.float64).reshape(-1, 7) for p in moved])
        Q = Q[:: max(1, len(Q) // config.max_moved_configs)]
        mark_configs(extra, occupancy, spheres, Q, config.moved_margin)
        extra &= occupancy.state != VoxelState.OCCUPIED
    extra |= assumed_unknown_free(occupancy, config, spheres, np.asarray(world.robot.q_home), task, method_rules)
    fine, t_fine = None, 0.0
    if grasp_map is not None and config.fine_map and grasp_map.frames:
        t0 = time.perf_counter()
        fine = grasp_map.fine_map_around(points, config.fine_margin, config.select.field_upsample)
        t_fine = time.perf_counter() - t0
    proposer = None if pinned is None or len(pinned) == 0 else \
        PinnedProposer(AntipodalProposer(config.select.candidates), pinned)
    sel = select_grasp(target, occupancy, task, q_current, spheres, config.select, rng, proposer=proposer,
                       extra_safe=extra,
                       fine_map=fine, q_via=np.asarray(world.robot.q_home) if config.plan_via_home else None)
    charge = sel.time_s + t_fine if planning_charge_s is None else planning_charge_s
    if sel.failure is not None:
        return GraspStageResult(_SELECT_FAILURE[sel.failure], charge, sel, None, q_current, 0)
    outcome = execute_grasp(world, sel, q_current, config.execute)
    failure = None if outcome.failure is None else _EXEC_FAILURE[outcome.failure]
    q_end = sel.q_lift if outcome.failure is None else q_current
    return GraspStageResult(failure, charge + outcome.t, sel, outcome, np.asarray(q_end), len(outcome.collisions))
