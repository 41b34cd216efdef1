"""`compass demo`: one scene end to end, as far as the system goes today.

It certifies the scene, sweeps the wrist joints (joints 1-4 stay at home, as in the paper's
near-field awareness scan) with the kinematic executor, checking ground-truth contacts
all along, integrates every wrist-camera frame into the occupancy map (the robot's own
body filtered out by its collision spheres), and writes the scene, the frames, the map
(PNG views and an OctoMap `.bt`) and a JSON summary to the output folder.
"""
from __future__ import annotations

import json
import os
import sys

import numpy as np

from ..errors import CompassInputError

HELP = "certify a scene, scan it with the wrist camera, build the map, write the outputs"


def add_arguments(p) -> None:
    p.add_argument("--level", type=int, default=4, help="difficulty level 1..4 (default 4)")
    p.add_argument("--index", type=int, default=0, help="scene index (default 0)")
    p.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    p.add_argument("--out", default="outputs/demo", help="output folder (default outputs/demo)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")


def run(args) -> int:
    from ..sim.levels import check_level

    check_level(args.level)
    if args.index < 0:
        raise CompassInputError(f"--index {args.index} is not allowed; use an integer >= 0")
    if args.seed < 0:
        raise CompassInputError(f"--seed {args.seed} is not allowed; use an integer >= 0")

    from ..mapping.frontiers import find_frontiers
    from ..mapping.occupancy import MapConfig, OccupancyMap
    from ..mapping.octomap_io import write_bt
    from ..mapping.observe import integrate_observation
    from ..exploration.wrist_sweep import wrist_sweep
    from ..robot.model import QD_MAX
    from ..robot.spheres import panda_sphere_model
    from ..sim.certify import certified_scene
    from ..sim.executor import ExecutorConfig, execute
    from ..viz.images import save_frame_png, save_rgb_png
    from ..sim.world import World, render_overview
    from ..types import Trajectory

    os.makedirs(args.out, exist_ok=True)
    print(f"certifying level {args.level} scene {args.index} (seed {args.seed})", file=sys.stderr)
    cs = certified_scene(args.level, args.index, args.seed)
    world = World(cs.scene)
    q_home = np.asarray(world.robot.q_home)
    way = wrist_sweep(q_home)
    seg_t = [np.max(np.abs(b - a) / (0.5 * QD_MAX)) for a, b in zip(way[:-1], way[1:])]  # 50 % of vmax
    traj = Trajectory(np.concatenate([[0.0], np.cumsum(seg_t)]), way)
    print("scanning", file=sys.stderr)
    start = world.render(q_home, seg=True)
    res = execute(world, traj, ExecutorConfig(frame_rate=4.0))
    frames = [start, *res.frames]

    print("mapping", file=sys.stderr)
    spheres = panda_sphere_model(world.robot)
    occ = OccupancyMap(MapConfig())
    for f in frames:
        integrate_observation(occ, f, spheres, world.camera.depth_max)
    t_lo, t_hi = cs.scene.target.aabb()
    counts = occ.counts()
    clusters = find_frontiers(occ)

    frames_dir = os.path.join(args.out, "frames")
    for k, f in enumerate(frames):
        save_frame_png(f, os.path.join(frames_dir, f"frame_{k:03d}.png"), world.target_label, f"t = {f.t:.2f} s")
    world.set_q(q_home)
    save_rgb_png(render_overview(world), os.path.join(args.out, "overview.png"))
    save_map_png(occ, cs.scene, os.path.join(args.out, "map.png"))
    write_bt(occ, os.path.join(args.out, "map.bt"))
    summary = {
        "level": cs.scene.level, "index": cs.scene.index, "sub_seed": list(cs.scene.seed),
        "certified": cs.certificate.certified,
        "view_visibility_fraction": round(cs.certificate.view_visibility_fraction, 4),
        "free_config_fraction": round(cs.certificate.free_config_fraction, 4),
        "scan_duration_s": round(res.t_end, 3), "frames": len(frames),
        "contacts": len(res.contacts), "scan_completed": res.completed,
        "target_pixels_seen": int(max(np.count_nonzero(f.seg == world.target_label) for f in frames)),
        "target_box_known_fraction": round(occ.known_fraction(t_lo, t_hi), 4),
        "voxels_free": counts.free, "voxels_occupied": counts.occupied, "voxels_unknown": counts.unknown,
        "frontier_clusters": len(clusters),
        "out": os.path.abspath(args.out),
    }
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump({"scene": cs.scene.to_dict(), "summary": summary}, f, indent=1)
    world.close()
    if args.json:
        print(json.dumps(summary))
    else:
        for k, v in summary.items():
            print(f"{k:>26}: {v}")
    return 0


def save_map_png(occ, scene, path: str) -> None:
    """Two slices of the map through the target: horizontal (top view) and vertical (side view)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    lo = np.array(scene.cabinet.interior_min) - np.array([0.25, 0.05, 0.05])
    hi = np.array(scene.cabinet.interior_max) + 0.05
    i0 = np.clip(occ.world_to_voxel(lo[None])[0], 0, np.array(occ.shape) - 1)
    i1 = np.clip(occ.world_to_voxel(hi[None])[0], 0, np.array(occ.shape) - 1)
    ic = occ.world_to_voxel(np.array(scene.target.pos)[None])[0]
    cmap = ListedColormap(["#bbbbbb", "#ffffff", "#2b4c7e"])  # unknown, free, occupied
    st = occ.state
    top = st[i0[0]:i1[0] + 1, i0[1]:i1[1] + 1, ic[2]]
    side = st[i0[0]:i1[0] + 1, ic[1], i0[2]:i1[2] + 1]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.4))
    axes[0].imshow(top, origin="lower", cmap=cmap, vmin=0, vmax=2, extent=[lo[1], hi[1], lo[0], hi[0]])
    axes[0].set(xlabel="y [m]", ylabel="x [m]", title=f"horizontal slice at z = {scene.target.pos[2]:.2f} m")
    axes[1].imshow(side.T, origin="lower", cmap=cmap, vmin=0, vmax=2, extent=[lo[0], hi[0], lo[2], hi[2]])
    axes[1].set(xlabel="x [m]", ylabel="z [m]", title=f"vertical slice at y = {scene.target.pos[1]:.2f} m")
    tl, th = scene.target.aabb()
    axes[0].add_patch(plt.Rectangle((tl[1], tl[0]), th[1] - tl[1], th[0] - tl[0], fill=False, ec="red", lw=1.5))
    axes[1].add_patch(plt.Rectangle((tl[0], tl[2]), th[0] - tl[0], th[2] - tl[2], fill=False, ec="red", lw=1.5))
    fig.suptitle("occupancy map through the target: blue occupied, white free, grey unknown; red box: target")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
