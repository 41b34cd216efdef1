"""The oracle reference (NOT a competitor): told the target's true position by the trial
runner, it goes straight to the best reachable view of it.

It lives on the trial side so that no method package can import it (the layering test
checks it). It shares the world model (map, validity) and the planner with every method,
so it still has to see space before moving through it; only the knowledge of where the
target is differs. Each decision samples `n_views` camera poses looking at the target's
centre from `distance` [m], in directions within `cone` [rad] of the confined space's
outward normal; keeps those with a valid IK solution whose line of sight to the target is
not blocked by a voxel the map holds occupied (ignoring voxels within `target_clearance`
[m] of the target centre); ranks them by joint distance from the current configuration
(nearest first: the shortest way to see the target) and plans to the first reachable one.
A view whose camera lies within `revisit_radius` [m] of an executed oracle view is not
chosen again (after a view that did not reveal the target, the map has learned the
occluder). Its TFT and PFT bound from below what a searching method can reach.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import check_field_types, check_ranges
from ..exploration.base import Decision, Phase, StopReason
from ..exploration.baseline_common import MapMethod, ViewPlanningConfig, plan_to, timed
from ..exploration.viewpoints import sample_direction_in_cone, view_configurations, view_pose
from ..mapping.occupancy import VoxelState

#: The method name the trial runner recognises (never registered in exploration.registry).
ORACLE_METHOD = "oracle"


@dataclass(frozen=True)
class OracleConfig:
    """n_views sampled per round, up to `rounds` rounds per decision until some view is
    valid; distance (min, max) [m] of the camera from the
    target; cone [rad]; ik_q7 / ik_solutions; target_clearance [m]; revisit_radius [m];
    max_attempts plans per decision; planning: the shared planner."""

    n_views: int = 48
    rounds: int = 4
    distance: tuple[float, float] = (0.25, 0.8)
    cone: float = 0.9
    ik_q7: int = 3
    ik_solutions: int = 2
    target_clearance: float = 0.06
    revisit_radius: float = 0.05
    max_attempts: int = 6
    planning: ViewPlanningConfig = field(default_factory=ViewPlanningConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, n_views=(1, 100000, ""), rounds=(1, 1000, ""), distance=(0.0, 5.0, "m"),
                     cone=(0.0, 3.1416, "rad"),                      ik_q7=(1, 1000, ""), ik_solutions=(1, 100, ""),
                     target_clearance=(0.0, 0.5, "m"), revisit_radius=(0.0, 1.0, "m"), max_attempts=(1, 1000, ""))


def line_of_sight_clear(occ, a: np.ndarray, b: np.ndarray, clearance: float) -> bool:
    """Whether the segment a -> b [m] crosses no occupied voxel farther than clearance [m]
    from b (sampled at a quarter voxel)."""
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / (occ.resolution / 4))))
    s = np.linspace(0.0, 1.0, n)[:, None]
    p = a + s * (b - a)
    p = p[np.linalg.norm(p - b, axis=1) > clearance]
    return not np.any(occ.state_at(p) == VoxelState.OCCUPIED)


class OracleMethod(MapMethod):
    """The oracle reference (see the module docstring); target_pos (3,) [m] from the runner."""

    def __init__(self, task, world_config, config: OracleConfig, rng: np.random.Generator, q_start, K,
                 target_pos: np.ndarray, name: str = ORACLE_METHOD) -> None:
        super().__init__(task, world_config, rng, q_start, K, name)
        self.config = config
        self.target = np.asarray(target_pos, float)
        self.visited: list[np.ndarray] = []

    def decide(self) -> Decision:
        t0 = time.perf_counter()
        escape = self.escape()  # as the baselines: out of a start the first frame made invalid
        if escape is not None:
            return timed(escape, t0)
        config, rng = self.config, self.rng
        Q, cams = np.zeros((0, 7)), np.zeros((0, 3))
        for _ in range(config.rounds):
            Q, cams = self._candidates()
            if len(Q):
                break
        attempted = succeeded = 0
        stats = {"candidates": len(Q)}
        if len(Q) == 0:
            return timed(Decision(None, StopReason.NO_REACHABLE_VIEW, Phase.EXPLORE, stats=stats), t0)
        for k in np.argsort(np.linalg.norm(Q - self.world.q, axis=1), kind="stable")[: config.max_attempts]:
            attempted += 1
            path = plan_to(self.world, Q[k][None], config.planning, rng)
            if path is None:
                continue
            succeeded += 1
            self.visited.append(cams[k])
            return timed(Decision(path, None, Phase.EXPLORE, attempted, succeeded, stats=stats), t0)
        return timed(Decision(None, StopReason.PLANNING_FAILED, Phase.EXPLORE, attempted, succeeded, stats=stats), t0)

    def _candidates(self) -> tuple[np.ndarray, np.ndarray]:
        """Valid view configurations (n, 7) [rad] with a clear line of sight, and their
        camera positions (n, 3) [m]."""
        config, rng = self.config, self.rng
        out = np.asarray(self.task.space.outward, float)
        Q, cams = [], []
        for _ in range(config.n_views):
            d = -sample_direction_in_cone(out, config.cone, rng)  # viewing direction, into the space
            T = view_pose(self.target, d, rng.uniform(*config.distance), rng.uniform(-np.pi / 2, np.pi / 2))
            cam = T[:3, 3]
            if any(np.linalg.norm(cam - v) < config.revisit_radius for v in self.visited):
                continue
            if not line_of_sight_clear(self.world.occ, cam, self.target, config.target_clearance):
                continue
            for q in view_configurations(self.ik, T, self.world.q, config.ik_q7, config.ik_solutions):
                Q.append(q)
                cams.append(cam)
        if not Q:
            return np.zeros((0, 7)), np.zeros((0, 3))
        Q, cams = np.array(Q), np.array(cams)
        ok = self.world.checker.are_valid(Q)
        return Q[ok], cams[ok]


def make_oracle_method(scene, task, compass_config, rng: np.random.Generator, q_start, K,
                       config: OracleConfig | None = None) -> OracleMethod:
    """The oracle for a simulated scene: the target's true centre comes from the scene."""
    return OracleMethod(task, compass_config.world, config or OracleConfig(), rng, q_start, K,
                        np.asarray(scene.target.pos, float))
