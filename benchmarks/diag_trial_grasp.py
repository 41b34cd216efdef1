"""Diagnose the trial's GRASP state on a few trials: per trial the outcome, the INSPECT / scan
views reached and the selection's rejections per reason (what `compass bench` does not store).

Run (benchmarks/ on PYTHONPATH): `python benchmarks/diag_trial_grasp.py --variant grasp_scan
--levels 1 2 --scenes 0 1 --seed 303` (variant: a function name of `trial_variants`, or
"default" for `TrialConfig()`). One JSON line per trial on stdout.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import trial_variants  # noqa: E402

from compass_manip.trial.config import TrialConfig  # noqa: E402
from compass_manip.trial import runner  # noqa: E402
from compass_manip.trial.runner import TrialSpec, run_trial_full  # noqa: E402

_LOOKS: list = []


class _KeptLooks(runner.BaseLooks):  # kept to print what the looks outside the cabinet did
    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        _LOOKS.append(self)


runner.BaseLooks = _KeptLooks


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="default")
    ap.add_argument("--levels", type=int, nargs="+", default=[1])
    ap.add_argument("--scenes", type=int, nargs="+", default=[0])
    ap.add_argument("--seed", type=int, default=303)
    ap.add_argument("--method", default="compass")
    args = ap.parse_args()
    config = TrialConfig() if args.variant == "default" else getattr(trial_variants, args.variant + "_config")()
    for level in args.levels:
        for scene in args.scenes:
            t0 = time.perf_counter()
            _LOOKS.clear()
            run = run_trial_full(TrialSpec(args.method, level, scene, 0, args.seed), config)
            r, g = run.result, run.outcome.grasp
            sel = None if g is None else g.selection
            out = g.outcome if g is not None else None
            print(json.dumps({
                "level": level, "scene": scene, "success": r.success, "failure": None if r.failure is None
                else r.failure.name, "found": r.found, "collisions": r.collisions, "n_inspected": run.outcome.n_inspected,
                "n_looks": None if g is None else g.n_looks, "look_log": None if g is None else list(g.look_log),
                "t_end": round(run.outcome.t_end, 1), "selection_failure": None if sel is None or sel.failure is None
                else sel.failure.name, "rejections": None if sel is None else {k.name: v for k, v in sel.rejections.items()},
                "select_s": None if sel is None else round(sel.time_s, 2),
                "exec": None if out is None else [f"{c.phase}:{c.robot_geom}->{c.other_geom}" for c in out.collisions]
                + [None if out.failure is None else out.failure.name],
                "looks": [{"looks": b.looks, "returned": b.returned, "stopped": b.stopped,
                           "inner_calls": b.inner_calls, "log": b.log} for b in _LOOKS],
                "wall_s": round(time.perf_counter() - t0, 1)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
