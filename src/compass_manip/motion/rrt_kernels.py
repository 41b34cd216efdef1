"""Numba kernels of the RRT-Connect planner: tree growth, connection and shortcutting.

`args` is `ValidityChecker.kernel_args()` (a `KernelArgs`); tree growth is `tree.extend`.
Edges are straight joint segments checked at a given joint resolution [rad]. Randomness: a
splitmix64 stream in a (1,) uint64 array, so a seed gives the same tree and path.
"""
from __future__ import annotations

import numba as nb
import numpy as np

from .tree import MAX_NEW_PER_EXTEND, REACHED, TRAPPED, edge_ok, extend
from .validity import config_valid_kernel

__all__ = ["STATUS_RUNNING", "STATUS_CONNECTED", "STATUS_FULL", "MAX_NEW_PER_ITER", "edge_ok", "states_valid",
           "rrt_connect_kernel", "simplify_kernel"]

STATUS_RUNNING, STATUS_CONNECTED, STATUS_FULL = 0, 1, 2
MAX_NEW_PER_ITER = MAX_NEW_PER_EXTEND


@nb.njit(cache=True, inline="always")
def _uniform01(state):
    """Next float in [0, 1) of a splitmix64 stream kept in state[0] (uint64)."""
    z = state[0] + np.uint64(0x9E3779B97F4A7C15)
    state[0] = z
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@nb.njit(cache=True)
def states_valid(Q, args):
    """(N,) validity of Q (N,7) with ValidityChecker's kernel, sequentially."""
    kin, robot, grid, prims, limits, params = args
    links = np.empty((kin.parent.shape[0], 4, 4))
    W = np.empty((robot.radii.shape[0], 3))
    out = np.empty(Q.shape[0], np.bool_)
    for n in range(Q.shape[0]):
        out[n] = config_valid_kernel(Q[n], kin, robot, grid, prims, limits, params, links, W)
    return out


@nb.njit(cache=True)
def _grow(args, nodes, parent, counts, t, q_target, step, res, connect):
    """`tree.extend` on tree t of several sharing one `counts` array (the planner's roots, the
    start and the goals, are checked valid before any tree is grown)."""
    r, k, counts[t], n_checks = extend(args, nodes, parent, counts[t], q_target, step, res, connect, True)
    return r, k, n_checks


@nb.njit(cache=True)
def rrt_connect_kernel(args, lo, hi, res, step, nodes0, parent0, nodes1, parent1,
                       counts, link, state, iters, max_checks):
    """Run up to `iters` RRT-Connect iterations on the start tree (0) and goal tree (1),
    stopping before an iteration once `max_checks` edge checks have been made in this call
    (an iteration makes at most 1 + MAX_NEW_PER_ITER, so the count may pass it by that much).

    counts (2,) node counts; link[0] the tree extended next, on connection link[1], link[2]
    are the meeting nodes in trees 0 and 1. Returns (STATUS_*, edge checks). The result of
    a sequence of calls depends only on the iterations run, not on how they are split.
    """
    q_rand = np.empty(lo.shape[0])
    n_checks = 0
    cap = min(nodes0.shape[0], nodes1.shape[0])
    for _ in range(iters):
        if n_checks >= max_checks:
            return STATUS_RUNNING, n_checks
        if max(counts[0], counts[1]) + 2 * MAX_NEW_PER_ITER >= cap:
            return STATUS_FULL, n_checks
        for j in range(lo.shape[0]):
            q_rand[j] = lo[j] + (hi[j] - lo[j]) * _uniform01(state)
        a = link[0]
        if a == 0:
            nA, pA, nB, pB = nodes0, parent0, nodes1, parent1
        else:
            nA, pA, nB, pB = nodes1, parent1, nodes0, parent0
        r, k, c = _grow(args, nA, pA, counts, a, q_rand, step, res, False)
        n_checks += c
        if r != TRAPPED:
            target = nA[k].copy()
            r2, k2, c2 = _grow(args, nB, pB, counts, 1 - a, target, step, res, True)
            n_checks += c2
            if r2 == REACHED:
                link[1 + a] = k
                link[2 - a] = k2
                return STATUS_CONNECTED, n_checks
        link[0] = 1 - a
    return STATUS_RUNNING, n_checks


@nb.njit(cache=True)
def _reduce_vertices(args, path, res):
    """Greedily connect each kept waypoint to the farthest later one with a valid edge."""
    n = path.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    keep[0] = True
    n_checks, i = 0, 0
    while i < n - 1:
        j = n - 1
        while j > i + 1:
            n_checks += 1
            if edge_ok(path[i], path[j], res, args):
                break
            j -= 1
        keep[j] = True
        i = j
    return path[keep].copy(), n_checks


@nb.njit(cache=True)
def simplify_kernel(args, path, res, rounds, state):
    """Shortcut a valid path: vertex reduction, then `rounds` random shortcuts between
    points on two different segments (OMPL's shortcutPath), then vertex reduction again.
    Every segment of the result has itself been checked at `res`."""
    path, n_checks = _reduce_vertices(args, path, res)
    for _ in range(rounds):
        n = path.shape[0]
        if n < 3:
            break
        seg = np.sqrt(np.sum((path[1:] - path[:-1]) ** 2, axis=1))
        cum = np.zeros(n)
        cum[1:] = np.cumsum(seg)
        s1, s2 = cum[-1] * _uniform01(state), cum[-1] * _uniform01(state)
        if s1 > s2:
            s1, s2 = s2, s1
        i1 = min(np.searchsorted(cum, s1, side="right") - 1, n - 2)
        i2 = min(np.searchsorted(cum, s2, side="right") - 1, n - 2)
        if i2 <= i1:
            continue
        p1 = path[i1] + (path[i1 + 1] - path[i1]) * ((s1 - cum[i1]) / max(seg[i1], 1e-12))
        p2 = path[i2] + (path[i2 + 1] - path[i2]) * ((s2 - cum[i2]) / max(seg[i2], 1e-12))
        # the pieces kept of segments i1 and i2 are sampled at new states: check them as-is too
        n_checks += 3
        if not (edge_ok(p1, p2, res, args) and edge_ok(path[i1], p1, res, args)
                and edge_ok(p2, path[i2 + 1], res, args)):
            continue
        out = np.empty((i1 + 1 + 2 + (n - i2 - 1), path.shape[1]))
        out[: i1 + 1] = path[: i1 + 1]
        out[i1 + 1] = p1
        out[i1 + 2] = p2
        out[i1 + 3:] = path[i2 + 1:]
        path = out
    path, c = _reduce_vertices(args, path, res)
    return path, n_checks + c
