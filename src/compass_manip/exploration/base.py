"""The interface every exploration method implements, and what a decision returns.

A method is built from the `Task` (what a robot is told before a trial), its own frozen
config and an explicit `np.random.Generator`. During the trial it receives every
`Observation` (depth, RGB, camera pose, time, joint state: never simulator labels), the
points of interest the detector proposes (low-confidence matches of the target query),
and the joint path the robot actually executed. On each `decide()` it returns a
`Decision`: a validated joint path from the current configuration to its next view, or a
typed `StopReason`. The trial decides what happens next (execution, detection, timing).

Imports allowed here and in every method module: task, types, errors, geometry, robot,
mapping, motion (tests/test_exploration_layering.py checks it).
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..types import Observation


class StopReason(enum.Enum):
    """Why a method has no next view."""

    NO_REACHABLE_VIEW = "no reachable viewpoint gains anything"
    PLANNING_FAILED = "no valid path to any chosen viewpoint"
    EXPLORED = "nothing left to explore"


class Phase(enum.Enum):
    NFA = "nfa"
    EXPLORE = "explore"


@dataclass(frozen=True, eq=False)
class Decision:
    """One decision: `path` (m, 7) [rad] from the current configuration (validated against
    the method's map) or None with `stop` set; `phase` it belongs to; `plans_attempted` /
    `plans_succeeded`: path validations this decision tried and passed (for MPSR);
    `compute_s` [s] wall time of the decision; `stats`: named figures for logs
    (e.g. tree size, chosen utility terms); `debug`: read-only arrays for viewers (video,
    Rerun), never read by the trial: for tree methods 'tree_cam_world' (N, 3) [m] and
    'tree_view_dir' (N, 3) camera positions and optical axes of the nodes, 'tree_parent'
    (N,) (-1 at the root), 'tree_utility' (N,) (-inf: not a candidate), 'chosen_node'."""

    path: np.ndarray | None
    stop: StopReason | None
    phase: Phase
    plans_attempted: int = 0
    plans_succeeded: int = 0
    compute_s: float = 0.0
    stats: dict = field(default_factory=dict)
    debug: dict = field(default_factory=dict)


class ExplorationMethod(Protocol):
    """What the trial needs from a method (see the module docstring)."""

    name: str

    def observe(self, obs: Observation) -> None:
        """Integrate one observation (depth into the map; obs.q is the joint state)."""

    def add_points_of_interest(self, points_world: np.ndarray) -> None:
        """Points (N, 3) [m] the detector flagged as possible partial views of the target."""

    def executed(self, path: np.ndarray) -> None:
        """The joint path (m, 7) [rad] the robot actually followed since the last call."""

    def decide(self) -> Decision:
        """The next view: a validated path from the current configuration, or a stop."""

    @property
    def occupancy(self):
        """The method's `mapping.occupancy.OccupancyMap` (read-only use by the trial's metrics)."""
