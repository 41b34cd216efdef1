"""System figures of the benchmark machinery: store and runner overhead, trials per hour, pool scaling.

Prints one JSON object per line (bench.stats). Run: `.venv/bin/python benchmarks/bench_system.py`.
- bench.store_add_ms: one trial row written in its own transaction (a 200-point explored curve).
- bench.runner_overhead_ms_per_trial: sweep wall time per trial with a zero-time synthetic
  trial on one worker (process start-up, IPC, store, progress), i.e. what the runner adds.
- bench.trials_per_hour: real simulated trials per hour on this machine with the local
  pool on 2 workers: 4 COMPASS trials (scene 0 of levels 1-4, the default 200 s limit),
  3600 * 4 / sweep wall time (worker start-up included; after one warm-up run of the same
  trials, which certifies and caches the scenes); the 1-worker figure beside it.
- bench.local_scaling_2v1 / bench.ray_scaling_2v1: sweep wall time of those 4 real trials
  on 1 worker over 2 workers, with the local process pool and with a fresh local Ray
  instance of 2 CPUs (each Ray run including ray.init and its shutdown; its init time is
  printed as ray_init_s). On 2 cores shared with other work this is bounded by the load.
- bench.local_speedup_2_vs_1 / bench.ray_speedup_2_vs_1: the same for 4 synthetic trials
  that each sleep 1 s (scheduling, not compute; Ray only when installed).
- trial.realtime_factor / trial.realtime_factor_cpu: simulated seconds per wall second and
  per CPU second of this process (all its threads: the detection worker included, i.e.
  what one core spends) of whole trials (scene load, simulator and renderer set-up
  included): COMPASS, default config (grasp stage on), scenes 0-1 of levels 1-4, trial 0,
  seed 0, one after another in this process after one warm-up trial (numba's cache) and
  with their scenes certified before; median and p10 (the slow end) over the trials and the pooled ratio
  (sum of simulated s / sum of wall or CPU s).
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from functools import partial

import numpy as np

from compass_manip.bench.runner import run_sweep
from compass_manip.bench.stats import emit_rate, emit_samples, emit_value, load_average
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


def ray_sweep_wall_s(tmp: str, name: str, config: SweepConfig, trial_fn) -> tuple[float, float]:
    """(sweep wall time, ray.init time) [s] on a fresh local Ray instance of 2 CPUs."""
    import ray

    t0 = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    t_init = time.perf_counter() - t0
    try:
        run_sweep(SweepConfig(**{**config.__dict__, "ray_address": "local"}), os.path.join(tmp, name),
                  trial_fn=trial_fn, progress=False)
    finally:
        ray.shutdown()
    return time.perf_counter() - t0, t_init


def real_trials(tmp: str, real, ctx: dict) -> None:
    """bench.trials_per_hour, bench.local_scaling_2v1 and bench.ray_scaling_2v1 on 4 real trials."""
    one = SweepConfig(methods=("compass",), levels=(1, 2, 3, 4), scenes=1, trials=1, workers=1)
    two = SweepConfig(**{**one.__dict__, "workers": 2})
    n = len(one.specs())
    # the first run of a scene certifies and caches it and loads numba's cache: warm up once
    warm = sweep_wall_s(tmp, "warm.sqlite", two, real)
    w1, w2 = sweep_wall_s(tmp, "real1.sqlite", one, real), sweep_wall_s(tmp, "real2.sqlite", two, real)
    emit_value("bench.trials_per_hour", n * 3600.0 / w2, "trials/h", digits=1, n=n, workers=2,
               one_worker=round(n * 3600.0 / w1, 1), trials="compass, scene 0 of levels 1-4", **ctx)
    emit_value("bench.local_scaling_2v1", w1 / w2, "x", digits=2, wall_1_s=round(w1, 2), wall_2_s=round(w2, 2),
               warmup_s=round(warm, 2), n=n, **ctx)
    try:
        import ray  # noqa: F401
    except ImportError:
        print("bench.ray_scaling_2v1 skipped: ray (the [cluster] extra) is not installed", file=sys.stderr)
        return
    r1, i1 = ray_sweep_wall_s(tmp, "ray1.sqlite", one, real)
    r2, i2 = ray_sweep_wall_s(tmp, "ray2.sqlite", two, real)
    emit_value("bench.ray_scaling_2v1", r1 / r2, "x", digits=2, wall_1_s=round(r1, 2), wall_2_s=round(r2, 2),
               ray_init_s=[round(i1, 2), round(i2, 2)], excluding_init=round((r1 - i1) / (r2 - i2), 2), n=n,
               context="each run includes ray.init and shutdown", **{**ctx, "load_1min": load_average()})


def realtime_trials(ctx: dict) -> None:
    """trial.realtime_factor and trial.realtime_factor_cpu (see the module docstring)."""
    from compass_manip.trial.runner import TrialSpec, run_trial_full

    from compass_manip.sim.certify import certified_scene

    specs = [TrialSpec("compass", level, scene, 0, 0) for level in (1, 2, 3, 4) for scene in (0, 1)]
    for spec in specs:  # certified (or read from the scene cache) before the timing
        certified_scene(spec.level, spec.scene, spec.seed)
    run_trial_full(TrialSpec("compass", 1, 2, 0, 0))  # warm-up: numba's cache, the renderer
    sim, wall, cpu = [], [], []
    for spec in specs:
        c0, w0 = time.process_time(), time.perf_counter()
        run = run_trial_full(spec)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
        sim.append(run.outcome.t_end)
    what = "COMPASS, scenes 0-1 of levels 1-4, trial 0, seed 0, grasp stage on, start-up included"
    extra = {**ctx, "load_1min": load_average(), "sim_s": round(sum(sim), 1), "what": what}
    for name, spent in (("trial.realtime_factor", wall), ("trial.realtime_factor_cpu", cpu)):
        rates = [s / w for s, w in zip(sim, spent)]
        emit_rate(name, rates, "x", p90=round(float(np.percentile(rates, 90)), 2),
                  pooled=round(sum(sim) / sum(spent), 2), spent_s=round(sum(spent), 1), **extra)


def main() -> None:
    ctx = {"load_1min": load_average(), "cpus": os.cpu_count()}
    realtime_trials(ctx)
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
            real_trials(tmp, real, ctx)

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
