"""MUE-RRT (paper Sec. III-B-2): a tree of reachable camera viewpoints grown from the
current configuration, scored by U(x) = w . [G, D, M, H] / C, best node's path smoothed.

Our reading (NOTES.md): the tree lives in joint space (`motion.tree.JointTree`), every edge
a validated straight joint segment, every node a configuration q whose camera pose is
FK(q). Sampling: with probability p_frontier a frontier cluster (by size) gives a camera
target looking into its unknown side; with p_prior a point of interest gives one looking
at it; the target pose is solved by camera IK and the tree extends towards the solution
nearest the current configuration (connect mode). Otherwise a configuration uniform in a
box of +-local_range around the root (within the joint limits) is drawn and the tree takes
one step towards it (the map only lets the arm into space it has seen, so samples far from
the root are almost never reachable). Every node is reachable along
checked edges by construction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..mapping.self_occlusion import robot_view_gains
from ..motion.tree import JointTree
from ..robot.model import Q_MAX, Q_MIN
from .utility import heuristic, momentum, utility
from .viewpoints import sample_direction_in_cone, view_configurations, view_pose


@dataclass(frozen=True)
class TreeConfig:
    """iterations of sampling per decision; p_frontier / p_prior sampling probabilities
    (uniform otherwise); step [rad] longest tree edge; res [rad] edge check step; capacity
    nodes; view_distance (min, max) [m] of sampled views from their target; cone [rad] half
    angle around the frontier's unknown direction; local_range [rad]: uniform samples are
    drawn within +-local_range of the root (and the joint limits) (or around the outward direction of the
    confined space for points of interest); ik_q7 q7 samples of the camera IK; rays (nu,
    nv) for the gain; gain_range [m]; min_gain [voxels] for a node to count as a view;
    gain_in_space: count only unknown voxels inside the confined space's interior grown by
    space_margin [m] (where the target can be; negative: inset, so that voxels inside its
    boards and just outside them, which no view can clear, do not lure the camera),
    instead of all unknown voxels in view;
    min_view_change [m]: a node counts as a new view only if its camera moved at least this
    far from the root's, or turned by at least min_view_change rad (no creeping);
    self_occlusion: the gain leaves out the rays the robot's own body blocks at the node
    (`mapping.self_occlusion`: the self-filter drops those pixels, so they clear nothing)."""

    iterations: int = 40
    p_frontier: float = 0.4
    p_prior: float = 0.2
    p_hint: float = 0.4
    step: float = 0.15
    local_range: float = 0.6
    res: float = 0.005
    capacity: int = 1024
    view_distance: tuple[float, float] = (0.2, 0.45)
    cone: float = 0.6
    ik_q7: int = 3
    ik_solutions: int = 2
    rays: tuple[int, int] = (20, 15)
    gain_range: float = 1.0
    min_gain: int = 8
    gain_in_space: bool = True
    min_view_change: float = 0.1
    space_margin: float = -0.01
    self_occlusion: bool = True

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, step=(1e-3, 3.2, "rad"), res=(1e-4, 0.5, "rad"), local_range=(1e-3, 10.0, "rad"),
                     cone=(0.0, 3.1416, "rad"), gain_range=(1e-3, 10.0, "m"), min_view_change=(0.0, 10.0, ""),
                     space_margin=(-0.5, 0.5, "m"), view_distance=(0.0, 5.0, "m"), ik_q7=(1, 1000, ""),
                     ik_solutions=(1, 100, ""))
        if not (0 <= self.p_frontier and 0 <= self.p_prior and 0 <= self.p_hint
                and self.p_frontier + max(self.p_prior, self.p_hint) <= 1):
            raise CompassInputError(
                f"p_frontier {self.p_frontier} + p_prior {self.p_prior} must be probabilities summing to <= 1")
        if self.iterations < 1 or self.capacity < 2:
            raise CompassInputError("TreeConfig needs iterations >= 1 and capacity >= 2")


@dataclass(frozen=True)
class UtilityWeights:
    """w = [w_g, w_d, w_m, w_h] of G, D, M, H; cost_offset [rad] added to C."""

    gain: float = 1.0
    momentum: float = 0.2
    manipulability: float = 0.3
    heuristic: float = 0.5
    cost_offset: float = 1.0

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.gain, self.momentum, self.manipulability, self.heuristic)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, gain=(0.0, 1e3, ""), momentum=(0.0, 1e3, ""), manipulability=(0.0, 1e3, ""),
                     heuristic=(0.0, 1e3, ""), cost_offset=(1e-6, 1e3, "rad"))


@dataclass(frozen=True, eq=False)
class ScoredTree:
    """The grown tree and its node scores: q (N, 7), T_world_cam (N, 4, 4), the terms and U
    (N,) (node 0 is the root, scored -inf), and the tree itself for paths."""

    tree: JointTree
    T_world_cam: np.ndarray
    G: np.ndarray
    D: np.ndarray
    M: np.ndarray
    H: np.ndarray
    C: np.ndarray
    U: np.ndarray


def grow_tree(world, ik, frontiers, points, outward: np.ndarray, config: TreeConfig,
              rng: np.random.Generator, hinted: bool = False, checker=None) -> JointTree:
    """Grow a viewpoint tree from world.q on checker (default world.checker; see the module
    docstring); hinted: the points are detector hints (sampled with p_hint instead of p_prior)."""
    checker = world.checker if checker is None else checker
    tree = JointTree(world.q, checker, capacity=config.capacity, step=config.step, res=config.res)
    sizes = np.array([c.size for c in frontiers], float)
    pf = sizes / sizes.sum() if len(sizes) else sizes
    pts = np.asarray(points, float).reshape(-1, 3)
    lo = np.maximum(Q_MIN, world.q - config.local_range)
    span = np.minimum(Q_MAX, world.q + config.local_range) - lo
    for _ in range(config.iterations):
        if tree.count >= config.capacity - 2:
            break
        u = rng.uniform()
        T = None
        if u < config.p_frontier and len(frontiers):
            c = frontiers[int(rng.choice(len(frontiers), p=pf))]
            d = sample_direction_in_cone(c.direction, config.cone, rng)
            T = view_pose(c.centroid_world, d, rng.uniform(*config.view_distance), rng.uniform(-np.pi / 2, np.pi / 2))
        elif u < config.p_frontier + (config.p_hint if hinted else config.p_prior) and len(pts):
            p = pts[int(rng.integers(len(pts)))]
            d = sample_direction_in_cone(-np.asarray(outward, float), config.cone, rng)
            T = view_pose(p, d, rng.uniform(*config.view_distance), rng.uniform(-np.pi / 2, np.pi / 2))
        if T is not None:
            for q in view_configurations(ik, T, world.q, config.ik_q7, config.ik_solutions):
                tree.extend(q, connect=True)
        else:  # rng.uniform(lo, hi), which is lo + (hi - lo) * random(), without its argument checks
            tree.extend(lo + span * rng.random(lo.size), connect=False)
    return tree


def score_tree(world, tree: JointTree, K: np.ndarray, t_prev: np.ndarray | None, points: np.ndarray,
               weights: UtilityWeights, config: TreeConfig, gain_map=None) -> ScoredTree:
    """Evaluate U on every node of the tree (node 0, the root, gets -inf). gain_map: the
    map G is counted on (default the world's)."""
    Q = tree.q.copy()
    T = world.kin.T_world_cam_batch(Q)
    G = robot_view_gains(world, gain_map if gain_map is not None else world.occ, Q, T, K, config.gain_range,
                         config.rays, self_occlusion=config.self_occlusion).astype(float)
    t = T[:, :3, 3]
    D = momentum(t_prev, t[0], t) if t_prev is not None else np.zeros(len(Q))
    M = world.kin.manipulability_batch(Q)
    H = heuristic(T[:, :3, 2], t, points)
    C = tree_costs(Q, tree.parent[: len(Q)])
    U = utility(G, D, M, H, C, weights.as_tuple(), weights.cost_offset)
    U[0] = -np.inf
    U[G < config.min_gain] = -np.inf
    moved = np.linalg.norm(t - t[0], axis=1)
    turned = np.arccos(np.clip(T[:, :3, 2] @ T[0, :3, 2], -1.0, 1.0))
    U[(moved < config.min_view_change) & (turned < config.min_view_change)] = -np.inf
    return ScoredTree(tree, T, G, D, M, H, C, U)


def tree_costs(Q: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """C (N,) [rad]: joint path length from the root to every node along the tree (parents
    precede their children), equal to `utility.motion_cost` of each `path_to(k)`."""
    C = np.zeros(len(Q))
    step = np.linalg.norm(Q - Q[np.maximum(parent, 0)], axis=1)
    for k in range(1, len(Q)):
        C[k] = C[parent[k]] + step[k]
    return C


def shortcut(path: np.ndarray, edge_valid) -> np.ndarray:
    """Greedy shortcutting: from each kept waypoint jump to the farthest later waypoint
    reachable by one valid straight segment (`edge_valid(q0, q1) -> bool`)."""
    path = np.asarray(path, float)
    out, i = [path[0]], 0
    while i < len(path) - 1:
        j = len(path) - 1
        while j > i + 1 and not edge_valid(path[i], path[j]):
            j -= 1
        out.append(path[j])
        i = j
    return np.array(out)


def validated_path(raw: np.ndarray, checker, resolution: float) -> np.ndarray | None:
    """The tree path `raw` (m, 7) [rad] shortcut and re-checked at `resolution` [rad]; the raw
    path if only it passes the check; None if neither does."""
    path = shortcut(raw, lambda a, b: checker.edge_valid(a, b, resolution))
    if checker.path_valid(path, resolution):
        return path
    return raw if checker.path_valid(raw, resolution) else None
