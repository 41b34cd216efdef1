"""What the baselines (FV, IG, GSE) share with COMPASS and with each other.

Every baseline keeps the same `WorldModel` as COMPASS (map, swept space, validity checker
built from `CompassConfig.world`), so only viewpoint selection differs. Motions to a
chosen view come from the shared joint-space planner (`motion.planner.plan`: straight
line, then RRT-Connect, re-checked at the fine step) on the world model's checker; a view
without a valid plan counts as an attempted, failed plan (MPSR).

`roi_map` gives the map the baselines' gains are counted on: the confined space's interior
(grown by `margin` [m], negative = inset), every other voxel FREE, the same region COMPASS
counts its gain in (`TreeConfig.gain_in_space`, `space_margin`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import check_field_types
from ..mapping.occupancy import OccupancyMap
from ..motion.planner import DEFAULT_MAX_CHECKS, PlannerConfig, plan
from ..robot.ik import PandaIK
from ..robot.model import RobotConfig
from ..task import Task
from ..types import Observation
from .base import Decision
from .escape import EscapeConfig, escape_decision
from .nfa import safe_box_map
from .world_model import WorldModel, WorldModelConfig


@dataclass(frozen=True)
class ViewPlanningConfig:
    """planner: the shared motion planner's settings (edge-check budget per query: twice
    the default, the old 1 s where 0.5 s was the rule elsewhere; edge
    steps [rad]); max_goals: IK solutions of one view handed to the planner as goals."""

    planner: PlannerConfig = field(default_factory=lambda: PlannerConfig(max_checks=2 * DEFAULT_MAX_CHECKS))
    max_goals: int = 4

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)


class MapMethod:
    """Inputs common to the baselines: the world model (observe / executed / occupancy),
    camera IK and intrinsics K. Points of interest from the detector are ignored: the
    baselines' papers select views by geometry alone."""

    def __init__(self, task: Task, world_config: WorldModelConfig, rng: np.random.Generator, q_start: np.ndarray,
                 K: np.ndarray, name: str, robot: RobotConfig | None = None) -> None:
        self.name, self.task, self.rng = name, task, rng
        self.robot = robot or RobotConfig(base_pos=task.robot_base_pos, base_yaw=task.robot_base_yaw)
        self.world = WorldModel(q_start, world_config, self.robot, task)
        self.ik = PandaIK(self.world.kin)
        self.K = np.asarray(K, float)
        self._roi: OccupancyMap | None = None

    @property
    def occupancy(self):
        return self.world.occ

    def observe(self, obs: Observation) -> None:
        self.world.observe(obs)

    def add_points_of_interest(self, points_world: np.ndarray) -> None:
        """Ignored (see the class docstring)."""

    def executed(self, path: np.ndarray) -> None:
        self.world.add_swept(path)

    def escape(self) -> Decision | None:
        """COMPASS's escape (`escape.py`), shared so that no baseline is weaker in it: when
        a new frame has made the current configuration invalid on the map (a face frame
        seen just beside the hand at the start), a short motion out of it; else None."""
        return escape_decision(self.world.checker, self.world.q, EscapeConfig(), self.rng)

    def roi_map(self, margin: float) -> OccupancyMap:
        """The map restricted to the confined space's interior grown by margin [m] (reused)."""
        sp = self.task.space
        self._roi = safe_box_map(self.world.occ, np.asarray(sp.interior_min) - margin,
                                 np.asarray(sp.interior_max) + margin, self._roi)
        return self._roi


def plan_to(world: WorldModel, goals: np.ndarray, config: ViewPlanningConfig, rng: np.random.Generator
            ) -> np.ndarray | None:
    """A validated joint path (m, 7) [rad] from world.q to one of goals (k, 7), or None."""
    G = np.asarray(goals, float).reshape(-1, 7)[: config.max_goals]
    if len(G) == 0:
        return None
    r = plan(world.q, G, world.checker, config.planner, rng)
    return r.path if r.success else None


def timed(d: Decision, t0: float) -> Decision:
    return replace(d, compute_s=time.perf_counter() - t0)


def interior_box(task: Task, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """The confined space's interior box grown by margin [m] (negative: inset)."""
    return (np.asarray(task.space.interior_min, float) - margin, np.asarray(task.space.interior_max, float) + margin)
