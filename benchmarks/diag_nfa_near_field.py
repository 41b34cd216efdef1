"""Diagnosis (GROUND TRUTH, read here only): what COMPASS's near-field scan (NFA) sees of the
base obstacles (the scene's static primitives named base*), view by view.

COMPASS's method is built as the trial builds it, the home frame observed, then the method
decides and executes NFA views one by one, each followed by its frame. First, what the NFA
*could* see: of `--samples` wrist samples (body held, as `exploration.nfa.wrist_candidates`
draws them), how many have > 30 sampled points of each base primitive in their camera
frustum, before and after the NFA's pull-back to the reachable part of their motion
(`reachable_candidates` on the method's checker). Then per NFA view: its gain, its wrist
motion from home and, per base primitive, how many of its sampled voxels the method's map
holds as occupied. Options narrow the NFA's gain box (`--gain-x-max`, `--gain-y-max`, metres
from the base; the method's own unsafe box is unchanged) or allow more views (`--views`).
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_nfa_near_field.py --seed 5151 --level 3 --scene 2`.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

import compass_manip.exploration.nfa as nfa_mod  # noqa: E402
from compass_manip.exploration.base import Phase  # noqa: E402
from compass_manip.exploration.nfa import reachable_candidates, wrist_candidates  # noqa: E402
from compass_manip.mapping.occupancy import VoxelState  # noqa: E402
from compass_manip.sim.certify import certified_scene  # noqa: E402
from compass_manip.sim.groundtruth import inside_primitive  # noqa: E402
from compass_manip.sim.world import World  # noqa: E402
from compass_manip.trial.config import TrialConfig  # noqa: E402
from compass_manip.trial.inspect import frustum_mask  # noqa: E402
from compass_manip.trial.runner import make_method  # noqa: E402


def method_at_home(world, scene, cfg: TrialConfig):
    """(COMPASS's method as the trial builds it at home, the scene's base primitives, and per
    primitive every 7th point of a 1 cm grid inside it (GROUND TRUTH))."""
    q0 = np.asarray(world.robot.q_home, float)
    method = make_method("compass", scene.task(cfg.time_limit_s), cfg.method, np.random.default_rng(1), q0,
                         world.camera.K)
    prims = [p for p in scene.static_primitives() if p.name.startswith("base")]
    grid = np.mgrid[-0.5:0.7:0.01, -0.6:0.6:0.01, 0:1.2:0.01].reshape(3, -1).T
    return method, prims, {p.name: grid[inside_primitive(p, grid)][::7] for p in prims}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=5151)
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--scene", type=int, default=2)
    ap.add_argument("--views", type=int, default=None, help="NFA views at most (default NFAConfig's)")
    ap.add_argument("--samples", type=int, default=400)
    ap.add_argument("--gain-x-max", type=float, default=None)
    ap.add_argument("--gain-y-max", type=float, default=None)
    args = ap.parse_args()
    scene = certified_scene(args.level, args.scene, args.seed).scene
    world = World(scene)
    cfg = TrialConfig()
    nfa = cfg.method.nfa if args.views is None else dataclasses.replace(cfg.method.nfa, max_views=args.views)
    cfg = dataclasses.replace(cfg, method=dataclasses.replace(cfg.method, nfa=nfa))
    base = np.asarray(world.robot.base_pos, float)
    orig = nfa_mod.safe_box_map

    def gain_box(occ, lo, hi, out=None, keep_occupied=False):
        hi = np.array(hi, float)
        if args.gain_x_max is not None:
            hi[0] = min(hi[0], base[0] + args.gain_x_max)
        if args.gain_y_max is not None:
            hi[1] = min(hi[1], base[1] + args.gain_y_max)
        return orig(occ, lo, hi, out, keep_occupied)

    nfa_mod.safe_box_map = gain_box
    q0 = np.asarray(world.robot.q_home, float)
    method, prims, points = method_at_home(world, scene, cfg)

    def seen() -> str:
        occ = method.occupancy
        out = []
        for p in prims:
            v = np.unique(occ.world_to_voxel(points[p.name]), axis=0)
            out.append(f"{p.name} {int(np.count_nonzero(occ.state[tuple(v.T)] == VoxelState.OCCUPIED))}/{len(v)}")
        return ", ".join(out)

    method.observe(world.render(q0, rgb=False, seg=False).observation())
    print("home: occupied voxels seen of each base primitive:", seen())
    Q = wrist_candidates(q0, args.samples, np.random.default_rng(3), nfa.wrist_range)
    R = reachable_candidates(method.world.checker, q0, Q, nfa.scan_resolution, nfa.min_motion, nfa.backoff)
    K = world.camera.K
    TQ, TR = method.world.kin.T_world_cam_batch(Q), method.world.kin.T_world_cam_batch(R)
    for p in prims:
        a = int(np.count_nonzero(frustum_mask(TQ, K, points[p.name], 1.0).sum(1) > 30))
        b = int(np.count_nonzero(frustum_mask(TR, K, points[p.name], 1.0).sum(1) > 30))
        print(f"  {p.name}: wrist samples seeing > 30 of its points: {a}/{len(Q)}; reachable ones: {b}/{len(R)}")
    try:
        for k in range(nfa.max_views + 1):
            d = method.decide()
            if d.path is None or d.phase != Phase.NFA:
                print(f"NFA over after {k} views (next decision: {d.phase.name})")
                break
            path = np.asarray(d.path)
            method.executed(path)
            method.observe(world.render(path[-1], rgb=False, seg=False).observation())
            print(f"view {k}: gain {d.stats.get('gain')}, wrist move {np.round(path[-1][4:] - q0[4:], 2)}; {seen()}")
    finally:
        nfa_mod.safe_box_map = orig
    return 0


if __name__ == "__main__":
    sys.exit(main())
