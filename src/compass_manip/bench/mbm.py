"""Solving MotionBenchMaker problems with our collision model and planner (`compass mbm`).

Solving checks the start and goals with the planner's sphere model; when it rejects them, a
fine sphere model (`FINE_FIT`: 2 mm protrusion on the wrist, hand and fingers, 0.5 mm
padding; as conservative, slower) re-checks them, and if it accepts them the problem is
planned and validated with the fine model. Problems come from `bench.mbm_io.load_problems`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from ..errors import CompassInputError
from ..motion.planner import PlanFailure, plan
from ..motion.primitives import PrimitiveSet
from ..motion.validity import ValidityChecker
from ..robot.model import Q_MAX, Q_MIN, check_q
from ..robot.sphere_fit import FINE_FIT, SphereFitConfig
from ..robot.spheres import panda_sphere_model
from .mbm_io import MbmProblem, load_problems  # noqa: F401  (re-exported for callers)
from .stats import json_float

class Rejection(Enum):
    """Why a problem was not planned: its start or goal is outside the joint limits (counted
    as `outside_limits`) or found in collision by our model (`rejected`; the problems are
    collision-free for the real robot)."""

    START_OUTSIDE_LIMITS = "start outside the joint limits"
    GOAL_OUTSIDE_LIMITS = "every goal outside the joint limits"
    START_IN_COLLISION = "start in collision"
    GOAL_IN_COLLISION = "every goal in collision"

    @property
    def in_collision(self) -> bool:
        return self in (Rejection.START_IN_COLLISION, Rejection.GOAL_IN_COLLISION)


@dataclass(frozen=True)
class MbmOutcome:
    """Result of one problem: rejection (None if planned), solved (a path was returned and
    passed the fine re-check), path_invalid (a path was returned but failed the re-check),
    plan_ms planning wall time [ms] (NaN when rejected), waypoints in the path (0 if none),
    refined: the planner's sphere model rejected the start or every goal and the fine model
    (which accepted them) was used for this problem; path: the returned waypoints (n,7) [rad]
    or None (kept so a benchmark or test can replay exactly what was counted)."""

    family: str
    name: str
    rejection: Rejection | None
    solved: bool
    path_invalid: bool
    plan_ms: float
    waypoints: int
    refined: bool = False
    path: np.ndarray | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class FamilyStats:
    """Per-family summary; plan times [ms] over the planned (not rejected) problems.
    rejected: start or every goal found in collision; outside_limits: start or every goal
    outside the joint limits; refined: planned with the fine sphere model."""

    family: str
    problems: int
    rejected: int
    solved: int
    plan_ms_median: float
    plan_ms_p90: float
    path_invalid: int
    outside_limits: int = 0
    refined: int = 0

    def as_json(self) -> dict:
        """The JSON object printed by `compass mbm --json`."""
        return {"family": self.family, "problems": self.problems, "rejected": self.rejected,
                "outside_limits": self.outside_limits, "solved": self.solved,
                "plan_ms_median": json_float(self.plan_ms_median),
                "plan_ms_p90": json_float(self.plan_ms_p90)}


def problem_validity(problem: MbmProblem, sphere_model):
    """A ValidityChecker for the problem's obstacles (joint limits + self-collision too)."""
    return ValidityChecker(sphere_model, obstacles=PrimitiveSet.from_lists(**problem.primitive_lists()))


def solve_problem(problem: MbmProblem, sphere_model, planner_config, rng: np.random.Generator,
                  validate_resolution: float = 0.005, fine_model=None) -> MbmOutcome:
    """Check start/goals, plan, and re-check the returned path at `validate_resolution` [rad].

    sphere_model / fine_model: SphereModels with the problem's finger opening (fine_model, or
    a callable returning it, is used only when sphere_model rejects the start or every goal;
    None: no refinement).
    """
    def reject(r: Rejection, refined: bool = False) -> MbmOutcome:
        return MbmOutcome(problem.family, problem.name, r, False, False, float("nan"), 0, refined)

    if not within_limits(problem.q_start):
        return reject(Rejection.START_OUTSIDE_LIMITS)
    goals = problem.q_goals[[within_limits(g) for g in problem.q_goals]]
    if len(goals) == 0:
        return reject(Rejection.GOAL_OUTSIDE_LIMITS)
    validity = problem_validity(problem, sphere_model)
    refined = False
    if fine_model is not None and not _ends_valid(validity, problem.q_start, goals):
        fine = problem_validity(problem, fine_model() if callable(fine_model) else fine_model)
        if _ends_valid(fine, problem.q_start, goals):
            validity, refined = fine, True
    result = plan(problem.q_start, goals, validity, planner_config, rng)
    if result.failure is PlanFailure.START_INVALID:
        return reject(Rejection.START_IN_COLLISION, refined)
    if result.failure is PlanFailure.GOAL_INVALID:
        return reject(Rejection.GOAL_IN_COLLISION, refined)
    ok = (result.success and np.array_equal(result.path[0], problem.q_start)
          and bool(np.any(np.all(result.path[-1] == goals, axis=1)))
          and path_is_valid(result.path, validity, validate_resolution))
    return MbmOutcome(problem.family, problem.name, None, ok, result.success and not ok,
                      1e3 * result.plan_time_s, 0 if result.path is None else len(result.path), refined,
                      result.path)


def solve_problems(problems: list[MbmProblem], planner_config, seed: int = 0, validate_resolution: float = 0.005,
                   refine: bool = True, progress=None) -> list[MbmOutcome]:
    """Solve every problem with the default sphere model at its finger opening (one model per
    distinct opening), refined by the FINE_FIT model (fitted only when first needed) unless
    refine is False. Problem i uses np.random.default_rng([seed, i]); progress: optional
    wrapper of the problem iterable (e.g. tqdm)."""
    coarse = sphere_models_by_width(problems)
    out = []
    for i, p in enumerate(progress(problems) if progress is not None else problems):
        fine = (lambda w=p.finger_width: panda_sphere_model(finger_width=w, fit=FINE_FIT)) if refine else None
        out.append(solve_problem(p, coarse[p.finger_width], planner_config, np.random.default_rng([seed, i]),
                                 validate_resolution, fine))
    return out


def _ends_valid(validity, q_start: np.ndarray, goals: np.ndarray) -> bool:
    """True if the start and at least one goal are valid."""
    return validity.is_valid(q_start) and bool(validity.are_valid(goals).any())


def sphere_models_by_width(problems: list[MbmProblem], fit: SphereFitConfig | None = None) -> dict:
    """{finger_width [m]: SphereModel} for every distinct finger opening of `problems`."""
    return {w: panda_sphere_model(finger_width=w, fit=fit) for w in sorted({p.finger_width for p in problems})}


def within_limits(q: np.ndarray) -> bool:
    """True if q (7,) [rad] is finite and within the Panda's limits (`robot.model.check_q`)."""
    try:
        check_q(q)
    except CompassInputError:
        return False
    return True


def path_is_valid(path: np.ndarray, validity, resolution: float) -> bool:
    """Every segment of a path (n,7) [rad] valid when checked every `resolution` [rad]."""
    return all(validity.edge_valid(a, b, resolution) for a, b in zip(path[:-1], path[1:])) and bool(
        validity.is_valid(path[0]))


def family_stats(outcomes: list[MbmOutcome]) -> list[FamilyStats]:
    """Summaries per family, in the order families first appear."""
    out = []
    for fam in dict.fromkeys(o.family for o in outcomes):
        rows = [o for o in outcomes if o.family == fam]
        t = np.array([o.plan_ms for o in rows if o.rejection is None])
        out.append(FamilyStats(
            fam, len(rows), sum(o.rejection is not None and o.rejection.in_collision for o in rows),
            sum(o.solved for o in rows),
            float(np.median(t)) if t.size else float("nan"),
            float(np.percentile(t, 90)) if t.size else float("nan"),
            sum(o.path_invalid for o in rows),
            sum(o.rejection is not None and not o.rejection.in_collision for o in rows),
            sum(o.refined for o in rows),
        ))
    return out


def _link_clearance(sphere_model, q: np.ndarray, ps) -> dict[str, float]:
    """{moving link: smallest (distance to the primitives ps - sphere radius) [m]} at q."""
    C = sphere_model.sphere_centers(q[None])[0]
    links = np.asarray(sphere_model.link_names)[sphere_model.body_index]
    gap = ps.distance(C) - sphere_model.radii
    moving = sphere_model.body_index != 0  # the base stands on its support
    return {str(k): float(gap[(links == k) & moving].min()) for k in dict.fromkeys(links[moving])}


def explain_invalid(problem: MbmProblem, sphere_model, q: np.ndarray, fine_model=None) -> list[str]:
    """Why our model finds q (7,) [rad] invalid: each (robot link, obstacle) pair whose
    spheres penetrate, with the deepest penetration [mm], then self-colliding link pairs.
    With a (tighter, also conservative) fine_model, each line also gives that link's
    clearance under the fine spheres: a lower bound on the true clearance, so a positive value
    means the coarse spheres overshoot the real geometry there by at least their sum."""
    q = np.clip(np.asarray(q, np.float64), Q_MIN, Q_MAX)
    C = sphere_model.sphere_centers(q[None])[0]
    links = np.asarray(sphere_model.link_names)[sphere_model.body_index]
    out = []
    singles = ([PrimitiveSet.from_lists(boxes=[b]) for b in problem.boxes]
               + [PrimitiveSet.from_lists(cylinders=[c]) for c in problem.cylinders]
               + [PrimitiveSet.from_lists(spheres=[s]) for s in problem.spheres])
    for ps, oid in zip(singles, problem.obstacle_ids or [f"#{i}" for i in range(len(singles))]):
        gap = _link_clearance(sphere_model, q, ps)
        fine = _link_clearance(fine_model, q, ps) if fine_model is not None else {}
        for link, g in gap.items():
            if g < 0:
                extra = f"; fine spheres {1e3 * fine[link]:+.1f} mm" if link in fine else ""
                out.append(f"{link} touches {oid!r} ({1e3 * -g:.1f} mm{extra})")
    pairs = sphere_model.self_collision_pairs
    if len(pairs):
        gap = np.linalg.norm(C[pairs[:, 0]] - C[pairs[:, 1]], axis=1) - sphere_model.radii[pairs].sum(axis=1)
        hit = {}
        for (a, b), g in zip(pairs[gap < 0], gap[gap < 0]):
            key = tuple(sorted((links[a], links[b])))
            hit[key] = min(hit.get(key, 0.0), g)
        out += [f"self: {a} x {b} ({-1e3 * g:.1f} mm)" for (a, b), g in hit.items()]
    return out
