"""`compass demo`: one Level-4 scene, end to end as far as the system goes today.

It certifies the scene, moves the wrist through a short scan with the kinematic executor
(ground-truth contacts checked all along), and writes the scene, its certificate, an
overview and the wrist-camera frames to the output folder.
"""
from __future__ import annotations

import json
import os
import sys

import numpy as np

from ..errors import CompassInputError

HELP = "certify a scene, scan it with the wrist camera and write the outputs"


def add_arguments(p) -> None:
    p.add_argument("--level", type=int, default=4, help="difficulty level 1..4 (default 4)")
    p.add_argument("--index", type=int, default=0, help="scene index (default 0)")
    p.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    p.add_argument("--out", default="outputs/demo", help="output folder (default outputs/demo)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")


def wrist_scan(q_home: np.ndarray, n: int = 4, amplitude: float = 0.35) -> np.ndarray:
    """Waypoints [rad] that keep joints 1-4 at home and sweep the wrist joints 5-7."""
    from ..robot.model import Q_MAX, Q_MIN

    angles = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    way = [q_home]
    for a in angles:
        q = q_home.copy()
        q[4] += amplitude * np.cos(a)
        q[5] += amplitude * np.sin(a)
        way.append(np.clip(q, Q_MIN, Q_MAX))
    way.append(q_home)
    return np.array(way)


def run(args) -> int:
    from ..sim.levels import check_level

    check_level(args.level)
    if args.index < 0:
        raise CompassInputError(f"--index {args.index} is not allowed; use an integer >= 0")
    if args.seed < 0:
        raise CompassInputError(f"--seed {args.seed} is not allowed; use an integer >= 0")

    from ..robot.model import QD_MAX
    from ..sim.certify import certified_scene
    from ..sim.executor import ExecutorConfig, execute
    from ..sim.images import save_frame_png, save_rgb_png
    from ..sim.world import World, render_overview
    from ..types import Trajectory

    os.makedirs(args.out, exist_ok=True)
    print(f"certifying level {args.level} scene {args.index} (seed {args.seed})", file=sys.stderr)
    cs = certified_scene(args.level, args.index, args.seed)
    world = World(cs.scene)
    q_home = np.asarray(world.robot.q_home)
    way = wrist_scan(q_home)
    # each segment at 50 % of the joint velocity limits
    seg_t = [np.max(np.abs(b - a) / (0.5 * QD_MAX)) for a, b in zip(way[:-1], way[1:])]
    traj = Trajectory(np.concatenate([[0.0], np.cumsum(seg_t)]), way)
    res = execute(world, traj, ExecutorConfig(frame_rate=2.0))
    frames_dir = os.path.join(args.out, "frames")
    for k, f in enumerate(res.frames):
        save_frame_png(f, os.path.join(frames_dir, f"frame_{k:03d}.png"), world.target_label, f"t = {f.t:.2f} s")
    world.set_q(q_home)
    save_rgb_png(render_overview(world), os.path.join(args.out, "overview.png"))
    start = world.render(q_home)
    save_frame_png(start, os.path.join(args.out, "start_camera.png"), world.target_label, "start wrist camera")
    seen = [float(np.mean(f.seg == world.target_label)) for f in res.frames]
    summary = {
        "level": cs.scene.level, "index": cs.scene.index, "sub_seed": list(cs.scene.seed),
        "certified": cs.certificate.certified,
        "view_visibility_fraction": cs.certificate.view_visibility_fraction,
        "free_config_fraction": cs.certificate.free_config_fraction,
        "scan_duration_s": round(res.t_end, 3), "frames": len(res.frames),
        "contacts": len(res.contacts), "completed": res.completed,
        "max_target_pixel_fraction": max(seen, default=0.0),
        "out": os.path.abspath(args.out),
    }
    with open(os.path.join(args.out, "scene.json"), "w") as f:
        json.dump({"scene": cs.scene.to_dict(), "summary": summary}, f, indent=1)
    world.close()
    if args.json:
        print(json.dumps(summary))
    else:
        for k, v in summary.items():
            print(f"{k:>26}: {v}")
    return 0
