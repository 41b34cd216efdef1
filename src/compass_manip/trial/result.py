"""The record of one trial and its typed failure reasons."""
from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np


class TrialFailure(enum.Enum):
    """Why a trial failed (a successful trial has `failure is None`)."""

    NO_REACHABLE_VIEW = "no reachable viewpoint gains anything"
    PLANNING_FAILED = "motion planning failed"
    TIME_LIMIT = "time limit reached"
    TARGET_NOT_FOUND = "everything reachable explored, target not found"
    FALSE_DETECTION = "the accepted detection is not the target"
    COLLISION = "the robot touched the scene"
    GRASP_NO_CANDIDATE = "found, but no grasp candidate within the approach cone"
    GRASP_NO_IK = "found, but no candidate has a collision-free IK solution"
    GRASP_NO_PATH = "found, but no candidate has a free approach, lift and path"
    GRASP_COLLISION = "found, but the grasp touched something other than the target"
    GRASP_MISSED = "found, but the fingers closed without holding the target"
    GRASP_SLIP = "found, but the target did not rise with the hand"
    GRASP_DROP = "found, but the target was lost during the hold"
    #: look before moving (`GraspTrialConfig.verify`): the chosen manoeuvre still sweeps unknown
    #: voxels when the look budget is spent (or no view sees them), so it is not executed
    GRASP_UNVERIFIED = "found, but the grasp's swept space could not be seen free in the look budget"


@dataclass(frozen=True)
class TrialResult:
    """Metrics of one trial (see `to_dict` for the JSON keys). tft_s [s] and pft_m [m] are
    time and end-effector path length to find the target (the limit and the path length at
    the limit for failures); mpsr: plans that succeeded / attempted; am: mean manipulability
    along executed paths; explored_curve: (t [s], fraction known) of the target's
    surroundings; planning_ms_*: decision compute time; wall_s: wall time of the trial.
    success is end to end: found and (unless the trial is find-only) grasped, lifted and
    held. found: the target was found (a true detection within the limit); gpq: the selected
    grasp's Grasp Pose Quality (None when no grasp was selected or find-only); grasp_s [s]
    simulated time of the GRASP state (None when not entered); lift_m [m] the target's rise
    after the hold (None when no grasp was executed); grasp_looks: look views the GRASP state
    executed before moving (`GraspTrialConfig.verify`; None when not entered)."""

    method: str
    level: int
    scene: int
    trial: int
    seed: int
    failure: TrialFailure | None
    tft_s: float
    pft_m: float
    mpsr: float | None
    am: float | None
    gpq: float | None
    collisions: int
    explored_curve: tuple[tuple[float, float], ...]
    decisions: int
    planning_ms_median: float | None
    planning_ms_p90: float | None
    wall_s: float
    true_detection: bool | None
    found: bool = False
    grasp_s: float | None = None
    lift_m: float | None = None
    grasp_looks: int | None = None

    @property
    def success(self) -> bool:
        return self.failure is None

    def to_dict(self) -> dict:
        def r(x, n=4):
            return None if x is None or not np.isfinite(x) else round(float(x), n)

        return {
            "method": self.method, "level": self.level, "scene": self.scene, "trial": self.trial, "seed": self.seed,
            "success": self.success, "failure": None if self.failure is None else self.failure.name.lower(),
            "tft_s": r(self.tft_s, 3), "pft_m": r(self.pft_m, 3), "mpsr": r(self.mpsr), "am": r(self.am, 5),
            "gpq": r(self.gpq), "collisions": self.collisions,
            "explored_curve": [[r(t, 3), r(f)] for t, f in self.explored_curve],
            "decisions": self.decisions, "planning_ms_median": r(self.planning_ms_median, 2),
            "planning_ms_p90": r(self.planning_ms_p90, 2), "wall_s": r(self.wall_s, 3),
            "true_detection": self.true_detection, "found": self.found, "grasp_s": r(self.grasp_s, 3),
            "lift_m": r(self.lift_m), "grasp_looks": self.grasp_looks,
        }
