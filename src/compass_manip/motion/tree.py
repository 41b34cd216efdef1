"""Joint-space tree primitives shared by the planner and the exploration methods.

Nodes are rows of a preallocated (capacity, 7) array [rad] with a parent index per node
(-1 for roots) and a node count; edges are straight joint segments checked with the
`ValidityChecker`'s numba edge kernel at `res` [rad] (largest joint step between checked
states). `nearest`, `steer` and `extend` are numba functions (usable from other kernels);
`JointTree` wraps them for Python callers such as the viewpoint trees of exploration.
"""
from __future__ import annotations

import numba as nb
import numpy as np

from ..robot.model import check_q
from .validity import edge_valid_from_kernel, edge_valid_kernel

TRAPPED, ADVANCED, REACHED = 0, 1, 2
#: Most nodes one `extend` call may add (connect mode).
MAX_NEW_PER_EXTEND = 64


@nb.njit(cache=True)
def edge_ok(q0, q1, res, args):
    """ValidityChecker.edge_valid in numba: every state at joint steps <= `res` [rad] valid,
    all checked (in bisection order). `args` is `ValidityChecker.kernel_args()`."""
    m = 0.0
    for j in range(q0.shape[0]):
        m = max(m, abs(q1[j] - q0[j]))
    n = max(1, int(np.ceil(m / res)))
    return edge_valid_kernel(q0, q1, n, args.kin, args.robot, args.grid, args.prims, args.limits, args.params)


@nb.njit(cache=True)
def edge_ok_from(q0, q1, res, args):
    """`edge_ok` for a q0 known to be valid on the checker of `args` (a tree node: roots are
    checked before planning, every other node was the end of a checked edge): the same
    answer without checking q0 again."""
    m = 0.0
    for j in range(q0.shape[0]):
        m = max(m, abs(q1[j] - q0[j]))
    n = max(1, int(np.ceil(m / res)))
    return edge_valid_from_kernel(q0, q1, n, args.kin, args.robot, args.grid, args.prims, args.limits, args.params)


@nb.njit(cache=True)
def nearest(nodes, n, q):
    """Index of the node among the first n rows of nodes nearest q (Euclidean, joint space)."""
    best, kbest = np.inf, 0
    for k in range(n):
        d = 0.0
        for j in range(q.shape[0]):
            e = nodes[k, j] - q[j]
            d += e * e
        if d < best:
            best, kbest = d, k
    return kbest


@nb.njit(cache=True)
def steer(q_from, q_to, step):
    """The configuration at most `step` [rad] (Euclidean) from q_from towards q_to, and
    whether it is q_to itself."""
    d = np.sqrt(np.sum((q_to - q_from) ** 2))
    if d <= step:
        return q_to.copy(), True
    return q_from + (q_to - q_from) * (step / d), False


@nb.njit(cache=True)
def extend(args, nodes, parent, count, q_target, step, res, connect, nodes_valid):
    """Extend a tree from its node nearest q_target by steps of at most `step` [rad]: one
    step (connect=False) or until q_target is reached or an edge is blocked (connect=True).
    nodes_valid: every node is known valid on the checker (the roots were checked), so an
    edge's first state is not checked again (`edge_ok_from`; the same answers).

    Adds nodes in place after the first `count` rows. Returns (TRAPPED | ADVANCED |
    REACHED, index of the last node reached, new count, edge checks).
    """
    k = nearest(nodes, count, q_target)
    result, n_checks = TRAPPED, 0
    for _ in range(MAX_NEW_PER_EXTEND):
        if count >= nodes.shape[0]:
            break
        q_new, reached = steer(nodes[k], q_target, step)
        n_checks += 1
        if not (edge_ok_from(nodes[k], q_new, res, args) if nodes_valid else edge_ok(nodes[k], q_new, res, args)):
            return result, k, count, n_checks
        nodes[count] = q_new
        parent[count] = k
        k = count
        count += 1
        if reached:
            return REACHED, k, count, n_checks
        result = ADVANCED
        if not connect:
            break
    return result, k, count, n_checks


@nb.njit(cache=True)
def extend_each(args, nodes, parent, count, targets, step, res, connect, stop_count, nodes_valid):
    """`extend` towards each row of targets (m, 7) [rad] in order until the tree holds
    stop_count nodes (checked before each call). Returns (new count, calls made, edge checks)."""
    used, checks = 0, 0
    for i in range(targets.shape[0]):
        if count >= stop_count:
            break
        _, _, count, c = extend(args, nodes, parent, count, targets[i], step, res, connect, nodes_valid)
        used += 1
        checks += c
    return count, used, checks


class JointTree:
    """A tree of valid configurations rooted at q_root (7,) [rad], grown with `extend`.

    validity: a `ValidityChecker`; step [rad]: longest edge; res [rad]: edge check step.
    Every node is valid and reachable from the root along checked edges (`path_to`).
    """

    def __init__(self, q_root: np.ndarray, validity, capacity: int = 2048, step: float = 0.3,
                 res: float = 0.02) -> None:
        q_root = check_q(q_root, "q_root")
        self.args = validity.kernel_args()
        self.nodes = np.empty((int(capacity), q_root.size))
        self.parent = np.full(int(capacity), -1, dtype=np.int64)
        self.nodes[0] = q_root
        self.count = 1
        self.step, self.res = float(step), float(res)
        self.edge_checks = 0
        # a valid root makes every node valid: edges then skip their (known) first state; an
        # invalid root fails every edge from it, as before (the tree never grows)
        self.root_valid = bool(validity.is_valid(q_root))

    def extend(self, q_target: np.ndarray, connect: bool = False) -> tuple[int, int]:
        """Grow towards q_target (7,) [rad]; returns (TRAPPED | ADVANCED | REACHED, index of
        the last node reached)."""
        r, k, self.count, c = extend(self.args, self.nodes, self.parent, self.count,
                                     np.asarray(q_target, dtype=np.float64), self.step, self.res, connect,
                                     self.root_valid)
        self.edge_checks += c
        return int(r), int(k)

    def extend_each(self, targets: np.ndarray, stop_count: int, connect: bool = False) -> int:
        """`extend` towards each row of targets (m, 7) [rad] in order while the tree holds
        fewer than stop_count nodes, in one compiled loop; returns how many targets were used."""
        targets = np.ascontiguousarray(targets, dtype=np.float64).reshape(-1, self.nodes.shape[1])
        self.count, used, c = extend_each(self.args, self.nodes, self.parent, self.count, targets, self.step,
                                          self.res, connect, int(stop_count), self.root_valid)
        self.edge_checks += c
        return int(used)

    def nearest(self, q: np.ndarray) -> int:
        return int(nearest(self.nodes, self.count, np.asarray(q, dtype=np.float64)))

    def path_to(self, k: int) -> np.ndarray:
        """Waypoints (m, 7) [rad] from the root to node k along the tree's edges."""
        idx = []
        while k >= 0:
            idx.append(k)
            k = int(self.parent[k])
        return self.nodes[idx[::-1]].copy()

    @property
    def q(self) -> np.ndarray:
        """The nodes (count, 7) [rad] (a view)."""
        return self.nodes[: self.count]
