"""Size the planner's deterministic budget: the edge checks (`PlanResult.n_checks`) each
`motion.planner.plan` call of the grasp-only harness makes, with the check cap raised to
--cap, and the CPU time of the call (thread time), so the checks per CPU second (what an
idle machine does in the old wall-clock budget) and the checks successful plans need can be
read off. Diagnosis only (prints one JSON line per call and a summary).

Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_plan_checks.py --levels 1 3 --start 0 --count 3`."""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.grasp import select as select_module
from compass_manip.motion import planner as planner_module
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.grasp_only import GraspOnlyConfig, run_grasp_only
from compass_manip.trial import grasp_stage, inspect as inspect_module

CALLS: list[dict] = []


def instrument(cap: int):
    """Patch the planner as the grasp selection and grasp stage import it: every call runs
    with max_checks=cap and no clock, and is logged."""
    original = planner_module.plan

    def logged_as(caller):
        return lambda *a, **k: logged(caller, *a, **k)

    def logged(caller, q_start, q_goals, validity, config=None, rng=None):
        config = dataclasses.replace(config or planner_module.PlannerConfig(), max_checks=cap, time_budget=None)
        c0, t0 = time.thread_time(), time.perf_counter()
        r = original(q_start, q_goals, validity, config, rng)
        CALLS.append({"caller": caller, "checks": int(r.n_checks), "success": bool(r.success),
                      "failure": None if r.failure is None else r.failure.name,
                      "cpu_s": time.thread_time() - c0, "wall_s": time.perf_counter() - t0})
        return r

    for module in (select_module, grasp_stage, inspect_module):
        module.plan = logged_as(module.__name__.rsplit(".", 1)[-1])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 3])
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--count", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cap", type=int, default=200000)
    args = ap.parse_args()
    instrument(args.cap)
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            n0 = len(CALLS)
            r = run_grasp_only(certified_scene(level, index, args.seed).scene, GraspOnlyConfig(), seed=args.seed)
            for c in CALLS[n0:]:
                print(json.dumps({"level": level, "index": index, **c}), flush=True)
            sel = r.selection
            print(json.dumps({"level": level, "index": index, "success": bool(r.success),
                              "selection_failure": None if sel is None or sel.failure is None else sel.failure.name}),
                  flush=True)
    ok = np.array([c["checks"] for c in CALLS if c["success"]])
    big = [c for c in CALLS if c["checks"] >= 2000]
    rate = sum(c["checks"] for c in big) / max(sum(c["cpu_s"] for c in big), 1e-9)
    print(json.dumps({"calls": len(CALLS), "successes": int(ok.size),
                      "success_checks_p50_p90_p99_max": [float(np.percentile(ok, p)) for p in (50, 90, 99, 100)]
                      if ok.size else None,
                      "checks_per_cpu_s (calls >= 2000 checks)": rate}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
