"""Diagnosis (GROUND TRUTH, read here only): why the trial's GRASP state rejects hands, as
`diag_hand_rejections.py` does for the grasp-only harness, on the end-to-end trial's own
selection inputs (its map, fine map, target model from the accepted detection, own space).

Per scene the trial runs (COMPASS, the variant's config) up to its first `select_grasp` call,
whose inputs are captured; then `diag_hand_rejections.diagnose`'s analysis runs on them. Also
printed: the detection's points against the true target (fraction within 1 cm of its surface)
and the target model's extent against the true target's.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_trial_hands.py --variant grasp_inspect_halo
--levels 1 --start 0 --count 3 --seed 2026`.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import diag_hand_rejections as dhr
import trial_variants
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.sim.certify import certified_scene
from compass_manip.trial import grasp_stage, runner
from compass_manip.trial.config import TrialConfig
from diag_grasp_certified import _dists


def trial_capture(config: TrialConfig, level: int, index: int):
    """A `capture(scene, seed)` replacement: the trial's first selection inputs."""
    def capture(scene, seed: int) -> dict:
        box: dict = {}
        orig_sel, orig_stage = grasp_stage.select_grasp, grasp_stage.run_grasp_stage

        def sel(target, occ, task, q, sph, cfg, rng, **kw):
            box.update(target=target, occ=occ, task=task, q=q, config=cfg, rng=copy.deepcopy(rng), **kw)
            raise StopIteration

        def stage(world, occupancy, detection, *a, **k):
            box["T_world_cam"] = np.array(detection.T_world_cam)
            box["points"] = np.asarray(detection.points_world, dtype=np.float64).reshape(-1, 3)
            return orig_stage(world, occupancy, detection, *a, **k)

        orig_runner_stage = runner.run_grasp_stage
        grasp_stage.select_grasp, runner.run_grasp_stage = sel, stage
        try:
            runner.run_trial_full(runner.TrialSpec("compass", level, index, 0, seed), config)
        except StopIteration:
            pass
        finally:
            grasp_stage.select_grasp, runner.run_grasp_stage = orig_sel, orig_runner_stage
        boxes.append(box)
        return box
    boxes: list = []
    return capture, boxes


def main() -> int:
    ap = dhr.scene_arguments(argparse.ArgumentParser())
    ap.add_argument("--variant", default="default")
    args = ap.parse_args()
    config = TrialConfig() if args.variant == "default" else getattr(trial_variants, args.variant + "_config")()
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            dhr.capture, boxes = trial_capture(config, level, index)
            rec = dhr.diagnose(level, index, args.seed)
            scene = certified_scene(level, index, args.seed).scene
            tgt = PrimitiveSet.from_shapes(list(scene.target.parts)).arrays()
            cap = boxes[0] if boxes else {}
            if "points" in cap:
                d = _dists(np.ascontiguousarray(cap["points"]), tgt)
                rec["det_points"] = int(len(d))
                rec["det_within_1cm"] = round(float(np.mean(np.abs(d) <= 0.01)), 3)
                tp = cap["target"].points
                dt = _dists(np.ascontiguousarray(tp), tgt)
                rec["model_points"] = int(len(tp))
                rec["model_within_1cm"] = round(float(np.mean(np.abs(dt) <= 0.01)), 3)
                rec["model_extent"] = np.round(tp.max(0) - tp.min(0), 3).tolist()
            print(json.dumps(rec), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
