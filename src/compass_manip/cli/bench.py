"""`compass bench`: run a resumable sweep of trials into a SQLite results store.

    compass bench --methods fv,ig,gse,compass --levels 1,2,3,4 --scenes 20 --trials 10 \\
        [--seed S] [--workers N] [--db results.sqlite] [--ray ADDRESS] [--wall-cap S]

Re-running the same command skips the trials already stored. Every argument, the store,
Ray and the trial function are checked before the first trial starts.
"""
from __future__ import annotations

import os
import re

from ..errors import CompassInputError

HELP = "run methods × levels × scenes × trials into a resumable SQLite results store"

_NAME = re.compile(r"^[a-z0-9][a-z0-9_.-]*$")


def add_arguments(p) -> None:
    p.add_argument("--methods", default="fv,ig,gse,compass",
                   help="comma-separated method names (default fv,ig,gse,compass)")
    p.add_argument("--levels", default="1,2,3,4", help="comma-separated levels among 1..4, or 'all' (default all)")
    p.add_argument("--scenes", type=int, default=20, help="scenes per level, indices 0..N-1 (default 20)")
    p.add_argument("--trials", type=int, default=10, help="trials per scene, each with its own trial seed (default 10)")
    p.add_argument("--seed", type=int, default=0, help="base seed of scenes and trials (default 0)")
    p.add_argument("--workers", type=int, default=max(1, (os.cpu_count() or 2) // 2),
                   help="trials run in parallel (default: half the CPUs here; with --ray, up to the "
                        "cluster's CPUs: give a large N)")
    p.add_argument("--db", default="results.sqlite", help="results store; created if missing (default results.sqlite)")
    p.add_argument("--ray", default=None, metavar="ADDRESS",
                   help="run on Ray: 'local' for a local instance, 'auto' or ray://HOST:PORT for a cluster "
                        "(needs pip install 'compass-manip[cluster]')")
    p.add_argument("--wall-cap", type=float, default=900.0, metavar="S",
                   help="wall time [s] after which a trial is killed and recorded as wall_time_exceeded (default 900)")
    p.add_argument("--trial-fn", default=None, metavar="MODULE:NAME",
                   help="trial function (default: the simulated trial); "
                        "compass_manip.bench.synthetic:synthetic_trial exercises the sweep without a simulator")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def parse_methods(text: str) -> tuple[str, ...]:
    names = tuple(m.strip() for m in text.split(","))
    for m in names:
        if not _NAME.match(m):
            raise CompassInputError(f"--methods {text!r}: {m!r} is not a method name; give names such as "
                                    "fv,ig,gse,compass separated by commas")
    return names


def parse_levels(text: str) -> tuple[int, ...]:
    if text.strip() == "all":
        return (1, 2, 3, 4)
    out = []
    for part in text.split(","):
        if part.strip() not in ("1", "2", "3", "4"):
            raise CompassInputError(f"--levels {text!r}: level {part.strip()!r} is not allowed; use levels among "
                                    "1, 2, 3, 4 separated by commas, or all")
        out.append(int(part))
    if len(set(out)) != len(out):
        raise CompassInputError(f"--levels {text!r} repeats a level; give each once")
    return tuple(out)


def run(args) -> int:
    from ..bench.runner import run_sweep
    from ..bench.store import ResultsStore
    from ..bench.sweep import REAL_TRIAL_FN, SweepConfig, resolve_trial_fn, validate

    config = SweepConfig(methods=parse_methods(args.methods), levels=parse_levels(args.levels), scenes=args.scenes,
                         trials=args.trials, seed=args.seed, workers=args.workers, wall_cap_s=args.wall_cap,
                         ray_address=args.ray)
    validate(config)
    if args.ray is not None:
        from ..bench.ray_pool import import_ray

        import_ray()
    trial_fn = resolve_trial_fn(args.trial_fn or REAL_TRIAL_FN)
    with ResultsStore(args.db, create=True) as store:
        summary = run_sweep(config, args.db, trial_fn=trial_fn, progress=not args.no_progress,
                            store=store)
    per_method = ", ".join(f"{m} {summary.successes.get(m, 0)}/{summary.done.get(m, 0)}" for m in config.methods)
    failures = ", ".join(f"{k} {v}" for k, v in sorted(summary.failures.items())) or "none"
    print(f"{summary.ran} trials run, {summary.skipped} already stored, {summary.total} in the sweep "
          f"({summary.wall_s:.1f} s) -> {args.db}")
    print(f"successes: {per_method}; failures of this run: {failures}")
    return 0
