"""Diagnosis (GROUND TRUTH, read here only): which frames of a find-only trial saw what.

Runs one find-only trial (COMPASS unless --method names another) with the detection buffer replaced by a recording one and
prints, per processed frame with a region of the query's colour: the frame's time [s], the
camera position [m], and per region its verdict, shape as seen, extents [cm], completeness,
pixel count, box, centroid [m] and the scene object most of its points lie in (ground truth:
each object's bounding box grown by 1.5 cm; '-' for none; CONFIRMED marks a detection accepted
by `perception.confirm`), then the places of tentative matches at the end (frames, the span of
their cameras, vetoed or not) and the trial's end. Variants: `--variant default` (the
trial's `TrialConfig()`), `old` (`trial_variants.find_only_old_config()`: one frame accepts),
`strict` (the detector accepts only whole views, min_completeness 0.99: to see which later
frames see the place of a first-frame match when nothing is accepted there).
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_confirm.py --level 3 --scene 8 --seed 3131`.
"""
from __future__ import annotations

import argparse
import json
import os
from dataclasses import replace

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.perception import buffer as buffer_mod
from compass_manip.trial import runner
from compass_manip.trial.runner import TrialSpec, run_trial_full
import trial_variants


def owner(scene, det, margin: float = 0.015) -> str:
    """The scene object holding most of the detection's points (ground truth), or '-'."""
    P = np.asarray(det.points_world, float).reshape(-1, 3)
    best, best_n = "-", 0
    for o in scene.objects:
        lo, hi = o.aabb()
        n = int(np.all((P >= lo - margin) & (P <= hi + margin), axis=1).sum())
        if n > best_n:
            size = 100 * (hi - lo)
            best, best_n = f"{o.name}:{o.category}:{o.colour}:{size[0]:.1f}x{size[1]:.1f}x{size[2]:.1f}", n
    return best if best_n >= 0.5 * len(P) else best + "(minority)" if best_n else "-"


class RecordingBuffer(buffer_mod.DetectionBuffer):
    log: list = []
    instances: list = []

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        RecordingBuffer.instances.append(self)

    def _process(self, obs) -> None:
        super()._process(obs)
        with self._lock:
            dets = self._window[-1][1]
        RecordingBuffer.log.append((obs, dets))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--scene", type=int, default=8)
    ap.add_argument("--seed", type=int, default=3131)
    ap.add_argument("--variant", choices=("default", "old", "strict"), default="default")
    ap.add_argument("--method", default="compass", help="exploration method (registry name)")
    ap.add_argument("--hue-check", choices=("default", "on", "off"), default="default",
                    help="the detector's hue check (DetectorConfig.hue_check)")
    args = ap.parse_args()
    config = trial_variants.find_only_config()
    if args.variant == "old":
        config = trial_variants.find_only_old_config()
    elif args.variant == "strict":
        config = replace(config, detector=replace(config.detector, min_completeness=0.99))
    if args.hue_check != "default":
        config = replace(config, detector=replace(config.detector, hue_check=args.hue_check == "on"))
    runner.DetectionBuffer = RecordingBuffer
    run = run_trial_full(TrialSpec(args.method, args.level, args.scene, 0, args.seed), config)
    scene = run.scene
    q = scene.task().target
    print(f"query: {q.colour} {q.shape} {np.round(100 * np.asarray(q.size), 1)} cm; target at "
          f"{np.round(scene.target.pos, 3)}")
    for obs, dets in RecordingBuffer.log:
        if not dets:
            continue
        cam = np.round(obs.T_world_cam[:3, 3], 3)
        print(f"t {obs.t:7.2f} cam {cam}")
        for d in dets:
            ext = " x ".join(f"{100 * e:.1f}" for e in d.extents)
            tag = "CONFIRMED " if d.verdict.value == "accepted" and d.score < 0.6 else ""
            print(f"    {tag}{d.verdict.value:12s} {d.shape:7s} {ext:18s} c {d.score:.2f} px {d.n_pixels:5d} "
                  f"bbox {d.bbox} at {np.round(d.centroid_world, 3)} -> {owner(scene, d)}"
                  + ("" if d.cut is None else f" cut o/op/c {d.cut.occluded:.2f}/{d.cut.open:.2f}/{d.cut.continued:.2f}"))
    for buf in RecordingBuffer.instances:
        for c in buf.confirmer.candidates:
            print(f"candidate from t {c.t:.2f}: {c.n_frames} frames, cameras {len(c.cameras)} spanning "
                  f"{max(np.linalg.norm(a - b) for a in c.cameras for b in c.cameras):.3f} m, vetoed {c.vetoed}, "
                  f"at {np.round(c.centroid, 3)}")
    r = run.result
    found = run.outcome.found
    print(json.dumps({"failure": None if r.failure is None else r.failure.value, "tft_s": r.tft_s,
                      "true_detection": r.true_detection,
                      "found_t": None if found is None else found.detection.t,
                      "found_at": None if found is None else np.round(found.detection.centroid_world, 3).tolist()}))


if __name__ == "__main__":
    main()
