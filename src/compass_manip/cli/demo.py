"""`compass demo`: one COMPASS trial end to end on a certified scene (Level 4 by default).

Runs the whole loop (near-field scan, MUE-RRT decisions, asynchronous detection, the trial
state machine on the simulated clock) and writes the trial's outputs: result.json (metrics,
config, scene), camera_path.png (the executed camera path over the scene), explored.png
(the explored fraction of the target's surroundings over time) and trial.mp4 (the trial's
video, `viz.video`; `--no-video` skips it). Prints where they are.
"""
from __future__ import annotations

import argparse
import json
import os

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
    p.add_argument("--video", action=argparse.BooleanOptionalAction, default=True,
                   help="write trial.mp4 into the output folder (default: yes)")


def run(args) -> int:
    from .run import run_checked_trial, save_trial

    if not 0 <= args.index < 2**63:  # named as the user gave it (the trial's spec calls it the scene)
        raise CompassInputError(f"--index {args.index} is not allowed; use a scene index 0 <= index < 2**63")
    video = os.path.join(args.out, "trial.mp4") if args.video and args.out else None
    result_run, config, out = run_checked_trial(
        "demo", (args.method, args.level, args.index, args.trial, args.seed), args.time_limit, args.out, video=video)
    paths = save_trial(result_run, config, out)
    if video is not None:
        paths["video"] = os.path.abspath(video)
    r = result_run.result.to_dict()
    if args.json:
        print(json.dumps({**r, "outputs": paths}))
        return 0
    if r["success"]:
        verdict = f"found the target at {r['tft_s']:.1f} s and grasped it"
    elif r.get("found"):
        verdict = f"found the target at {r['tft_s']:.1f} s, then failed: {r['failure']}"
    else:
        verdict = f"failed: {r['failure']}"
    print(f"{result_run.result.method} {verdict} after {r['decisions']} decisions, {r['collisions']} collisions, "
          f"{r['wall_s']:.1f} s wall time")
    print(f"outputs in {os.path.abspath(out)}:")
    for name, path in paths.items():
        print(f"  {name:>12}: {path}")
    return 0


