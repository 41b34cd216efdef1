"""`compass demo`: one COMPASS trial end to end on a certified scene (Level 4 by default).

Runs the whole loop (near-field scan, MUE-RRT decisions, asynchronous detection, the trial
state machine on the simulated clock) and writes the trial's outputs: result.json (metrics,
config, scene), camera_path.png (the executed camera path over the scene) and explored.png
(the explored fraction of the target's surroundings over time). Prints where they are.
"""
from __future__ import annotations

import json
import os
import sys

from ..errors import CompassInputError

HELP = "run one COMPASS trial on a certified scene and write its outputs"


def add_arguments(p) -> None:
    p.add_argument("--level", type=int, default=4, help="difficulty level 1..4 (default 4)")
    p.add_argument("--index", type=int, default=0, help="scene index (default 0)")
    p.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    p.add_argument("--trial", type=int, default=0, help="trial index (default 0)")
    p.add_argument("--method", default="compass", help="registered method (default compass)")
    p.add_argument("--time-limit", type=float, default=200.0, help="simulated time limit [s] (default 200)")
    p.add_argument("--out", default="outputs/demo", help="output folder (default outputs/demo)")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object on stdout")


def run(args) -> int:
    from ..trial.runner import TrialSpec, check_spec
    from .run import check_out, save_trial

    spec = check_spec(TrialSpec(args.method, args.level, args.index, args.trial, args.seed))
    if not 0 < args.time_limit <= 3600:
        raise CompassInputError(f"--time-limit {args.time_limit} s is not allowed; use 0 < limit <= 3600 s")
    out = check_out(args.out)
    from ..trial.config import TrialConfig
    from ..trial.runner import run_trial_full

    config = TrialConfig(time_limit_s=args.time_limit)
    print(f"compass demo: {spec.method}, level {spec.level} scene {spec.scene} (seed {spec.seed}), "
          f"trial {spec.trial}", file=sys.stderr)
    result_run = run_trial_full(spec, config, lambda line: print(f"\r  {line}", end="", file=sys.stderr, flush=True))
    print("", file=sys.stderr)
    paths = save_trial(result_run, config, out)
    r = result_run.result.to_dict()
    if args.json:
        print(json.dumps({**r, "outputs": paths}))
        return 0
    verdict = f"found the target at {r['tft_s']:.1f} s" if r["success"] else f"failed: {r['failure']}"
    print(f"{spec.method} {verdict} after {r['decisions']} decisions, {r['collisions']} collisions, "
          f"{r['wall_s']:.1f} s wall time")
    print(f"outputs in {os.path.abspath(out)}:")
    for name, path in paths.items():
        print(f"  {name:>12}: {path}")
    return 0


