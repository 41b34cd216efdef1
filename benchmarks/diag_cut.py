"""Diagnosis (GROUND TRUTH, read here only): what cuts off the regions the detector cannot
judge whole, on the target and on other objects.

Runs find-only COMPASS trials with a recording detection buffer and writes one JSON line per
TENTATIVE or WRONG_SHAPE region of a processed frame: trial, time [s], verdict, completeness,
extents [cm], `perception.cut.CutKinds` (occluded / open / continued shares of the pixels
just outside its outline) and whether most of its points lie in the target (ground truth:
the target's bounding box grown by 1.5 cm). `--summary` prints, per owner (target or not),
how the continued share is distributed, and which regions a rule `continued >= X` would drop.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_cut.py --seed 3131 --levels 3 --scenes 0-9 --out F.jsonl`.
"""
from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.perception import buffer as buffer_mod
from compass_manip.perception.detector import Verdict
from compass_manip.trial import runner
from compass_manip.trial.runner import TrialSpec, run_trial_full
import trial_variants

_KEEP = (Verdict.TENTATIVE, Verdict.WRONG_SHAPE)


class RecordingBuffer(buffer_mod.DetectionBuffer):
    log: list = []

    def _process(self, obs) -> None:
        super()._process(obs)
        with self._lock:
            dets = self._window[-1][1]
        RecordingBuffer.log.extend((float(obs.t), d) for d in dets if d.cut is not None or d.verdict in _KEEP)


def in_target(scene, det, margin: float = 0.015) -> bool:
    P = np.asarray(det.points_world, float).reshape(-1, 3)
    lo, hi = scene.target.aabb()
    return bool(np.all((P >= lo - margin) & (P <= hi + margin), axis=1).mean() >= 0.5)


def scenes_arg(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def collect(args) -> None:
    runner.DetectionBuffer = RecordingBuffer
    config = trial_variants.find_only_config()
    with open(args.out, "a") as f:
        for level in [int(x) for x in args.levels.split(",")]:
            for scene_i in scenes_arg(args.scenes):
                RecordingBuffer.log = []
                run = run_trial_full(TrialSpec("compass", level, scene_i, 0, args.seed), config)
                for t, d in RecordingBuffer.log:
                    c = d.cut
                    f.write(json.dumps({
                        "seed": args.seed, "level": level, "scene": scene_i, "t": t, "verdict": d.verdict.value,
                        "shape": d.shape, "score": round(d.score, 3), "ext_cm": [round(100 * e, 1) for e in d.extents],
                        "occluded": None if c is None else round(c.occluded, 3),
                        "open": None if c is None else round(c.open, 3),
                        "continued": None if c is None else round(c.continued, 3),
                        "ring": None if c is None else c.n, "target": in_target(run.scene, d),
                        "found_t": None if run.outcome.found is None else run.outcome.found.detection.t}) + "\n")
                f.flush()
                print(f"seed {args.seed} level {level} scene {scene_i}: {len(RecordingBuffer.log)} regions, "
                      f"tft {run.result.tft_s}", flush=True)


def summary(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    rows = [r for r in rows if r["continued"] is not None]
    kinds = {"match": ("tentative", "partial", "accepted"), "wrong shape": ("wrong shape",)}
    for kind, verdicts in kinds.items():  # a match: TENTATIVE when cut (PARTIAL under the rule, ACCEPTED once confirmed)
        for tgt in (True, False):
            sel = [r for r in rows if r["verdict"] in verdicts and r["target"] is tgt]
            if not sel:
                continue
            c = np.array([r["continued"] for r in sel])
            o = np.array([r["occluded"] for r in sel])
            trials = len({(r["seed"], r["level"], r["scene"]) for r in sel})
            print(f"{kind:12s} target={tgt!s:5s} n {len(c):5d} in {trials:3d} trials: continued median {np.median(c):.2f} "
                  f"p90 {np.percentile(c, 90):.2f} max {c.max():.2f}; occluded min {o.min():.2f} median {np.median(o):.2f}")
    for x in (0.1, 0.2, 0.3, 0.4, 0.5):
        for tgt in (True, False):
            sel = [r for r in rows if r["target"] is tgt]
            drop = [r for r in sel if r["continued"] >= x]
            trials = sorted({(r["seed"], r["level"], r["scene"]) for r in drop})
            print(f"continued >= {x}: target={tgt!s:5s} {len(drop)}/{len(sel)} regions, trials {trials[:8]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=3131)
    ap.add_argument("--levels", default="3")
    ap.add_argument("--scenes", default="0-9")
    ap.add_argument("--out", default="cut.jsonl")
    ap.add_argument("--summary", action="store_true")
    args = ap.parse_args()
    summary(args.out) if args.summary else collect(args)


if __name__ == "__main__":
    main()
