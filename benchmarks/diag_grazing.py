"""Diagnosis: why a grasp-only transfer touched an obstacle the map called safe.

Runs the grasp-only harness on one certified scene (seed 0) with the near-field scan of
--scan (default: the wider scan of docs/grasping_log.md), recording every depth frame it
integrates into its 1 cm map and the inputs and output of the selection. With GROUND TRUTH
(read here only, through `sim.oracle` and the simulator's contacts):

* the configurations of the executed transfer/approach at which the robot penetrates the
  obstacle of the recorded collision, and the robot's spheres that reach into it;
* the 1 cm map voxels those spheres overlap that hold true geometry (the obstacle within
  half a voxel diagonal of the centre): their label, log-odds, whether the robot's-way
  mask (`extra_safe`) or the base volume marks them safe, and the fine map's label;
* replaying the recorded frames into a fresh map: per such voxel, how many scans hit it and
  missed it, and the angle between each freeing ray and the obstacle's surface (the
  surface normal is the gradient of the true distance), with the ray's chord in the voxel.

Prints one JSON record. Run:
`.venv/bin/python benchmarks/diag_grazing.py --level 1 --index 2 [--scan wide|default]`.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections import Counter

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.mapping import raycast
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.mapping.selffilter import SphereBodyFilter
from compass_manip.mapping.observe import SELF_FILTER_MARGIN, integrate_observation
from compass_manip.grasp.robot_space import base_volume_mask
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.motion.timing import densify
from compass_manip.robot.model import GRIPPER_MAX_WIDTH
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import grasp_only, near_field, oracle
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.grasp_only import GraspOnlyConfig
from compass_manip.sim.near_field import WIDE_SCAN, NearFieldScanConfig
from compass_manip.sim.world import World

sys.path.insert(0, os.path.dirname(__file__))
from diag_grasp_certified import _dists  # noqa: E402

STATE = {0: "unknown", 1: "free", 2: "occupied"}
WIDE = WIDE_SCAN


def record_run(scene, config, seed, world, way_overrides_occupied=False):
    """Run the harness; returns (result, [frames integrated into the 1 cm map, in order], selection inputs).
    way_overrides_occupied: pass the robot's whole way as safe, voxels seen occupied included
    (the harness before this branch)."""
    frames, inputs, ways = [], {}, []

    class Way(grasp_only.RobotSpaceMask):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            ways.append(self)
    orig_int, orig_nf, orig_sel = grasp_only.integrate_observation, near_field.integrate_observation, \
        grasp_only.select_grasp

    def rec(occ, obs, spheres, max_range, *a, **k):
        if abs(occ.resolution - 0.01) < 1e-9:
            frames.append(obs)
        return orig_int(occ, obs, spheres, max_range, *a, **k)

    def sel(target, occ, task, q, sph, cfg, rng, **kw):
        if way_overrides_occupied:
            kw["extra_safe"] = ways[-1].mask
        inputs.update(target=target, occ=occ.copy(), extra=kw.get("extra_safe"), fine=kw.get("fine_map"), q=q)
        return orig_sel(target, occ, task, q, sph, cfg, rng, **kw)

    grasp_only.integrate_observation = near_field.integrate_observation = rec
    grasp_only.select_grasp = sel
    orig_way, grasp_only.RobotSpaceMask = grasp_only.RobotSpaceMask, Way
    try:
        r = grasp_only.run_grasp_only(scene, config, seed=seed, world=world)
    finally:
        grasp_only.integrate_observation, near_field.integrate_observation = orig_int, orig_nf
        grasp_only.select_grasp = orig_sel
        grasp_only.RobotSpaceMask = orig_way
    return r, frames, inputs


def obstacle_prims(scene, name):
    """The one true primitive (board, base obstacle or object part) whose MuJoCo name matches."""
    items = scene.cabinet.boards() + list(scene.base_obstacles) + [p for o in scene.clutter for p in o.parts]
    for p in items:
        if p.name == name:
            return PrimitiveSet.from_shapes([p]).arrays()
    return None


def surface_normal(prims, c, h=1e-4):
    g = np.array([(_dists((c + h * e)[None], prims)[0] - _dists((c - h * e)[None], prims)[0]) / (2 * h)
                  for e in np.eye(3)])
    return g / max(np.linalg.norm(g), 1e-12)


def ray_box(o, e, lo, hi):
    """(t_in, t_out) of segments o -> e (N,3) in box [lo, hi] (parameters in [0, 1]); t_in > t_out: miss."""
    d = e - o
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (lo - o) / d
        b = (hi - o) / d
    a = np.where(d == 0, np.where((o >= lo) & (o < hi), -np.inf, np.inf), a)
    b = np.where(d == 0, np.where((o >= lo) & (o < hi), np.inf, -np.inf), b)
    t_in = np.max(np.minimum(a, b), axis=1)
    t_out = np.min(np.maximum(a, b), axis=1)
    return np.maximum(t_in, 0.0), np.minimum(t_out, 1.0)


def replay(frames, spheres, voxels, occ_cfg, max_range, prims):
    """Per voxel: scans that hit / missed it, and the freeing rays' angles to the surface."""
    occ = OccupancyMap(occ_cfg)
    res = occ.resolution
    out = []
    lo_all = (voxels + occ.grid_key_min) * res
    hist = {i: {"hits": 0, "misses": 0, "angles": [], "chords_mm": []} for i in range(len(voxels))}
    for f in frames:
        before = occ.logodds[voxels[:, 0], voxels[:, 1], voxels[:, 2]].copy()
        T = f.T_world_cam
        centers = spheres.sphere_centers(np.asarray(f.q, dtype=np.float64)[None])[0]
        occ.integrate(f.depth, f.K, T, max_range,
                      point_filter=SphereBodyFilter(centers, spheres.radii, margin=SELF_FILTER_MARGIN))
        after = occ.logodds[voxels[:, 0], voxels[:, 1], voxels[:, 2]]
        changed = np.nonzero(after != before)[0]
        if not len(changed):
            continue
        pts, kind = raycast.backproject(np.ascontiguousarray(f.depth, dtype=np.float32), f.K[0, 0], f.K[1, 1],
                                        f.K[0, 2], f.K[1, 2], np.ascontiguousarray(T[:3, :3]),
                                        np.ascontiguousarray(T[:3, 3]), 1)
        o = T[:3, 3]
        ok = kind == raycast.KIND_POINT
        P = pts[ok]
        L = np.linalg.norm(P - o, axis=1)
        far = L > max_range
        P[far] = o + (P[far] - o) * (max_range / L[far])[:, None]
        for i in changed:
            if after[i] > before[i]:
                hist[i]["hits"] += 1
                continue
            hist[i]["misses"] += 1
            lo, hi = lo_all[i], lo_all[i] + res
            t_in, t_out = ray_box(np.broadcast_to(o, P.shape), P, lo, hi)
            cross = (t_in < t_out) & ~np.all(np.floor(P / res) == np.floor(lo / res + 0.5), axis=1)
            if not np.any(cross):
                continue
            d = (P[cross] - o)
            n = surface_normal(prims, lo + 0.5 * res)
            u = d / np.linalg.norm(d, axis=1)[:, None]
            ang = np.degrees(np.arcsin(np.clip(np.abs(u @ n), 0, 1)))
            chord = (t_out[cross] - t_in[cross]) * np.linalg.norm(d, axis=1)
            hist[i]["angles"].append(float(np.median(ang)))
            hist[i]["chords_mm"].append(round(1e3 * float(np.median(chord)), 1))
            hist[i]["min_angle"] = min(hist[i].get("min_angle", 90.0), float(np.min(ang)))
            hist[i]["n_rays"] = hist[i].get("n_rays", 0) + int(np.count_nonzero(cross))
    for i in range(len(voxels)):
        h = hist[i]
        out.append({"hits": h["hits"], "misses": h["misses"],
                    "median_angle_deg_per_miss": [round(a, 1) for a in h["angles"]],
                    "min_angle_deg": round(h.get("min_angle", float("nan")), 1), "n_freeing_rays": h.get("n_rays", 0),
                    "median_chord_mm_per_miss": h["chords_mm"],
                    "final": STATE[int(occ.state[tuple(voxels[i])])]})
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--level", type=int, required=True)
    ap.add_argument("--index", type=int, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scan", choices=("wide", "default"), default="wide")
    ap.add_argument("--max-voxels", type=int, default=12)
    ap.add_argument("--octomap-rule", action="store_true", help="the map with OctoMap's rule (as before this branch)")
    ap.add_argument("--way-overrides-occupied", action="store_true",
                    help="the robot's way safe even where seen occupied (the harness before this branch)")
    args = ap.parse_args()
    scene = certified_scene(args.level, args.index, args.seed).scene
    config = GraspOnlyConfig(near_field_scan=WIDE if args.scan == "wide" else NearFieldScanConfig(),
                             map=MapConfig(surface_guard=False, sticky_hits=0) if args.octomap_rule else MapConfig())
    world = World(scene)
    try:
        r, frames, inp = record_run(scene, config, args.seed, world, args.way_overrides_occupied)
        rec = {"level": args.level, "index": args.index, "scan": args.scan, "octomap_rule": args.octomap_rule,
               "way_overrides_occupied": args.way_overrides_occupied, **{k: r.to_dict()[k] for k in (
            "success", "selection_failure", "exec_failure", "collisions")}, "n_frames": len(frames)}
        o, s = r.outcome, r.selection
        if o is None or not o.collisions or s is None or s.path is None:
            print(json.dumps(rec))
            return 0
        spheres = panda_sphere_model(world.robot)
        occ, extra = inp["occ"], inp["extra"]
        res = occ.resolution
        path = densify(np.vstack([s.path, s.q_grasp[None]]), 0.005)
        new_map = None
        for c in o.collisions:
            prims = obstacle_prims(scene, c.other_geom)
            crec = {"collision": f"{c.phase}:{c.robot_geom}->{c.other_geom}", "depth_mm": round(1e3 * c.depth, 1)}
            if prims is None:
                crec["note"] = "obstacle not among boards/base obstacles/clutter parts"
                rec.setdefault("contacts", []).append(crec)
                continue
            hits = [k for k, q in enumerate(path) if any(ct.other_geom == c.other_geom and ct.robot_geom == c.robot_geom
                                                         for ct in world.contacts(q, GRIPPER_MAX_WIDTH))]
            crec["path_steps_in_contact"] = [hits[0], hits[-1], len(path)] if hits else None
            if not hits:
                rec.setdefault("contacts", []).append(crec)
                continue
            W = spheres.sphere_centers(path[hits])  # (K, S, 3)
            d = _dists(W.reshape(-1, 3), prims).reshape(W.shape[:2]) - spheres.radii[None]
            pen = np.nonzero(np.any(d < 0.0, axis=0))[0]
            crec["spheres_in_obstacle"] = {spheres.link_names[b]: int(n) for b, n in
                                           Counter(spheres.body_index[pen].tolist()).items()}
            crec["min_sphere_clearance_mm"] = round(1e3 * float(d.min()), 1)
            # voxels overlapped by those spheres that hold true obstacle geometry
            vox = set()
            for k in range(len(hits)):
                for sidx in pen:
                    cc, rr = W[k, sidx], spheres.radii[sidx]
                    a = occ.world_to_voxel((cc - rr)[None])[0]
                    b = occ.world_to_voxel((cc + rr)[None])[0]
                    g = np.stack(np.meshgrid(*[np.arange(a[j], b[j] + 1) for j in range(3)], indexing="ij"), -1)
                    g = g.reshape(-1, 3)
                    ctr = occ.voxel_to_world(g)
                    near = np.linalg.norm(np.clip(cc, ctr - 0.5 * res, ctr + 0.5 * res) - cc, axis=1) < rr  # cube meets sphere
                    for v in g[near]:
                        vox.add(tuple(int(x) for x in v))
            V = np.array(sorted(vox)).reshape(-1, 3)
            ctr = occ.voxel_to_world(V)
            dist = _dists(ctr, prims)
            solid = dist <= 0.5 * math.sqrt(3.0) * res
            V, dist = V[solid], dist[solid]
            st = occ.state[V[:, 0], V[:, 1], V[:, 2]]
            ex = extra[V[:, 0], V[:, 1], V[:, 2]] if extra is not None else np.zeros(len(V), bool)
            bv = base_volume_mask(spheres, occ)[V[:, 0], V[:, 1], V[:, 2]]
            crec["overlapped_voxels_with_truth"] = len(V)
            crec["by_label_way_base"] = dict(Counter(
                f"{STATE[int(a)]}/{'way' if b else 'no_way'}/{'base_volume' if c else 'no_base'}" for a, b, c in zip(st, ex, bv)))
            if new_map is None:  # the same frames with this branch's rule (surface guard, sticky hits)
                new_map = OccupancyMap(MapConfig())
                for f in frames:
                    integrate_observation(new_map, f, spheres, world.camera.depth_max)
            st_new = new_map.state[V[:, 0], V[:, 1], V[:, 2]]
            crec["by_label_new_rule"] = dict(Counter(STATE[int(a)] for a in st_new))
            free = np.nonzero(st == VoxelState.FREE)[0]
            # the freed voxels, deepest in the obstacle first
            pick = free[np.argsort(dist[free])][: args.max_voxels]
            rp = replay(frames, spheres, V[pick], occ.config, world.camera.depth_max, prims)
            crec["freed_voxels"] = [{"centre_m": [round(float(x), 3) for x in occ.voxel_to_world(V[i][None])[0]],
                                     "true_dist_from_centre_mm": round(1e3 * float(dist[i]), 1),
                                     "logodds": round(float(occ.logodds[tuple(V[i])]), 2), **r_}
                                    for i, r_ in zip(pick, rp)]
            rec.setdefault("contacts", []).append(crec)
        print(json.dumps(rec))
    finally:
        world.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
