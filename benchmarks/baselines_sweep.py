"""The small parameter sweep behind the baselines' defaults (issue 10, docs/baselines.md).

Each variant is a registered baseline with one or two fields changed; every variant runs
the same development trials (levels x scenes, seed 101 by default). One JSON line per
trial is appended to --out as trials finish.

    python benchmarks/baselines_sweep.py --levels 1 2 --scenes 0 1 --seed 101 --workers 2 \
        --out outputs/baselines_sweep.jsonl
"""
from __future__ import annotations

import argparse
import json
from dataclasses import replace
from multiprocessing import Pool

import numpy as np

from baselines_side_by_side import _run as _run_trial  # same record, same error handling


def variants() -> dict:
    from compass_manip.exploration.baselines import FV_CONFIG, GSE_CONFIG, IG_CONFIGS, fv_factory, gse_factory, \
        ig_factory

    ig = IG_CONFIGS["ig"]
    # the sweep ran from these starting points (the defaults before it); the chosen values are now the defaults
    fv0 = replace(FV_CONFIG, heights=(0.75, 0.4), lateral=(0.15, 0.5, 0.85))
    gse0 = replace(GSE_CONFIG, local_range=0.6, retry_iterations_factor=1)
    return {
        "fv": fv_factory("fv", fv0),
        "fv|rows3": fv_factory("fv|rows3", replace(fv0, heights=(0.8, 0.5, 0.2))),
        "fv|rows3-close": fv_factory("fv|rows3-close", replace(fv0, heights=(0.8, 0.5, 0.2), standoff=0.15)),
        "fv|grid3x5": fv_factory("fv|grid3x5", replace(fv0, heights=(0.85, 0.55, 0.25),
                                                      lateral=(0.0, 0.25, 0.5, 0.75, 1.0))),
        "fv|rows3-steep": fv_factory("fv|rows3-steep", replace(fv0, heights=(0.8, 0.5, 0.2), rise=0.15,
                                                               depth=0.8)),
        "ig": ig_factory("ig", ig),
        "ig|rounds1": ig_factory("ig|rounds1", replace(ig, rounds=1)),
        "ig|n96": ig_factory("ig|n96", replace(ig, n_views=96)),
        "ig|radius-in": ig_factory("ig|radius-in", replace(ig, radius=(0.15, 0.75))),
        "ig|aim-centre": ig_factory("ig|aim-centre", replace(ig, aim_spread=0.0)),
        "gse": gse_factory("gse", gse0),
        "gse|global-range": gse_factory("gse|global-range", replace(gse0, local_range=np.inf)),
        "gse|lambda0": gse_factory("gse|lambda0", replace(gse0, path_lambda=0.0)),
    }


def _run(job):
    """One trial of a swept variant: registered under its name in this worker, then run
    like every side-by-side trial."""
    from compass_manip.exploration import registry

    name = job[0]
    registry.METHODS.setdefault(name, variants()[name])
    return _run_trial(job)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--levels", type=int, nargs="+", default=[1, 2])
    p.add_argument("--scenes", type=int, nargs="+", default=[0, 1])
    p.add_argument("--seed", type=int, default=101)
    p.add_argument("--variants", nargs="+", default=None)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", required=True)
    a = p.parse_args()
    names = a.variants or list(variants())
    jobs = [(n, lv, sc, a.seed) for n in names for lv in a.levels for sc in a.scenes]
    with Pool(a.workers) as pool, open(a.out, "a") as f:
        for rec in pool.imap_unordered(_run, jobs):
            f.write(json.dumps(rec) + "\n")
            f.flush()


if __name__ == "__main__":
    main()
