"""`compass mbm PATH`: solve MotionBenchMaker problems with our collision model and planner."""
from __future__ import annotations

import json
import math
import sys
from functools import partial

HELP = "solve MotionBenchMaker problems (folder or .tar.bz2) and print per-family results"


def add_arguments(parser) -> None:
    parser.add_argument("path", help="folder or .tar.bz2 of sceneNNNN.yaml + requestNNNN.yaml pairs "
                                     "(the repository ships data/mbm-panda.tar.bz2)")
    parser.add_argument("--json", action="store_true", help="print one JSON object per family")
    parser.add_argument("--time-budget", type=float, default=1.0, metavar="S",
                        help="planning time budget per problem [s] (default 1.0)")
    parser.add_argument("--resolution", type=float, default=None, metavar="RAD",
                        help="edge check resolution [rad] while planning (default: planner default)")
    parser.add_argument("--validate-resolution", type=float, default=0.005, metavar="RAD",
                        help="resolution [rad] of the re-check of every returned path (default 0.005)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--backend", choices=("numba", "ompl"), default="numba", help="planner backend")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.add_argument("--explain", action="store_true",
                        help="list which robot link touches which obstacle for each problem the "
                             "planner's spheres reject, with the fine spheres' clearance there")
    parser.add_argument("--no-refine", action="store_true",
                        help="do not re-check rejected starts/goals with the fine sphere model")


def _fmt(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:.2f}"


def run(args) -> int:
    import numpy as np
    from tqdm import tqdm

    from ..errors import CompassInputError
    from ..bench.mbm import (
        FINE_FIT,
        explain_invalid,
        family_stats,
        load_problems,
        problem_validity,
        solve_problems,
        sphere_models_by_width,
        within_limits,
    )
    from ..motion.planner import PlannerConfig
    from ..robot.spheres import panda_sphere_model

    if not 1e-4 <= args.validate_resolution <= 0.5:
        raise CompassInputError(f"--validate-resolution {args.validate_resolution} rad is not allowed; use 1e-4..0.5 rad")
    if not 0.0 < args.time_budget <= 3600.0:
        raise CompassInputError(f"--time-budget {args.time_budget} s is not allowed; use 0 < t <= 3600 s")
    if args.resolution is not None and not 1e-4 <= args.resolution <= 0.5:
        raise CompassInputError(f"--resolution {args.resolution} rad is not allowed; use 1e-4..0.5 rad")
    if not 0 <= args.seed < 2**63:
        raise CompassInputError(f"--seed {args.seed} is not allowed; use a whole number 0..2**63 - 1")
    edge = PlannerConfig().edge_resolution if args.resolution is None else args.resolution
    config = PlannerConfig(time_budget=args.time_budget, seed=args.seed, backend=args.backend,
                           edge_resolution=edge, verify_resolution=min(args.validate_resolution, edge))
    problems = load_problems(args.path)
    bar = partial(tqdm, desc="mbm", unit="problem", file=sys.stderr, disable=args.no_progress or None, leave=False)
    outcomes = solve_problems(problems, config, args.seed, args.validate_resolution, not args.no_refine, bar)
    coarse = sphere_models_by_width(problems)
    stats = family_stats(outcomes)
    if args.json:
        for s in stats:
            print(json.dumps(s.as_json()))
        return 0
    print(f"{'family':<18} {'problems':>8} {'rejected':>8} {'solved':>7} {'outside_limits':>14} "
          f"{'median ms':>10} {'p90 ms':>9}")
    for s in stats:
        print(f"{s.family:<18} {s.problems:>8} {s.rejected:>8} {s.solved:>7} {s.outside_limits:>14} "
              f"{_fmt(s.plan_ms_median):>10} {_fmt(s.plan_ms_p90):>9}")
    widths = sorted({p.finger_width for p in problems})
    print("rejected: start or every goal in collision for our spheres; outside_limits: start or every "
          "goal outside the joint limits")
    print(f"finger opening from each problem's start state: {', '.join(f'{w:.3f}' for w in widths)} m")
    n_refined = sum(s.refined for s in stats)
    if not args.no_refine:
        print(f"refined: {n_refined} problems planned with the fine sphere model (wrist/hand/finger "
              f"protrusion {1e3 * FINE_FIT.fine_protrusion:.0f} mm): the planner's spheres rejected "
              "their start or goals, the fine ones did not")
    reasons: dict[tuple[str, str], int] = {}
    for o in outcomes:
        if o.rejection is not None:
            key = (o.family, o.rejection.value)
            reasons[key] = reasons.get(key, 0) + 1
    for (fam, why), n in sorted(reasons.items()):
        print(f"not planned: {fam}: {n} x {why}")
    if args.explain:
        for p, o in zip(problems, outcomes):
            if o.refined or (o.rejection is not None and o.rejection.in_collision):
                v = problem_validity(p, coarse[p.finger_width])
                bad = [q for q in (p.q_start, *p.q_goals) if within_limits(q) and not v.is_valid(q)]
                for q in bad[:2]:
                    what = "start" if q is p.q_start else "goal"
                    fine = None if args.no_refine else panda_sphere_model(finger_width=p.finger_width, fit=FINE_FIT)
                    why = "; ".join(explain_invalid(p, coarse[p.finger_width], q, fine))
                    status = o.rejection.value if o.rejection is not None else "accepted by the fine spheres"
                    print(f"{p.family} {p.name} {what} ({status}): {why or 'no sphere contact found'}")
    for s in stats:
        if s.path_invalid:
            print(f"warning: {s.family}: {s.path_invalid} returned paths failed the re-check "
                  f"at {args.validate_resolution} rad and count as unsolved")
    return 0
