"""Real time per CPU second of a sample of find-only trials, with each trial's fingerprint
(a measurement, not a test; docs/compass_loop.md, "Real time, second round").

Runs the trials one after another in this process (scenes certified first, one warm-up
trial for numba's cache and the renderer) and prints one JSON line per trial: simulated s,
process CPU s (all threads), wall s, sim / CPU, the outcome (found, failure, collisions,
TFT, decisions, frames) and a hash of the executed camera path and the final q; then the
median, p10, p90 and pooled sim / CPU. Two runs of different code on the same trials can be
compared line by line (`--out` writes the rows as JSON).

  python scripts/realtime_sample.py --methods compass,gse --levels 1,2,3,4 --scenes 3 --seed 606 [--out rows.json]

--map-stride and --detector-period override the exploration map's `MapConfig.pixel_stride`
and the detector's `BufferConfig.min_period_s` [s] (docs/compass_loop.md, "Real time, sixth
round"; both off by default: `--map-stride 1 --detector-period 0`).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import replace

import numpy as np


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--methods", default="compass,gse")
    p.add_argument("--levels", default="1,2,3,4")
    p.add_argument("--scenes", type=int, default=3)
    p.add_argument("--seed", type=int, default=606)
    p.add_argument("--out", default=None)
    p.add_argument("--map-stride", type=int, default=None)
    p.add_argument("--detector-period", type=float, default=None)
    args = p.parse_args(argv)
    from compass_manip.errors import CompassInputError
    from compass_manip.sim.certify import certified_scene
    from compass_manip.trial.config import GraspTrialConfig, TrialConfig
    from compass_manip.trial.runner import TrialSpec, check_spec, run_trial_full

    try:
        levels = [int(x) for x in args.levels.split(",")]
        if args.scenes < 1:
            raise CompassInputError(f"--scenes {args.scenes} is not allowed; use 1 or more")
        specs = [check_spec(TrialSpec(m, lv, s, 0, args.seed)) for m in args.methods.split(",") for lv in levels
                 for s in range(args.scenes)]
        config = TrialConfig(grasp=GraspTrialConfig(enabled=False))
        if args.map_stride is not None:
            world = replace(config.method.world, map=replace(config.method.world.map, pixel_stride=args.map_stride))
            config = replace(config, method=replace(config.method, world=world))
        if args.detector_period is not None:
            config = replace(config, buffer=replace(config.buffer, min_period_s=args.detector_period))
    except (CompassInputError, ValueError) as exc:
        print(f"realtime_sample: {exc}", file=sys.stderr)
        return 2
    for spec in specs:
        certified_scene(spec.level, spec.scene, spec.seed)
    run_trial_full(specs[0], config)  # warm-up
    rows = []
    for spec in specs:
        c0, w0 = time.process_time(), time.perf_counter()
        run = run_trial_full(spec, config)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        r, o = run.result, run.outcome
        digest = hashlib.sha1(np.ascontiguousarray(o.camera_path).tobytes() + np.asarray(o.q_end).tobytes())
        row = dict(method=spec.method, level=spec.level, scene=spec.scene, sim_s=round(o.t_end, 4),
                   cpu_s=round(cpu, 3), wall_s=round(wall, 3), rt_cpu=round(o.t_end / cpu, 2), found=r.found,
                   failure=None if r.failure is None else r.failure.value, collisions=r.collisions, tft=r.tft_s,
                   decisions=r.decisions, frames=len(o.camera_path), fingerprint=digest.hexdigest()[:12])
        rows.append(row)
        print(json.dumps(row), flush=True)
    rt = np.array([r["sim_s"] / r["cpu_s"] for r in rows])
    pooled = sum(r["sim_s"] for r in rows) / sum(r["cpu_s"] for r in rows)
    print(f"sim s per CPU s: median {np.median(rt):.2f}, p10 {np.percentile(rt, 10):.2f}, "
          f"p90 {np.percentile(rt, 90):.2f}, pooled {pooled:.2f} over {len(rows)} trials")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(rows, f, indent=0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
