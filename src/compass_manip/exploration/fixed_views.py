"""FV (Fixed Views): an open-loop sequence of camera viewpoints computed from the Task alone.

The sequence depends only on the confined space's outer geometry (interior box, opening,
outward normal), the robot's base and its start configuration, never on the map or the
scene's contents. Construction (`fixed_view_poses`):

* rows: `heights` fractions of the interior height, from top to bottom; columns: `lateral`
  fractions of the opening's width (along the horizontal axis of the opening);
* each view's camera sits `standoff` [m] out of the opening plane (along `outward`) in
  front of its (column, row) point of the opening, `rise` [m] above the row, and looks at
  the point `depth` (fraction of the interior depth) into the space, at the row's height,
  displaced laterally towards the other side by `cross` times the column's offset from
  the centre (so side views look obliquely across the space, behind front objects);
* rows are visited in serpentine order (left-to-right, then right-to-left, ...).

Each view is solved by camera IK with the previous view's solution as reference (the first
from the start configuration); views without an IK solution are dropped. At run time the
robot plans (shared planner, current map) to each view in turn; a view without a valid
plan is skipped (a failed plan for MPSR) and, with `retry_skipped`, tried once more after
the sequence. The method stops (EXPLORED) when the sequence ends; the trial stops earlier
when the target is detected.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..robot.ik import PandaIK
from ..task import Task
from .base import Decision, Phase, StopReason
from .baseline_common import MapMethod, ViewPlanningConfig, plan_to, timed
from .viewpoints import view_pose
from .world_model import WorldModelConfig


@dataclass(frozen=True)
class FixedViewsConfig:
    """heights / lateral: fractions of the interior height / opening width of the view grid;
    standoff [m] of the camera out of the opening plane; rise [m] of the camera above its
    row (looking slightly down); depth: fraction of the interior depth the views look at;
    cross: lateral displacement of the look-at point towards the other side, as a
    fraction of the column's offset from the centre; ik_q7 q7 samples of the camera IK;
    ik_solutions kept per view (planner goals); retry_skipped: one more pass over views
    whose plan failed; planning: the shared planner."""

    heights: tuple[float, ...] = (0.85, 0.55, 0.25)
    lateral: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
    standoff: float = 0.25
    rise: float = 0.08
    depth: float = 0.6
    cross: float = 0.8
    ik_q7: int = 8
    ik_solutions: int = 4
    retry_skipped: bool = True
    planning: ViewPlanningConfig = field(default_factory=ViewPlanningConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, standoff=(-1.0, 2.0, "m"), rise=(-1.0, 1.0, "m"),
                     cross=(-2.0, 2.0, ""), ik_q7=(1, 1000, ""), ik_solutions=(1, 100, ""))
        fr = np.asarray((*self.heights, *self.lateral), float)  # lists too
        if len(self.heights) == 0 or len(self.lateral) == 0 or np.any((fr < 0) | (fr > 1)):
            raise CompassInputError("heights and lateral must be non-empty fractions in [0, 1]")
        if not 0.0 <= self.depth <= 1.0:
            raise CompassInputError(f"depth {self.depth} must be a fraction in [0, 1]")


def fixed_view_poses(task: Task, config: FixedViewsConfig) -> np.ndarray:
    """Camera poses T_world_cam (n, 4, 4) of the sequence, in visiting order (see module doc)."""
    sp = task.space
    out = np.asarray(sp.outward, float)
    axis = int(np.argmax(np.abs(out)))  # the axis the opening faces
    lat = 1 if axis != 1 else 0  # horizontal axis across the opening
    lo, hi = np.asarray(sp.interior_min, float), np.asarray(sp.interior_max, float)
    olo, ohi = np.asarray(sp.opening_min, float), np.asarray(sp.opening_max, float)
    plane = sp.opening_centre[axis]
    depth = hi[axis] - lo[axis]
    centre_lat = (olo[lat] + ohi[lat]) / 2
    poses = []
    for r, h in enumerate(config.heights):
        z = lo[2] + h * (hi[2] - lo[2])
        cols = config.lateral if r % 2 == 0 else config.lateral[::-1]
        for f in cols:
            y = olo[lat] + f * (ohi[lat] - olo[lat])
            cam = np.zeros(3)
            cam[axis], cam[lat], cam[2] = plane, y, z + config.rise
            cam = cam + config.standoff * out
            look = np.zeros(3)
            look[axis] = plane - out[axis] * config.depth * depth
            look[lat] = y - config.cross * (y - centre_lat) * 2
            look[2] = z
            d = look - cam
            poses.append(view_pose(look, d / np.linalg.norm(d), float(np.linalg.norm(d)), 0.0))
    return np.array(poses)


def fixed_view_configurations(ik: PandaIK, poses: np.ndarray, q_start: np.ndarray, config: FixedViewsConfig
                              ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Indices of the poses with an IK solution and, for each, its solutions (k, 7) [rad]
    nearest the previous view's first solution (the first view: nearest q_start)."""
    keep, sols = [], []
    q_ref = np.asarray(q_start, float)
    for i, T in enumerate(poses):
        S = ik.solve(T, "cam", q_ref, config.ik_q7).solutions[: config.ik_solutions]
        if len(S):
            keep.append(i)
            sols.append(S)
            q_ref = S[0]
    return np.array(keep, int), sols


class FixedViewsMethod(MapMethod):
    """The FV baseline (see the module docstring)."""

    def __init__(self, task: Task, world_config: WorldModelConfig, config: FixedViewsConfig,
                 rng: np.random.Generator, q_start: np.ndarray, K: np.ndarray, name: str = "fv") -> None:
        super().__init__(task, world_config, rng, q_start, K, name)
        self.config = config
        self.poses = fixed_view_poses(task, config)
        self.view_index, self.view_solutions = fixed_view_configurations(self.ik, self.poses, q_start, config)
        self.queue = list(range(len(self.view_index)))
        self.skipped: list[int] = []
        self.retried = False

    def decide(self) -> Decision:
        t0 = time.perf_counter()
        escape = self.escape()
        if escape is not None:
            return timed(escape, t0)
        attempted = succeeded = 0
        while True:
            if not self.queue and self.skipped and self.config.retry_skipped and not self.retried:
                self.queue, self.skipped, self.retried = self.skipped, [], True
            if not self.queue:
                return timed(Decision(None, StopReason.EXPLORED, Phase.EXPLORE, attempted, succeeded,
                                      stats={"views": len(self.view_index)}), t0)
            k = self.queue.pop(0)
            attempted += 1
            path = plan_to(self.world, self.view_solutions[k], self.config.planning, self.rng)
            if path is None:
                self.skipped.append(k)
                continue
            succeeded += 1
            return timed(Decision(path, None, Phase.EXPLORE, attempted, succeeded,
                                  stats={"view": int(self.view_index[k]), "views": len(self.view_index)}), t0)
