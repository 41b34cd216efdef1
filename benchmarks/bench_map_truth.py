"""How trustworthy are the map's free labels? Depth frames of grasp-only trials, integrated
with OctoMap's rule and with the surface guard / sticky hits (`MapConfig`), compared with
the true geometry.

Per certified scene (levels, indices --start.., seed 0) the grasp-only harness builds its
1 cm map as `compass run --grasp-only` does (near-field scan: --scan) and stops at the
selection; its frames are recorded and integrated again into fresh 1 cm maps, one per rule.
With GROUND TRUTH (through `sim.oracle`, here only): a voxel is *false free* when it is
labelled free and the scene's geometry (boards, base obstacles, objects) lies within half a
voxel edge of its centre (it surely fills part of the cube), *maybe* within half a
diagonal. Also the free voxels in all, the occupied ones, and the integration time per
frame (load-affected: the load average is printed).

Run: `.venv/bin/python benchmarks/bench_map_truth.py --levels 1 4 --start 2 --count 1 [--scan wide]`.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from types import SimpleNamespace

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.bench.stats import load_average
from compass_manip.mapping.observe import integrate_observation
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import grasp_only, near_field, oracle
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.grasp_only import GraspOnlyConfig
from compass_manip.sim.near_field import WIDE_SCAN, NearFieldScanConfig
from compass_manip.sim.world import World

sys.path.insert(0, os.path.dirname(__file__))
from diag_grasp_certified import _dists  # noqa: E402

WIDE = WIDE_SCAN
RULES = {"octomap": dict(surface_guard=False, sticky_hits=0), "guard": dict(surface_guard=True, sticky_hits=0),
         "sticky": dict(surface_guard=False, sticky_hits=1), "guard+sticky": dict(surface_guard=True, sticky_hits=1)}


def harness_frames(scene, config, seed, world):
    """The frames the harness integrates into its 1 cm map (in order); the run stops at the selection."""
    frames = []
    orig_int, orig_nf, orig_sel = grasp_only.integrate_observation, near_field.integrate_observation, \
        grasp_only.select_grasp

    def rec(occ, obs, spheres, max_range, *a, **k):
        if abs(occ.resolution - 0.01) < 1e-9:
            frames.append(obs)
        return orig_int(occ, obs, spheres, max_range, *a, **k)

    def stop(*a, **k):
        raise StopIteration

    grasp_only.integrate_observation = near_field.integrate_observation = rec
    grasp_only.select_grasp = stop
    try:
        grasp_only.run_grasp_only(scene, config, seed=seed, world=world)
    except StopIteration:
        pass
    finally:
        grasp_only.integrate_observation, near_field.integrate_observation = orig_int, orig_nf
        grasp_only.select_grasp = orig_sel
    return frames


def cached_frames(folder, key, make):
    """The frames from folder/key.npz if there, else make() (saved there when folder is given):
    the rules are then compared on the very same frames."""
    path = os.path.join(folder, key + ".npz") if folder else None
    if path and os.path.exists(path):
        z = np.load(path)
        return [SimpleNamespace(depth=z["depth"][i], K=z["K"], T_world_cam=z["T"][i], q=z["q"][i])
                for i in range(len(z["q"]))]
    frames = make()
    if path:
        os.makedirs(folder, exist_ok=True)
        np.savez_compressed(path, depth=np.array([f.depth for f in frames]), K=frames[0].K,
                            T=np.array([f.T_world_cam for f in frames]), q=np.array([f.q for f in frames]))
    return frames


def truth_distance(scene, occ: OccupancyMap, candidates: np.ndarray) -> np.ndarray:
    """Distance [m] from the centres of voxels (K, 3) to the scene's true geometry."""
    return _dists(occ.voxel_to_world(candidates), oracle.scene_obstacles(scene).arrays())


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 4])
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--count", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scan", choices=("wide", "default"), default="wide")
    ap.add_argument("--cache", default=None, help="folder for the recorded frames (reused when there)")
    args = ap.parse_args()
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            scene = certified_scene(level, index, args.seed).scene
            world = World(scene)
            try:
                config = GraspOnlyConfig(near_field_scan=WIDE if args.scan == "wide" else NearFieldScanConfig())
                frames = cached_frames(args.cache, f"{level}_{index}_{args.scan}",
                                       lambda: harness_frames(scene, config, args.seed, world))
                spheres = panda_sphere_model(world.robot)
                maps, times = {}, {}
                for name, kw in RULES.items():
                    occ = OccupancyMap(MapConfig(**kw))
                    integrate_observation(occ, frames[0], spheres, world.camera.depth_max)  # compile outside timing
                    occ.reset()
                    t0 = time.perf_counter()
                    for f in frames:
                        integrate_observation(occ, f, spheres, world.camera.depth_max)
                    times[name] = (time.perf_counter() - t0) / len(frames)
                    maps[name] = occ
                # the true distance only of voxels some rule labels free (the rest cannot be false free)
                any_free = np.argwhere(np.any([m.state == VoxelState.FREE for m in maps.values()], axis=0))
                d = truth_distance(scene, maps["octomap"], any_free)
                res = maps["octomap"].resolution
                sure, maybe = d <= 0.5 * res, d <= 0.5 * math.sqrt(3.0) * res
                rec = {"level": level, "index": index, "scan": args.scan, "n_frames": len(frames),
                       "load": load_average()}
                for name, occ in maps.items():
                    free = occ.state[any_free[:, 0], any_free[:, 1], any_free[:, 2]] == VoxelState.FREE
                    rec[name] = {"false_free": int(np.sum(free & sure)), "maybe_false_free": int(np.sum(free & maybe)),
                                 "free": int(np.sum(occ.state == VoxelState.FREE)),
                                 "occupied": int(np.sum(occ.state == VoxelState.OCCUPIED)),
                                 "ms_per_frame": round(1e3 * times[name], 1)}
                print(json.dumps(rec), flush=True)
            finally:
                world.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
