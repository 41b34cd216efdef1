"""Side-by-side trials of FV / IG / IG-occlusion / GSE / COMPASS / oracle on development
seeds (issue 10). Writes one JSON line per trial to --out as trials finish.

    python benchmarks/baselines_side_by_side.py --levels 1 2 3 4 --scenes 0 --seed 101 \
        --methods fv ig ig-occlusion gse compass oracle --workers 2 --out outputs/baselines.jsonl
"""
from __future__ import annotations

import argparse
import json
import time
import traceback
from multiprocessing import Pool


def _run(job):
    method, level, scene, seed = job
    from compass_manip.trial.runner import TrialSpec, run_trial

    t0 = time.perf_counter()
    try:
        r = run_trial(TrialSpec(method, level, scene, 0, seed))
        rec = r.to_dict()
        rec.pop("explored_curve", None)
    except Exception as exc:  # recorded, not hidden: the table counts it as an error
        rec = {"method": method, "level": level, "scene": scene, "seed": seed, "error": repr(exc),
               "traceback": traceback.format_exc()}
    rec["wall_s"] = time.perf_counter() - t0
    return rec


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4])
    p.add_argument("--scenes", type=int, nargs="+", default=[0])
    p.add_argument("--seed", type=int, default=101)
    p.add_argument("--methods", nargs="+", default=["fv", "ig", "ig-occlusion", "gse", "compass", "oracle"])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", required=True)
    a = p.parse_args()
    jobs = [(m, lv, sc, a.seed) for sc in a.scenes for lv in a.levels for m in a.methods]
    with Pool(a.workers) as pool, open(a.out, "a") as f:
        for rec in pool.imap_unordered(_run, jobs):
            f.write(json.dumps(rec) + "\n")
            f.flush()


if __name__ == "__main__":
    main()
