"""GSE: geometric sampling-based exploration in the spirit of NBVP (Bircher et al. 2016)
and DSVP (Zhu et al. 2021), adapted to an arm in joint space.

Local stage (NBVP's receding-horizon tree, DSVP's local RRT): each decision grows a
`motion.tree.JointTree` from the current configuration by plain RRT expansion: targets
drawn uniformly in the joint limits (or within +-`local_range` [rad] of the root when it
is finite), the nearest node stepping towards them by at most `step` [rad] along checked
edges: no bias towards frontiers or points of interest. Every node's camera pose gets the
geometric information gain G (distinct unknown voxels in view, `mapping.infogain`, on the
same region COMPASS counts, the confined space grown by `roi_margin` [m]). The score is
NBVP's G exp(-lambda C), C the joint path length [rad] along the tree (lambda = 0: gain
only). The best node (G >= `min_gain`, camera moved or turned by `min_view_change`) is
reached along its tree path, shortcut and re-validated as COMPASS's is; like DSVP the whole
path is executed. With no node worth going to, a larger tree is grown once
(`retry_iterations_factor`, the same retry COMPASS gets) before the global stage.

Global stage (DSVP's dual stage): when no tree node gains enough, the frontier clusters of
the map inside the exploration bounds (the interior grown by `global_margin` [m]), nearest
to the camera first, up to `global_tries`, each give `global_samples` views looking into
their unknown side (cone `global_cone` [rad], distance `global_distance` [m]); their valid
IK solutions go to the shared planner and the first cluster it reaches is executed (a
cluster with valid views but no plan is a failed plan for MPSR). No frontier left:
EXPLORED; none reachable: NO_REACHABLE_VIEW.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..mapping.infogain import info_gain_batch
from ..motion.tree import JointTree
from ..robot.model import Q_MAX, Q_MIN
from ..task import Task
from .base import Decision, Phase, StopReason
from .baseline_common import MapMethod, ViewPlanningConfig, interior_box, plan_to, timed
from .mue_rrt import validated_path
from .utility import tree_path_costs
from .viewpoints import sample_direction_in_cone, view_configurations, view_pose
from .world_model import WorldModelConfig


@dataclass(frozen=True)
class GSEConfig:
    """iterations of tree expansion per decision (a second tree with
    retry_iterations_factor times as many when the first has no node worth going to, as
    COMPASS retries); step [rad] longest edge; res [rad] edge
    check step; local_range [rad] (inf: the whole joint range); capacity nodes; rays and
    gain_range [m] of G; roi_margin [m]; min_gain [voxels]; path_lambda [1/rad] NBVP's cost
    discount; min_view_change [m] / [rad]; max_attempts best nodes tried when the final path
    fails; verify_resolution [rad]; global_tries frontier clusters tried; global_samples views
    per cluster, in a cone of global_cone [rad] around its unknown side, from
    global_distance (min, max) [m] of its centroid; global_margin [m]: frontiers count
    within the interior grown by it (the exploration bounds); ik_q7 / ik_solutions of the
    global views; planning: the shared planner."""

    iterations: int = 60
    retry_iterations_factor: int = 3
    step: float = 0.15
    res: float = 0.005
    local_range: float = float("inf")
    capacity: int = 1024
    rays: tuple[int, int] = (20, 15)
    gain_range: float = 1.0
    roi_margin: float = -0.01
    min_gain: int = 8
    path_lambda: float = 0.5
    min_view_change: float = 0.1
    max_attempts: int = 3
    verify_resolution: float = 0.005
    global_tries: int = 4
    global_distance: tuple[float, float] = (0.2, 0.5)
    global_samples: int = 8
    global_cone: float = 0.6
    global_margin: float = 0.1
    ik_q7: int = 4
    ik_solutions: int = 2
    planning: ViewPlanningConfig = field(default_factory=ViewPlanningConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, step=(1e-3, 3.2, "rad"), res=(1e-4, 0.5, "rad"), gain_range=(1e-3, 10.0, "m"),
                     roi_margin=(-0.5, 0.5, "m"), path_lambda=(0.0, 1e3, "1/rad"), min_view_change=(0.0, 10.0, ""),
                     verify_resolution=(1e-4, 0.5, "rad"), global_distance=(0.0, 5.0, "m"),
                     global_cone=(0.0, 3.1416, "rad"), global_margin=(-0.5, 1.0, "m"), max_attempts=(1, 1000, ""),
                     retry_iterations_factor=(1, 100, ""), ik_q7=(1, 1000, ""), ik_solutions=(1, 100, ""))
        if self.iterations < 1 or self.capacity < 2 or self.step <= 0 or self.local_range <= 0:
            raise CompassInputError("GSEConfig needs iterations >= 1, capacity >= 2, step > 0, local_range > 0")
        if self.path_lambda < 0:
            raise CompassInputError(f"path_lambda {self.path_lambda} must be >= 0")


def grow_random_tree(world, config: GSEConfig, rng: np.random.Generator) -> JointTree:
    """A tree of valid configurations from world.q expanded towards uniform random targets."""
    tree = JointTree(world.q, world.checker, capacity=config.capacity, step=config.step, res=config.res)
    lo = np.maximum(Q_MIN, world.q - config.local_range)
    hi = np.minimum(Q_MAX, world.q + config.local_range)
    # = `tree.extend(rng.uniform(lo, hi))` per iteration while tree.count < capacity - 2, in
    # one compiled loop: uniform(lo, hi) is lo + (hi - lo) * random(), so all targets are drawn
    # at once and the generator is then left where the used draws leave it
    state = rng.bit_generator.state
    targets = lo + (hi - lo) * rng.random((config.iterations, lo.size))
    used = tree.extend_each(targets, config.capacity - 2)
    rng.bit_generator.state = state
    rng.random((used, lo.size))
    return tree


def node_scores(G: np.ndarray, C: np.ndarray, path_lambda: float) -> np.ndarray:
    """NBVP's score G exp(-lambda C) of nodes with gains G (N,) and path costs C (N,) [rad]."""
    return np.asarray(G, float) * np.exp(-path_lambda * np.asarray(C, float))


class GSEMethod(MapMethod):
    """The GSE baseline (see the module docstring)."""

    def __init__(self, task: Task, world_config: WorldModelConfig, config: GSEConfig,
                 rng: np.random.Generator, q_start: np.ndarray, K: np.ndarray, name: str = "gse") -> None:
        super().__init__(task, world_config, rng, q_start, K, name)
        self.config = config
        self.last_tree: JointTree | None = None

    def decide(self) -> Decision:
        t0 = time.perf_counter()
        escape = self.escape()
        if escape is not None:
            return timed(escape, t0)
        d = self._local()
        if d is None:
            d = self._global()
        return timed(d, t0)

    def _local(self) -> Decision | None:
        for factor in (1, self.config.retry_iterations_factor):
            config = self.config if factor == 1 else replace(self.config, iterations=self.config.iterations * factor)
            d = self._local_tree(config)
            if d is not None:
                return d
        return None

    def _local_tree(self, config: GSEConfig) -> Decision | None:
        tree = self.last_tree = grow_random_tree(self.world, config, self.rng)
        Q = tree.q.copy()
        T = self.world.kin.T_world_cam_batch(Q)
        G = info_gain_batch(self.roi_map(config.roi_margin), T, self.K, config.gain_range, config.rays).astype(float)
        C = tree_path_costs(Q, tree.parent)  # = motion_cost of every path_to(k)
        S = node_scores(G, C, config.path_lambda)
        t = T[:, :3, 3]
        moved = np.linalg.norm(t - t[0], axis=1)
        turned = np.arccos(np.clip(T[:, :3, 2] @ T[0, :3, 2], -1.0, 1.0))
        S[(G < config.min_gain) | ((moved < config.min_view_change) & (turned < config.min_view_change))] = -np.inf
        S[0] = -np.inf
        if not np.isfinite(S).any():
            return None
        checker = self.world.checker
        attempted = succeeded = 0
        stats = {"stage": "local", "tree_nodes": int(tree.count)}
        for k in np.argsort(-S, kind="stable")[: config.max_attempts]:
            if not np.isfinite(S[k]):
                break
            attempted += 1
            path = validated_path(tree.path_to(int(k)), checker, config.verify_resolution)
            if path is None:
                continue
            succeeded += 1
            stats.update(G=float(G[k]), C=float(C[k]))
            return Decision(path, None, Phase.EXPLORE, attempted, succeeded, stats=stats)
        return Decision(None, StopReason.PLANNING_FAILED, Phase.EXPLORE, attempted, succeeded, stats=stats)

    def _global(self) -> Decision:
        config = self.config
        lo, hi = interior_box(self.task, config.global_margin)
        frontiers = [c for c in self.world.frontiers if np.all((c.centroid_world >= lo) & (c.centroid_world <= hi))]
        stats = {"stage": "global", "frontiers": len(frontiers)}
        if not frontiers:
            return Decision(None, StopReason.EXPLORED, Phase.EXPLORE, stats=stats)
        cam = self.world.kin.T_world_cam_batch(self.world.q[None])[0, :3, 3]
        dist = [float(np.linalg.norm(c.centroid_world - cam)) for c in frontiers]
        attempted = succeeded = 0
        for i in np.argsort(dist, kind="stable")[: config.global_tries]:
            c = frontiers[int(i)]
            S = []
            for _ in range(config.global_samples):
                d = sample_direction_in_cone(c.direction, config.global_cone, self.rng)
                T = view_pose(c.centroid_world, d, self.rng.uniform(*config.global_distance),
                              self.rng.uniform(-np.pi / 2, np.pi / 2))
                S.extend(view_configurations(self.ik, T, self.world.q, config.ik_q7, config.ik_solutions))
            if not S:
                continue
            S = np.array(S)
            S = S[self.world.checker.are_valid(S)]
            if len(S) == 0:
                continue
            attempted += 1
            S = S[np.argsort(np.linalg.norm(S - self.world.q, axis=1), kind="stable")]
            path = plan_to(self.world, S, config.planning, self.rng)
            if path is None:
                continue
            succeeded += 1
            return Decision(path, None, Phase.EXPLORE, attempted, succeeded, stats=stats)
        return Decision(None, StopReason.NO_REACHABLE_VIEW if not attempted else StopReason.PLANNING_FAILED,
                        Phase.EXPLORE, attempted, succeeded, stats=stats)
