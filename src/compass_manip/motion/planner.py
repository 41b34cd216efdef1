"""Joint-space motion planning: straight line first, then RRT-Connect, then shortcutting.

`plan(q_start, q_goals, validity, config, rng)` plans from one start to any of k goal
configurations (e.g. all IK solutions of a grasp). Start and goals are checked first and
reported as typed failures; the straight segment to each valid goal (nearest first) is
tried before any tree is grown. Two backends:

* ``"numba"`` (default): RRT-Connect (Kuffner & LaValle 2000) with the goal tree rooted at
  all valid goals, compiled with numba and calling the checker's numba edge kernel
  directly, so no Python runs per state. Randomness comes from a splitmix64 stream seeded
  by the caller's `np.random.Generator`, so the same seed gives the same path.
* ``"ompl"``: OMPL 2.0.1's RRTConnect + PathSimplifier through its Python wheel, with a
  Python state validity callback and a motion validator calling the same edge check. OMPL
  seeds one process-wide RNG on first use, so it is not reproducible per call.

Edges are straight lines in joint space checked at `edge_resolution` [rad] (largest
joint step between checked states) during the search. The final path is re-checked at the
finer `verify_resolution`; a segment that fails there is replanned between its ends at the
fine step (if that fails too, the whole search is redone at the fine step). Paths are
returned as waypoints (n,7) [rad] whose segments are all valid at `verify_resolution`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from enum import Enum

import numba as nb
import numpy as np

from ..errors import CompassInputError
from ..robot.model import N_ARM_JOINTS, Q_MAX, Q_MIN, check_q
from .validity import config_valid_kernel, edge_valid_kernel

BACKENDS = ("numba", "ompl")


class PlanFailure(Enum):
    """Why a query has no path."""

    START_INVALID = "start configuration is in collision"
    GOAL_INVALID = "every goal configuration is in collision"
    TIMEOUT = "no path found within the time budget"


@dataclass(frozen=True)
class PlannerConfig:
    """time_budget [s] for the search; range [rad] longest tree extension; simplify: shortcut
    the path; edge_resolution [rad] largest joint step between checked states on an edge
    during the search; verify_resolution [rad] finer step at which the final path is
    re-checked (failing segments are replanned at that step; 0 = no re-check);
    simplify_rounds random shortcut attempts; seed for `plan` when no rng is given;
    backend "numba" or "ompl"."""

    time_budget: float = 1.0
    range: float = 0.5
    simplify: bool = True
    edge_resolution: float = 0.04
    verify_resolution: float = 0.005
    simplify_rounds: int = 20
    seed: int = 0
    backend: str = "numba"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.time_budget) and 0.0 < self.time_budget <= 3600.0):
            raise CompassInputError(f"time_budget = {self.time_budget} s is not allowed; use 0 < t <= 3600 s")
        if not (np.isfinite(self.range) and 0.0 < self.range <= 20.0):
            raise CompassInputError(f"range = {self.range} rad is not allowed; use 0 < range <= 20 rad")
        if not (np.isfinite(self.edge_resolution) and 1e-4 <= self.edge_resolution <= 0.5):
            raise CompassInputError(f"edge_resolution = {self.edge_resolution} rad is not allowed; use 1e-4..0.5 rad")
        if not (self.verify_resolution == 0.0 or 1e-4 <= self.verify_resolution <= self.edge_resolution):
            raise CompassInputError(
                f"verify_resolution = {self.verify_resolution} rad is not allowed; use 0 or 1e-4..edge_resolution"
            )
        if self.simplify_rounds < 0:
            raise CompassInputError(f"simplify_rounds = {self.simplify_rounds} is not allowed; use >= 0")
        if self.backend not in BACKENDS:
            raise CompassInputError(f"backend {self.backend!r} is not allowed; use one of {BACKENDS}")


@dataclass(frozen=True)
class PlanResult:
    """success; path (n,7) [rad] from the start to one goal, or None; failure reason (None on
    success); goal_index into q_goals (-1 on failure); plan_time_s wall time [s] including
    the start/goal checks and simplification; n_checks state and edge validity queries."""

    success: bool
    path: np.ndarray | None
    failure: PlanFailure | None
    goal_index: int
    plan_time_s: float
    n_checks: int


def check_goals(q_goals: np.ndarray) -> np.ndarray:
    """q_goals as a float64 (k,7) array; raise CompassInputError on bad shape, NaN, limits."""
    G = np.asarray(q_goals, dtype=np.float64)
    if G.ndim == 1:
        G = G[None, :]
    if G.ndim != 2 or G.shape[1] != N_ARM_JOINTS or G.shape[0] == 0:
        raise CompassInputError(f"q_goals must have shape (k>=1, 7) [rad], got {np.shape(q_goals)}")
    for i in range(G.shape[0]):
        check_q(G[i], f"q_goals[{i}]")
    return np.ascontiguousarray(G)


def plan(q_start, q_goals, validity, config: PlannerConfig | None = None,
         rng: np.random.Generator | None = None) -> PlanResult:
    """Plan a collision-free joint path from q_start (7,) to any of q_goals (k,7) [rad].

    `validity` is a `ValidityChecker` (is_valid(q), are_valid(Q), edge_valid(q0, q1,
    resolution); the numba backend also uses its numba edge kernel). Invalid start or
    goals give a failed `PlanResult` with its reason; NaN or out-of-limit input raises
    CompassInputError.
    """
    config = config or PlannerConfig()
    args = validity.kernel_args() if hasattr(validity, "kernel_args") else None
    if args is not None:
        _compile_kernels(args)  # once per process, outside the time budget
    t0 = time.perf_counter()
    rng = rng if rng is not None else np.random.default_rng(config.seed)
    q_start = check_q(q_start, "q_start")
    G = check_goals(q_goals)

    def fail(reason: PlanFailure, n: int) -> PlanResult:
        return PlanResult(False, None, reason, -1, time.perf_counter() - t0, n)

    if args is not None:  # one sequential numba call: no Python per state, no thread start-up
        ok = _states_valid(np.vstack([q_start, G]), args)
    else:
        ok = np.array([bool(validity.is_valid(q)) for q in np.vstack([q_start, G])])
    n_checks = 1 + len(G)
    if not ok[0]:
        return fail(PlanFailure.START_INVALID, n_checks)
    ok = ok[1:]
    if not ok.any():
        return fail(PlanFailure.GOAL_INVALID, n_checks)
    idx = np.nonzero(ok)[0]
    idx = idx[np.argsort(np.linalg.norm(G[idx] - q_start, axis=1), kind="stable")]
    deadline = t0 + config.time_budget
    coarse, fine = config.edge_resolution, config.verify_resolution
    path, gi, n = _search(q_start, G[idx], validity, args, config, coarse, rng, deadline)
    n_checks += n
    if path is not None and 0.0 < fine < coarse:
        # re-check at the fine step; replan only the failing segments; last resort: all at the fine step
        repaired, n = _repair(path, validity, args, config, fine, rng, deadline)
        n_checks += n
        if repaired is None:
            path, gi, n = _search(q_start, G[idx], validity, args, config, fine, rng, deadline)
            n_checks += n
        else:
            path = repaired
    if path is None:
        return fail(PlanFailure.TIMEOUT, n_checks)
    return PlanResult(True, path, None, int(idx[gi]), time.perf_counter() - t0, n_checks)


def _repair(path, validity, args, config, fine, rng, deadline, depth: int = 0):
    """The path with every segment that fails at the `fine` step replaced by a path planned
    between its ends at that step (itself re-checked, at most 3 levels deep); (None,
    checks) if a segment cannot be replanned in time."""
    out, n_checks = [path[:1]], 0
    for a, b in zip(path[:-1], path[1:]):
        n_checks += 1
        if _edge_ok(a, b, fine, validity, args):
            out.append(b[None])
            continue
        if depth >= 2:
            return None, n_checks
        if config.backend == "ompl":
            sub, _, n = _plan_ompl(a, b[None], validity, args, config, fine, deadline)
        else:
            sub, _, n = _plan_numba(a, b[None], args, config, fine, rng, deadline)
        n_checks += n
        if sub is None:
            return None, n_checks
        sub, n = _repair(sub, validity, args, config, fine, rng, deadline, depth + 1)
        n_checks += n
        if sub is None:
            return None, n_checks
        out.append(sub[1:])
    return np.concatenate(out), n_checks


_COMPILED: list = []  # the first checker's argument types, once its kernels are compiled


def _compile_kernels(args) -> None:
    """Run every numba kernel once on empty work so JIT compilation (or loading from the
    numba cache) never counts against a query's time budget. All ValidityCheckers share
    the argument types, so this runs once per process (`nb.typeof` costs ~0.2 ms a call)."""
    if _COMPILED:
        return
    q = Q_MIN + 0.5 * (Q_MAX - Q_MIN)
    _states_valid(np.empty((0, N_ARM_JOINTS)), args)
    _edge(q, q, 0.1, args)
    trees = _Trees(q, q[None], capacity=8)
    state = np.zeros(1, np.uint64)
    rrt_connect_kernel(args, Q_MIN, Q_MAX, 0.1, 1.0, trees.nodes_a, trees.parent_a, trees.nodes_b,
                       trees.parent_b, trees.counts, trees.link, state, 0)
    simplify_kernel(args, np.stack([q, q]), 0.1, 0, state)
    _COMPILED.append(nb.typeof(args))


def _edge_ok(q0, q1, res, validity, args) -> bool:
    return bool(_edge(q0, q1, res, args) if args is not None else validity.edge_valid(q0, q1, res))


def _search(q_start, goals, validity, args, config, res, rng, deadline):
    """Straight line to each goal (nearest first), then RRT-Connect; (path, goal, checks)."""
    n_checks = 0
    for i in range(len(goals)):
        n_checks += 1
        if _edge_ok(q_start, goals[i], res, validity, args):
            return np.stack([q_start, goals[i]]), i, n_checks
    goals = np.ascontiguousarray(goals)
    if config.backend == "ompl":
        path, gi, n = _plan_ompl(q_start, goals, validity, args, config, res, deadline)
    else:
        path, gi, n = _plan_numba(q_start, goals, args, config, res, rng, deadline)
    return path, gi, n_checks + n


def _plan_numba(q_start, goals, args, config, res, rng, deadline):
    """RRT-Connect in chunks of iterations between clock checks; returns (path, goal, n)."""
    if args is None:
        raise CompassInputError("the numba planner needs a ValidityChecker (kernel_args); use backend='ompl'")
    state = np.array([rng.integers(0, 2**63 - 1, dtype=np.int64)], dtype=np.uint64)
    trees = _Trees(q_start, goals, capacity=4096)
    res, rng_range = float(res), float(config.range)
    chunk = 8  # iterations between clock checks, adapted to ~2 ms of work
    n_checks = 0
    while True:
        tc = time.perf_counter()
        if tc >= deadline:
            return None, -1, n_checks
        status, n = rrt_connect_kernel(
            args, Q_MIN, Q_MAX, res, rng_range, trees.nodes_a, trees.parent_a,
            trees.nodes_b, trees.parent_b, trees.counts, trees.link, state, chunk,
        )
        n_checks += n
        if status == STATUS_CONNECTED:
            break
        if status == STATUS_FULL:
            trees.grow()
        now = time.perf_counter()
        if now - tc < 1e-3:
            chunk = min(2 * chunk, 4096)
        elif now - tc > 4e-3:
            chunk = max(chunk // 2, 1)
    path, goal_root = trees.path()
    if config.simplify and len(path) > 2:
        path, n = simplify_kernel(args, path, res, config.simplify_rounds, state)
        n_checks += n
    return path, goal_root, n_checks


# --- numba RRT-Connect ---------------------------------------------------------------
STATUS_RUNNING, STATUS_CONNECTED, STATUS_FULL = 0, 1, 2
_TRAPPED, _ADVANCED, _REACHED = 0, 1, 2
_MAX_NEW_PER_ITER = 64


@nb.njit(cache=True)
def _edge(q0, q1, res, args):
    """ValidityChecker.edge_valid in numba: states every `res` [rad] (largest joint step)."""
    m = 0.0
    for j in range(q0.shape[0]):
        m = max(m, abs(q1[j] - q0[j]))
    n = max(1, int(np.ceil(m / res)))
    kin, robot, grid, prims, limits, params = args
    return edge_valid_kernel(q0, q1, n, kin, robot, grid, prims, limits, params)


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
def _states_valid(Q, args):
    """(N,) validity of Q (N,7) with ValidityChecker's kernel, sequentially."""
    kin, robot, grid, prims, limits, params = args
    links = np.empty((kin[1].shape[0], 4, 4))
    W = np.empty((robot[0].shape[0], 3))
    out = np.empty(Q.shape[0], np.bool_)
    for n in range(Q.shape[0]):
        out[n] = config_valid_kernel(Q[n], kin, robot, grid, prims, limits, params, links, W)
    return out


@nb.njit(cache=True)
def _nearest(nodes, n, q):
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
def _grow(args, nodes, parent, counts, t, q_target, step, res, connect):
    """Extend tree t from its node nearest q_target by steps of at most `step` [rad]; one step
    (connect=False) or until reached or blocked (connect=True). Returns (result, last node
    index, edge checks)."""
    k = _nearest(nodes, counts[t], q_target)
    result, n_checks = _TRAPPED, 0
    for _ in range(_MAX_NEW_PER_ITER):
        n = counts[t]
        d = np.sqrt(np.sum((q_target - nodes[k]) ** 2))
        reached = d <= step
        if reached:
            nodes[n] = q_target
        else:
            nodes[n] = nodes[k] + (q_target - nodes[k]) * (step / d)
        n_checks += 1
        if not _edge(nodes[k], nodes[n], res, args):
            return result, k, n_checks
        parent[n] = k
        counts[t] = n + 1
        k = n
        if reached:
            return _REACHED, k, n_checks
        result = _ADVANCED
        if not connect:
            break
    return result, k, n_checks


@nb.njit(cache=True)
def rrt_connect_kernel(args, lo, hi, res, step, nodes0, parent0, nodes1, parent1,
                       counts, link, state, iters):
    """Run up to `iters` RRT-Connect iterations on the start tree (0) and goal tree (1).

    counts (2,) node counts; link[0] the tree extended next, on connection link[1], link[2]
    are the meeting nodes in trees 0 and 1. Returns (STATUS_*, edge checks).
    """
    q_rand = np.empty(lo.shape[0])
    n_checks = 0
    cap = min(nodes0.shape[0], nodes1.shape[0])
    for _ in range(iters):
        if max(counts[0], counts[1]) + 2 * _MAX_NEW_PER_ITER >= cap:
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
        if r != _TRAPPED:
            target = nA[k].copy()
            r2, k2, c2 = _grow(args, nB, pB, counts, 1 - a, target, step, res, True)
            n_checks += c2
            if r2 == _REACHED:
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
            if _edge(path[i], path[j], res, args):
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
        if not (_edge(p1, p2, res, args) and _edge(path[i1], p1, res, args) and _edge(p2, path[i2 + 1], res, args)):
            continue
        out = np.empty((i1 + 1 + 2 + (n - i2 - 1), path.shape[1]))
        out[: i1 + 1] = path[: i1 + 1]
        out[i1 + 1] = p1
        out[i1 + 2] = p2
        out[i1 + 3:] = path[i2 + 1:]
        path = out
    path, c = _reduce_vertices(args, path, res)
    return path, n_checks + c


class _Trees:
    """Growable node arrays of the start tree (0) and the goal tree (1, rooted at all goals)."""

    def __init__(self, q_start: np.ndarray, goals: np.ndarray, capacity: int):
        capacity = max(capacity, len(goals) + 4 * _MAX_NEW_PER_ITER)
        self.nodes_a = np.empty((capacity, N_ARM_JOINTS))
        self.parent_a = np.full(capacity, -1, dtype=np.int64)
        self.nodes_b = np.empty((capacity, N_ARM_JOINTS))
        self.parent_b = np.full(capacity, -1, dtype=np.int64)
        self.nodes_a[0] = q_start
        self.nodes_b[: len(goals)] = goals
        self.counts = np.array([1, len(goals)], dtype=np.int64)
        self.link = np.zeros(3, dtype=np.int64)

    def grow(self) -> None:
        for name in ("nodes_a", "nodes_b"):
            old = getattr(self, name)
            setattr(self, name, np.concatenate([old, np.empty_like(old)]))
        for name in ("parent_a", "parent_b"):
            old = getattr(self, name)
            setattr(self, name, np.concatenate([old, np.full_like(old, -1)]))

    def path(self) -> tuple[np.ndarray, int]:
        """Waypoints start -> goal through the meeting nodes, and the goal's index."""
        ia, ib = int(self.link[1]), int(self.link[2])
        a = [ia]
        while self.parent_a[a[-1]] >= 0:
            a.append(int(self.parent_a[a[-1]]))
        b = [ib]
        while self.parent_b[b[-1]] >= 0:
            b.append(int(self.parent_b[b[-1]]))
        # the meeting node exists in both trees with the same configuration
        path = np.concatenate([self.nodes_a[a[::-1]], self.nodes_b[b[1:]]])
        return np.ascontiguousarray(path), b[-1]


# --- OMPL backend --------------------------------------------------------------------
def _plan_ompl(q_start, goals, validity, args, config, res, deadline):
    """OMPL RRTConnect + PathSimplifier with Python callbacks; returns (path, goal, n)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    space = ob.RealVectorStateSpace(N_ARM_JOINTS)
    bounds = ob.RealVectorBounds(N_ARM_JOINTS)
    for i in range(N_ARM_JOINTS):
        bounds.setLow(i, float(Q_MIN[i]))
        bounds.setHigh(i, float(Q_MAX[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    si = ss.getSpaceInformation()
    counter = [0]

    def as_q(s) -> np.ndarray:
        return np.array([s[i] for i in range(N_ARM_JOINTS)])

    def state_valid(s) -> bool:
        counter[0] += 1
        q = as_q(s)
        return bool(_states_valid(q[None], args)[0] if args is not None else validity.is_valid(q))

    class _EdgeValidator(ob.MotionValidator):
        def checkMotion(self, s1, s2, *_last_valid):
            counter[0] += 1
            q1, q2 = as_q(s1), as_q(s2)
            return bool(_edge(q1, q2, res, args) if args is not None else validity.edge_valid(q1, q2, res))

    ss.setStateValidityChecker(state_valid)
    mv = _EdgeValidator(si)
    si.setMotionValidator(mv)
    start = space.allocState()
    for i in range(N_ARM_JOINTS):
        start[i] = float(q_start[i])
    goal = ob.GoalStates(si)
    for g in goals:
        s = space.allocState()
        for i in range(N_ARM_JOINTS):
            s[i] = float(g[i])
        goal.addState(s)
    ss.setStartState(start)
    ss.setGoal(goal)
    planner = og.RRTConnect(si)
    planner.setRange(config.range)
    ss.setPlanner(planner)
    ss.setup()
    ss.solve(max(deadline - time.perf_counter(), 1e-4))
    if not ss.haveExactSolutionPath():
        return None, -1, counter[0]
    if config.simplify:
        ss.simplifySolution(max(deadline - time.perf_counter(), 1e-3))
    p = ss.getSolutionPath()
    path = np.array([as_q(p.getState(k)) for k in range(p.getStateCount())])
    gi = int(np.argmin(np.linalg.norm(goals - path[-1], axis=1)))
    return path, gi, counter[0]
