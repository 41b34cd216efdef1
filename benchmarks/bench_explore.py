"""Exploration benchmark: COMPASS trials on Level 1 and Level 4 scenes.

Prints JSON lines (bench/stats.py): find rate, MPSR, TFT, PFT, decision compute time (NBV
decisions of the MUE-RRT phase and NFA steps separately), real-time factor (simulated
seconds per wall second, one trial per process on one core), collisions and false
detections. Scenes 0..N-1 of each level, trial 0; N from COMPASS_BENCH_SCENES (default 5),
the scene seed from COMPASS_BENCH_SEED (default 0). Over both levels: `explore.decision_ms`
(the whole compute time of an EXPLORE decision: checker rebuild, frontiers, tree, utility,
path check), `trial.wall_s` (start-up included) and `trial.loop_realtime_factor` (simulated
s / wall s of the trial loop over all trials, without the start-up: scene load, simulator and
renderer set-up; `trial.realtime_factor` with the start-up, and its CPU-time variant, are
in bench_system.py). Run: `.venv/bin/python benchmarks/bench_explore.py`.
"""
from __future__ import annotations

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import time

import numpy as np

from compass_manip.bench.stats import emit_rate, emit_samples, emit_value, load_average
from compass_manip.trial.runner import TrialSpec, run_trial_full


def main() -> None:
    n = int(os.environ.get("COMPASS_BENCH_SCENES", "5"))
    seed = int(os.environ.get("COMPASS_BENCH_SEED", "0"))
    everything = []
    for level in (1, 4):
        runs = []
        for scene in range(n):
            run = _timed_run(TrialSpec("compass", level, scene, 0, seed))
            r = run.result
            print(f"[explore] level {level} scene {scene}: found {r.found}, {r.failure.name if r.failure else 'success'}, "
                  f"tft {r.tft_s:.1f} s, {r.decisions} decisions, wall {r.wall_s:.1f} s", file=sys.stderr)
            runs.append(run)
        res = [x.result for x in runs]
        ctx = {"level": level, "scenes": n, "load": load_average()}
        found = [r.found for r in res]  # the find (success is end to end: found and grasped)
        emit_value(f"trial.l{level}.find_rate", float(np.mean(found)), "fraction", n=len(res), **ctx)
        att = sum(x.metrics.plans_attempted for x in runs)
        ok = sum(x.metrics.plans_succeeded for x in runs)
        emit_value(f"trial.l{level}.mpsr", ok / att if att else float("nan"), "fraction", n=att, **ctx)
        emit_samples(f"trial.l{level}.tft_s", [r.tft_s for r in res], "s", **ctx)
        emit_samples(f"trial.l{level}.pft_m", [r.pft_m for r in res], "m", **ctx)
        emit_value(f"trial.l{level}.collisions", sum(r.collisions for r in res), "contacts", **ctx)
        emit_value(f"trial.l{level}.false_detections", sum(r.true_detection is False for r in res), "trials", **ctx)
        sim_t = [x.outcome.t_end for x in runs]
        emit_rate(f"trial.l{level}.realtime_factor", [t / r.wall_s for t, r in zip(sim_t, res)], "x", **ctx)
        emit_samples(f"explore.l{level}.nbv_ms", [v for x in runs for v in x.metrics.nbv_ms], "ms",
                     what="frontiers + tree + utility + path check of one MUE-RRT decision", **ctx)
        emit_samples(f"explore.l{level}.checker_rebuild_ms", [v for x in runs for v in x.metrics.checker_ms], "ms",
                     what="distance field and validity checker on the updated map", **ctx)
        for phase in ("explore", "nfa"):
            ms = [1000 * s for x in runs for s, p in zip(x.metrics.decision_s, x.metrics.decision_phase) if p == phase]
            emit_samples(f"explore.l{level}.{phase}_decision_ms", ms, "ms", **ctx)
        everything += runs
    ctx = {"levels": [1, 4], "scenes": n, "seed": seed, "load": load_average()}
    ms = [1000 * s for x in everything for s, p in zip(x.metrics.decision_s, x.metrics.decision_phase)
          if p == "explore"]
    emit_samples("explore.decision_ms", ms, "ms", what="one EXPLORE decision: checker rebuild, frontiers, tree, "
                 "utility, path check", **ctx)
    emit_samples("explore.nbv_ms", [v for x in everything for v in x.metrics.nbv_ms], "ms",
                 what="frontiers + tree + utility + path check of one MUE-RRT decision", **ctx)
    emit_samples("trial.wall_s", [x.result.wall_s for x in everything], "s", **ctx)
    sim = sum(x.outcome.t_end for x in everything)
    emit_value("trial.loop_realtime_factor", sim / sum(x.loop_s for x in everything), "x",
               what="simulated s / wall s of the trial loop (no scene load, simulator or renderer set-up)", **ctx)


class _Run:
    """A TrialRun with the wall time of its state machine's loop (loop_s [s])."""

    def __init__(self, run, loop_s: float) -> None:
        self.result, self.outcome, self.metrics, self.loop_s = run.result, run.outcome, run.metrics, loop_s


def _timed_run(spec: TrialSpec) -> _Run:
    from compass_manip.trial import runner

    spent = []
    machine_cls = runner.TrialMachine

    class Timed(machine_cls):
        def run(self):
            t0 = time.perf_counter()
            try:
                return super().run()
            finally:
                spent.append(time.perf_counter() - t0)

    runner.TrialMachine = Timed
    try:
        run = run_trial_full(spec)
    finally:
        runner.TrialMachine = machine_cls
    return _Run(run, spent[0])


if __name__ == "__main__":
    main()
