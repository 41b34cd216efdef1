"""System figures of the benchmark machinery: store and runner overhead, trials per hour, pool scaling.

Prints one JSON object per line (bench.stats). Run: `.venv/bin/python benchmarks/bench_system.py`.
- bench.store_add_ms: one trial row written in its own transaction (a 200-point explored curve).
- bench.runner_overhead_ms_per_trial: sweep wall time per trial with a zero-time synthetic
  trial on one worker (process start-up, IPC, store, progress), i.e. what the runner adds.
- bench.trials_per_hour: real simulated trials on this machine (2 workers); only when the
  trial package is in this build, otherwise said on stderr.
- bench.local_speedup_2_vs_1 / bench.ray_speedup_2_vs_1: sweep wall time of 4 synthetic
  trials that each sleep 1 s on 1 worker over 2 workers (scheduling, not compute; Ray only
  when installed, each run including its ray.init).
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from functools import partial

from compass_manip.bench.runner import run_sweep
from compass_manip.bench.stats import emit_samples, emit_value, load_average
from compass_manip.bench.store import ResultsStore, TrialRecord
from compass_manip.bench.sweep import Spec, SweepConfig
from compass_manip.bench.synthetic import SyntheticConfig, synthetic_trial


def store_add_ms(tmp: str, n: int = 200) -> list[float]:
    config, result = synthetic_trial(Spec("compass", 4, 0, 0, 0))
    result["explored_curve"] = [[float(t), t / 200.0] for t in range(200)]
    out = []
    with ResultsStore(os.path.join(tmp, "store.sqlite"), create=True) as store:
        for i in range(n):
            rec = TrialRecord("compass", 4, i, 0, 0, True, None, None, "bench", config, result, 1.0)
            t0 = time.perf_counter()
            store.add(rec)
            out.append((time.perf_counter() - t0) * 1e3)
    return out


def sweep_wall_s(tmp: str, name: str, config: SweepConfig, trial_fn) -> float:
    t0 = time.perf_counter()
    run_sweep(config, os.path.join(tmp, name), trial_fn=trial_fn, progress=False)
    return time.perf_counter() - t0


def main() -> None:
    ctx = {"load_1min": load_average(), "cpus": os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        emit_samples("bench.store_add_ms", store_add_ms(tmp), "ms", **ctx)
        n = 200
        zero = SweepConfig(methods=("compass",), levels=(1,), scenes=n, trials=1, workers=1)
        wall = sweep_wall_s(tmp, "zero.sqlite", zero, synthetic_trial)
        emit_value("bench.runner_overhead_ms_per_trial", 1e3 * wall / n, "ms", digits=2, n=n, **ctx)

        try:
            from compass_manip.bench.sweep import resolve_trial_fn

            real = resolve_trial_fn()
        except Exception as exc:  # noqa: BLE001 (the trial package may be absent in this build)
            print(f"bench.trials_per_hour skipped: {exc}", file=sys.stderr)
        else:
            config = SweepConfig(methods=("compass",), levels=(1,), scenes=1, trials=4, workers=2)
            wall = sweep_wall_s(tmp, "real.sqlite", config, real)
            emit_value("bench.trials_per_hour", 4 * 3600.0 / wall, "trials/h", digits=1, n=4, workers=2, **ctx)

        sleepy = partial(synthetic_trial, config=SyntheticConfig(sleep_s=1.0))
        one = SweepConfig(methods=("compass",), levels=(1,), scenes=4, trials=1, workers=1)
        two = SweepConfig(methods=("compass",), levels=(1,), scenes=4, trials=1, workers=2)
        w1, w2 = sweep_wall_s(tmp, "l1.sqlite", one, sleepy), sweep_wall_s(tmp, "l2.sqlite", two, sleepy)
        emit_value("bench.local_speedup_2_vs_1", w1 / w2, "x", digits=2, wall_1_s=round(w1, 2), wall_2_s=round(w2, 2))
        try:
            import ray  # noqa: F401
        except ImportError:
            print("bench.ray_speedup_2_vs_1 skipped: ray (the [cluster] extra) is not installed", file=sys.stderr)
        else:
            w1 = sweep_wall_s(tmp, "r1.sqlite", SweepConfig(**{**one.__dict__, "ray_address": "local"}), sleepy)
            w2 = sweep_wall_s(tmp, "r2.sqlite", SweepConfig(**{**two.__dict__, "ray_address": "local"}), sleepy)
            emit_value("bench.ray_speedup_2_vs_1", w1 / w2, "x", digits=2, wall_1_s=round(w1, 2),
                       wall_2_s=round(w2, 2), context="each run includes ray.init and shutdown")


if __name__ == "__main__":
    main()
