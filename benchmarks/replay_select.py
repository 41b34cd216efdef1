"""Replay captured `select_grasp` inputs (`capture_select_inputs.py`) with config overrides:
per scene the failure or the chosen grasp, rejections, time, and (GROUND TRUTH, diagnosis only)
whether the chosen manoeuvre is free of the true scene: the path to the pre-grasp (target
included) and the straight approach and lift (target excluded), densified at 1 cm of joint
motion, on the planner's sphere model with margin 0.

Run: `PYTHONPATH=src:benchmarks python benchmarks/replay_select.py --dir DIR [--set max_checked=200 ...]`."""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from capture_select_inputs import capture_arguments, read_captures
from compass_manip.grasp.select import select_grasp
from compass_manip.motion.planner import PlannerConfig  # noqa: F401 (for --set planner=...)
from compass_manip.motion.timing import densify
from compass_manip.robot.model import RobotConfig
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import oracle
from compass_manip.sim.certify import certified_scene


def main() -> int:
    ap = capture_arguments(argparse.ArgumentParser())
    ap.add_argument("--set", nargs="*", default=[], help="GraspSelectConfig field=value (python literal)")
    ap.add_argument("--via-home", action="store_true", help="q_via = the home posture")
    args = ap.parse_args()
    over = {k: eval(v) for k, v in (s.split("=", 1) for s in args.set)}
    n_ok = 0
    for level, index, box in read_captures(args.dir, args.only):
        if "target" not in box:
            print(json.dumps({"level": level, "index": index, "error": "no selection reached"}))
            continue
        scene = certified_scene(level, index, args.seed).scene
        spheres = panda_sphere_model(RobotConfig(base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw))
        cfg = dataclasses.replace(box["config"], **over)
        t0 = time.perf_counter()
        s = select_grasp(box["target"], box["occ"], box["task"], box["q"], spheres, cfg, box["rng"],
                         proposer=box.get("proposer"), extra_safe=box["extra_safe"], fine_map=box.get("fine_map"),
                         q_via=np.asarray(RobotConfig().q_home) if args.via_home else None)
        wall = time.perf_counter() - t0
        rec = {"level": level, "index": index, "failure": None if s.failure is None else s.failure.name,
               "score": s.score, "time_ms": round(1e3 * wall), "rejections": {k.name: v for k, v in s.rejections.items()}}
        if s.failure is None:
            n_ok += 1
            full = oracle.ground_truth_checker(scene)
            notgt = oracle.ground_truth_checker(scene, exclude_target=True)
            tr = densify(np.asarray(s.path), 0.01)
            app = densify(np.vstack([s.q_pregrasp, s.q_grasp]), 0.01)
            lift = densify(np.vstack([s.q_grasp, s.q_lift]), 0.01)
            rec["gt_transfer_free"] = bool(full.are_valid(tr).all())
            rec["gt_approach_free"] = bool(notgt.are_valid(app).all())
            rec["gt_lift_free"] = bool(notgt.are_valid(lift).all())
            rec["gt_min_clear_mm"] = round(1e3 * min(min(full.clearance(q) for q in tr),
                                                     min(notgt.clearance(q) for q in np.vstack([app, lift]))), 1)
        print(json.dumps(rec), flush=True)
    print(json.dumps({"selected": n_ok, "set": args.set}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
