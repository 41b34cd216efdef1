"""IG: greedy next-best view by volumetric information (Isler et al., ICRA 2016).

Each decision samples `n_views` candidate camera poses on a view hemisphere in front of
the opening (a new sample, up to `rounds` in all, while no view is worth going to): the
camera at a distance in `radius` [m] from the region of interest's centre (the confined
space's interior), in a direction drawn uniformly within `cone` [rad] of the
space's outward normal, looking at the centre (Isler's view sphere around the object);
with `aim_spread` > 0 the look-at point is drawn uniformly in the ROI box shrunk to that
fraction (the ROI here is a container, not one object). Each pose is solved by camera IK
(`ik_q7` q7 samples, at most `ik_solutions` solutions) and kept if a solution is valid on
the current map. Every valid view is scored by the configured formulation
(`ig_formulations`) over the ROI (the interior grown by `roi_margin` [m]; views that move
the camera less than `min_view_change` [m] and turn it less than as many [rad] are
dropped, as in COMPASS). The best view is chosen greedily and the shared planner plans to
it; if that fails the next best is tried, up to `max_attempts` (each a failed plan for
MPSR). The method stops when no view reaches `min_information`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..task import Task
from .base import Decision, Phase, StopReason
from .baseline_common import MapMethod, ViewPlanningConfig, interior_box, plan_to, timed
from .ig_formulations import IGFormulation, roi_mask, view_information
from .viewpoints import sample_direction_in_cone, view_configurations, view_pose
from .world_model import WorldModelConfig


@dataclass(frozen=True)
class GreedyIGConfig:
    """formulation; n_views candidate poses per sample, rounds samples at most; radius (min, max) [m] of the view
    hemisphere; cone [rad] half angle around the outward normal; aim_spread (see module
    doc); ik_q7, ik_solutions; rays (nu, nv) and max_range [m] of the information; roi_margin
    [m]; p_unknown prior occupancy of unknown voxels; min_information (voxels or bits) of a
    view worth going to; min_view_change [m] / [rad]; max_attempts planned views per
    decision; planning: the shared planner."""

    formulation: IGFormulation = IGFormulation.UNOBSERVED
    n_views: int = 48
    rounds: int = 3
    radius: tuple[float, float] = (0.35, 0.75)
    cone: float = 1.0
    aim_spread: float = 0.8
    ik_q7: int = 3
    ik_solutions: int = 2
    rays: tuple[int, int] = (20, 15)
    max_range: float = 1.0
    roi_margin: float = -0.01
    p_unknown: float = 0.5
    min_information: float = 8.0
    min_view_change: float = 0.1
    max_attempts: int = 3
    planning: ViewPlanningConfig = field(default_factory=ViewPlanningConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, radius=(0.0, 5.0, "m"), cone=(0.0, 3.1416, "rad"), max_range=(0.05, 10.0, "m"),
                     roi_margin=(-0.5, 0.5, "m"), p_unknown=(1e-6, 1 - 1e-6, ""), min_information=(0.0, 1e9, ""),
                     min_view_change=(0.0, 10.0, ""), ik_q7=(1, 1000, ""), ik_solutions=(1, 100, ""))
        if self.n_views < 1 or self.max_attempts < 1:
            raise CompassInputError("GreedyIGConfig needs n_views >= 1 and max_attempts >= 1")
        if not 0 < self.radius[0] <= self.radius[1]:
            raise CompassInputError(f"radius {self.radius} must satisfy 0 < min <= max [m]")
        if not 0.0 <= self.aim_spread <= 1.0:
            raise CompassInputError(f"aim_spread {self.aim_spread} must be a fraction in [0, 1]")


class GreedyIGMethod(MapMethod):
    """The IG baseline (see the module docstring)."""

    def __init__(self, task: Task, world_config: WorldModelConfig, config: GreedyIGConfig,
                 rng: np.random.Generator, q_start: np.ndarray, K: np.ndarray, name: str = "ig") -> None:
        super().__init__(task, world_config, rng, q_start, K, name)
        self.config = config
        self.roi_lo, self.roi_hi = interior_box(task, config.roi_margin)
        self.roi = roi_mask(self.world.occ, self.roi_lo, self.roi_hi)

    def candidates(self) -> tuple[np.ndarray, np.ndarray]:
        """Valid candidate configurations (n, 7) [rad] and their camera poses (n, 4, 4)."""
        config, rng = self.config, self.rng
        centre = (self.roi_lo + self.roi_hi) / 2
        half = (self.roi_hi - self.roi_lo) / 2 * config.aim_spread
        out = np.asarray(self.task.space.outward, float)
        Q = []
        for _ in range(config.n_views):
            d = sample_direction_in_cone(out, config.cone, rng)
            cam = centre + rng.uniform(*config.radius) * d
            aim = centre + rng.uniform(-1, 1, 3) * half
            v = aim - cam
            T = view_pose(aim, v / np.linalg.norm(v), float(np.linalg.norm(v)), rng.uniform(-np.pi / 2, np.pi / 2))
            Q.extend(view_configurations(self.ik, T, self.world.q, config.ik_q7, config.ik_solutions))
        if not Q:
            return np.zeros((0, 7)), np.zeros((0, 4, 4))
        Q = np.array(Q)
        Q = Q[self.world.checker.are_valid(Q)]
        T = self.world.kin.T_world_cam_batch(Q) if len(Q) else np.zeros((0, 4, 4))
        return Q, T

    def scored_candidates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Valid candidates (n, 7), their camera poses (n, 4, 4) and information (n,)
        (-inf for views too close to the current one)."""
        config = self.config
        Q, T = self.candidates()
        if len(Q) == 0:
            return Q, T, np.zeros(0)
        info = view_information(self.world.occ, self.roi, T, self.K, config.max_range, config.rays, config.formulation,
                                config.p_unknown)
        T_now = self.world.kin.T_world_cam_batch(self.world.q[None])[0]
        moved = np.linalg.norm(T[:, :3, 3] - T_now[:3, 3], axis=1)
        turned = np.arccos(np.clip(T[:, :3, 2] @ T_now[:3, 2], -1.0, 1.0))
        return Q, T, np.where((moved < config.min_view_change) & (turned < config.min_view_change), -np.inf, info)

    def decide(self) -> Decision:
        t0 = time.perf_counter()
        escape = self.escape()
        if escape is not None:
            return timed(escape, t0)
        config = self.config
        for _ in range(config.rounds):
            Q, T, info = self.scored_candidates()
            if len(Q) and info.max() >= config.min_information:
                break
        stats = {"candidates": len(Q)}
        if len(Q) == 0:
            return timed(Decision(None, StopReason.NO_REACHABLE_VIEW, Phase.EXPLORE, stats=stats), t0)
        order = np.argsort(-info, kind="stable")
        attempted = succeeded = 0
        for k in order[: config.max_attempts]:
            if not info[k] >= config.min_information:
                break
            attempted += 1
            path = plan_to(self.world, Q[k][None], config.planning, self.rng)
            if path is None:
                continue
            succeeded += 1
            stats.update(information=float(info[k]))
            return timed(Decision(path, None, Phase.EXPLORE, attempted, succeeded, stats=stats), t0)
        stop = StopReason.PLANNING_FAILED if attempted else StopReason.NO_REACHABLE_VIEW
        stats.update(best_information=float(info[order[0]]))
        return timed(Decision(None, stop, Phase.EXPLORE, attempted, succeeded, stats=stats), t0)
