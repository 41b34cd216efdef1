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

Budget: by default a deterministic one, `max_checks` edge checks of tree growth (each
extension step of RRT-Connect is one check of an edge of at most `range` [rad]) summed over
everything one `plan` call searches (the search, the fine-step repairs, the fine-step
re-search), so the same call with the same rng gives the same result on an idle or a busy
machine. A wall-clock cap (`time_budget` [s]) is an explicit option (the MBM benchmark, the
motion benchmark and scene certification use it); given alone it is the only cap, as before.
The start/goal checks, the straight segments to the goals and the shortcutting (bounded
by `simplify_rounds`) are not counted. OMPL stops on the same check count (a termination
condition on its validity queries) and on the wall clock if given, but its RNG is
process-wide, so its paths are not reproducible either way.

Edges are straight lines in joint space checked at `edge_resolution` [rad] (largest
joint step between checked states) during the search. The final path is re-checked at the
finer `verify_resolution`; a segment that fails there is replanned between its ends at the
fine step (the numba planner checks every segment it returns at the step it plans with, so
the replacement is not checked twice; if replanning fails, the whole search is redone at
the fine step). Paths are returned as waypoints (n,7) [rad] whose segments are all valid
at `verify_resolution`. The numba kernels live in `rrt_kernels`, the OMPL backend in
`ompl_backend`.
"""
from __future__ import annotations

import math

import time
from dataclasses import dataclass
from enum import Enum

import numba as nb
import numpy as np

from ..errors import CompassInputError, real_number
from ..robot.model import N_ARM_JOINTS, Q_MAX, Q_MIN, check_q
from .ompl_backend import plan_ompl
from .rrt_kernels import (MAX_NEW_PER_ITER, STATUS_CONNECTED, STATUS_FULL, edge_ok, rrt_connect_kernel,
                          simplify_kernel, states_valid)

BACKENDS = ("numba", "ompl")



class PlanFailure(Enum):
    """Why a query has no path."""

    START_INVALID = "start configuration is in collision"
    GOAL_INVALID = "every goal configuration is in collision"
    TIMEOUT = "no path found within the wall-clock time budget"
    CHECK_BUDGET = "no path found within the edge-check budget"


#: Default `PlannerConfig.max_checks`: edge checks of tree growth per `plan` call. Sized
#: from measurements (docs/grasping.md "Speed"): above the checks the numba planner made in
#: 0.5 s of CPU on the grasp selections' failed calls (the old 0.5 s wall-clock budget on an
#: idle machine) and above every successful call measured on grasp selections and exploration
#: decisions.
DEFAULT_MAX_CHECKS = 20000


@dataclass(frozen=True)
class PlannerConfig:
    """max_checks: edge checks of tree growth one `plan` call may make (deterministic; None
    with time_budget given: no check cap); time_budget [s]: optional wall-clock cap (None: no
    clock; given without max_checks it is the only cap); with neither given max_checks is
    DEFAULT_MAX_CHECKS. range [rad] longest tree extension; simplify: shortcut
    the path; edge_resolution [rad] largest joint step between checked states on an edge
    during the search; verify_resolution [rad] finer step at which the final path is
    re-checked (failing segments are replanned at that step; 0 = no re-check);
    simplify_rounds random shortcut attempts (5: in the Level-3/4 benchmark 20 rounds took
    ~2x the planning time for < 1 % shorter joint paths); seed for `plan` when no rng is given;
    backend "numba" or "ompl"."""

    max_checks: int | None = None
    time_budget: float | None = None
    range: float = 0.5
    simplify: bool = True
    edge_resolution: float = 0.04
    verify_resolution: float = 0.005
    simplify_rounds: int = 5
    seed: int = 0
    backend: str = "numba"

    def __post_init__(self) -> None:
        if self.max_checks is None and self.time_budget is None:
            object.__setattr__(self, "max_checks", DEFAULT_MAX_CHECKS)
        for name in ("range", "edge_resolution", "verify_resolution") + (("time_budget",) * (self.time_budget is not None)):
            real_number(getattr(self, name), f"PlannerConfig.{name}")
        for name in ("simplify_rounds", "seed") + (("max_checks",) * (self.max_checks is not None)):
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
                raise CompassInputError(f"PlannerConfig.{name} = {v!r:.40} is not allowed; use a whole number >= 0")
        if self.max_checks is not None and not 1 <= self.max_checks <= 10**9:
            raise CompassInputError(f"max_checks = {self.max_checks} is not allowed; use 1..10**9 or None")
        if not 0 <= self.seed < 2**63:
            raise CompassInputError(f"seed = {self.seed} is not allowed; use a whole number 0..2**63 - 1")
        if not isinstance(self.simplify, (bool, np.bool_)):
            raise CompassInputError(f"PlannerConfig.simplify = {self.simplify!r:.40} is not allowed; use True or False")
        if self.time_budget is not None and not (math.isfinite(float(self.time_budget))
                                                 and 0.0 < self.time_budget <= 3600.0):
            raise CompassInputError(f"time_budget = {self.time_budget} s is not allowed; use 0 < t <= 3600 s")
        if not (math.isfinite(float(self.range)) and 0.0 < self.range <= 20.0):
            raise CompassInputError(f"range = {self.range} rad is not allowed; use 0 < range <= 20 rad")
        if not (math.isfinite(float(self.edge_resolution)) and 1e-4 <= self.edge_resolution <= 0.5):
            raise CompassInputError(f"edge_resolution = {self.edge_resolution} rad is not allowed; use 1e-4..0.5 rad")
        if not (self.verify_resolution == 0.0 or 1e-4 <= self.verify_resolution <= self.edge_resolution):
            raise CompassInputError(
                f"verify_resolution = {self.verify_resolution} rad is not allowed; use 0 or 1e-4..edge_resolution"
            )
        if self.simplify_rounds < 0:
            raise CompassInputError(f"simplify_rounds = {self.simplify_rounds} is not allowed; use >= 0")
        if not isinstance(self.backend, str) or self.backend not in BACKENDS:
            raise CompassInputError(f"backend {self.backend!r} is not allowed; use one of {BACKENDS}")


@dataclass(frozen=True)
class PlanResult:
    """path (n,7) [rad] from the start to one goal, or None; failure reason (None on
    success); goal_index into q_goals (-1 on failure); plan_time_s wall time [s] including
    the start/goal checks and simplification; n_checks state and edge validity queries."""

    path: np.ndarray | None
    failure: PlanFailure | None
    goal_index: int
    plan_time_s: float
    n_checks: int

    @property
    def success(self) -> bool:
        return self.failure is None


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
    config = PlannerConfig() if config is None else config
    if not isinstance(config, PlannerConfig):
        raise CompassInputError(f"config {config!r:.60} is not allowed; give a PlannerConfig or None")
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise CompassInputError(f"rng {rng!r:.60} is not allowed; give a numpy.random.Generator or None")
    args = validity.kernel_args() if hasattr(validity, "kernel_args") else None
    if args is not None:
        _compile_kernels(args)  # once per process, outside the time budget
    t0 = time.perf_counter()
    rng = rng if rng is not None else np.random.default_rng(config.seed)
    q_start = check_q(q_start, "q_start")
    G = check_goals(q_goals)

    def fail(reason: PlanFailure, n: int) -> PlanResult:
        return PlanResult(None, reason, -1, time.perf_counter() - t0, n)

    if args is not None:  # one sequential numba call: no Python per state, no thread start-up
        ok = states_valid(np.vstack([q_start, G]), args)
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
    budget = Budget(config.max_checks, None if config.time_budget is None else t0 + config.time_budget)
    coarse, fine = config.edge_resolution, config.verify_resolution
    path, gi, n = _search(q_start, G[idx], validity, args, config, coarse, rng, budget)
    n_checks += n
    if path is not None and 0.0 < fine < coarse:
        # re-check at the fine step; replan only the failing segments; last resort: all at the fine step
        repaired, n = _repair(path, validity, args, config, fine, rng, budget)
        n_checks += n
        if repaired is None:
            path, gi, n = _search(q_start, G[idx], validity, args, config, fine, rng, budget)
            n_checks += n
        else:
            path = repaired
    if path is None:
        return fail(PlanFailure.TIMEOUT if budget.timed_out else PlanFailure.CHECK_BUDGET, n_checks)
    return PlanResult(path, None, int(idx[gi]), time.perf_counter() - t0, n_checks)


class Budget:
    """What one `plan` call may still spend: checks_left edge checks of tree growth (None:
    no cap) and a `time.perf_counter()` deadline (None: no clock). The searches charge it."""

    def __init__(self, max_checks: int | None, deadline: float | None):
        self.checks_left = max_checks
        self.deadline = deadline
        self.timed_out = False

    def spent(self) -> bool:
        """True once the checks are used up or the deadline has passed (then timed_out)."""
        if self.deadline is not None and time.perf_counter() >= self.deadline:
            self.timed_out = True
            return True
        return self.checks_left is not None and self.checks_left <= 0

    def charge(self, n: int) -> None:
        if self.checks_left is not None:
            self.checks_left -= int(n)

    def kernel_limit(self) -> int:
        """The check cap to hand one kernel call."""
        return 2**62 if self.checks_left is None else max(int(self.checks_left), 0)


def _repair(path, validity, args, config, fine, rng, budget, depth: int = 0):
    """The path with every segment that fails at the `fine` step replaced by a path planned
    between its ends at that step (the numba planner checks every returned segment at the
    step it plans with, so the replacement is not checked again; OMPL's is, at most 3
    levels deep); (None, checks) if a segment cannot be replanned in time."""
    out, n_checks = [path[:1]], 0
    for a, b in zip(path[:-1], path[1:]):
        n_checks += 1
        if _edge_ok(a, b, fine, validity, args):
            out.append(b[None])
            continue
        if depth >= 2:
            return None, n_checks
        if config.backend == "ompl":
            sub, _, n = plan_ompl(a, b[None], validity, args, config, fine, budget)
        else:
            sub, _, n = _plan_numba(a, b[None], args, config, fine, rng, budget)
        n_checks += n
        if sub is None:
            return None, n_checks
        if config.backend == "ompl":  # OMPL's simplifier is not ours: re-check what it returns
            sub, n = _repair(sub, validity, args, config, fine, rng, budget, depth + 1)
            n_checks += n
            if sub is None:
                return None, n_checks
        out.append(sub[1:])  # numba: every segment was checked at `fine` by the search or shortcutting
    return np.concatenate(out), n_checks


_COMPILED: list = []  # the first checker's argument types, once its kernels are compiled


def _compile_kernels(args) -> None:
    """Run every numba kernel once on empty work so JIT compilation (or loading from the
    numba cache) never counts against a query's time budget. All ValidityCheckers share
    the argument types, so this runs once per process (`nb.typeof` costs ~0.2 ms a call)."""
    if _COMPILED:
        return
    q = Q_MIN + 0.5 * (Q_MAX - Q_MIN)
    states_valid(np.empty((0, N_ARM_JOINTS)), args)
    edge_ok(q, q, 0.1, args)
    trees = _Trees(q, q[None], capacity=8)
    state = np.zeros(1, np.uint64)
    rrt_connect_kernel(args, Q_MIN, Q_MAX, 0.1, 1.0, trees.nodes_a, trees.parent_a, trees.nodes_b,
                       trees.parent_b, trees.counts, trees.link, state, 0, 0)
    simplify_kernel(args, np.stack([q, q]), 0.1, 0, state)
    _COMPILED.append(nb.typeof(args))


def _edge_ok(q0, q1, res, validity, args) -> bool:
    return bool(edge_ok(q0, q1, res, args) if args is not None else validity.edge_valid(q0, q1, res))


def _search(q_start, goals, validity, args, config, res, rng, budget):
    """Straight line to each goal (nearest first), then RRT-Connect; (path, goal, checks)."""
    n_checks = 0
    for i in range(len(goals)):
        n_checks += 1
        if _edge_ok(q_start, goals[i], res, validity, args):
            return np.stack([q_start, goals[i]]), i, n_checks
    goals = np.ascontiguousarray(goals)
    if config.backend == "ompl":
        path, gi, n = plan_ompl(q_start, goals, validity, args, config, res, budget)
    else:
        path, gi, n = _plan_numba(q_start, goals, args, config, res, rng, budget)
    return path, gi, n_checks + n


def _plan_numba(q_start, goals, args, config, res, rng, budget):
    """RRT-Connect charged to `budget`; with a deadline in chunks of iterations between
    clock checks (the chunking does not change the result); returns (path, goal, n)."""
    if args is None:
        raise CompassInputError("the numba planner needs a ValidityChecker (kernel_args); use backend='ompl'")
    state = np.array([rng.integers(0, 2**63 - 1, dtype=np.int64)], dtype=np.uint64)
    trees = _Trees(q_start, goals, capacity=4096)
    res, rng_range = float(res), float(config.range)
    chunk = 8 if budget.deadline is not None else 2**62  # iterations between clock checks, ~2 ms of work
    n_checks = 0
    while True:
        tc = time.perf_counter()
        if budget.spent():
            return None, -1, n_checks
        status, n = rrt_connect_kernel(
            args, Q_MIN, Q_MAX, res, rng_range, trees.nodes_a, trees.parent_a,
            trees.nodes_b, trees.parent_b, trees.counts, trees.link, state, chunk, budget.kernel_limit(),
        )
        n_checks += n
        budget.charge(n)
        if status == STATUS_CONNECTED:
            break
        if status == STATUS_FULL:
            trees.grow()
        if budget.deadline is None:
            continue
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


class _Trees:
    """Growable node arrays of the start tree (0) and the goal tree (1, rooted at all goals)."""

    def __init__(self, q_start: np.ndarray, goals: np.ndarray, capacity: int):
        capacity = max(capacity, len(goals) + 4 * MAX_NEW_PER_ITER)
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
