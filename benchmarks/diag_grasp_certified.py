"""Diagnosis: why grasp-only misses the certified grasp of a scene.

Per certified scene (levels, indices --start..; seed 0) the grasp-only harness builds its
map exactly as `compass run --grasp-only` does and stops at the selection (its inputs are
captured). With GROUND TRUTH (read here only, through `sim.oracle` and the certificate):

* the certified grasp's TCP pose (FK of the certificate path's grasp configuration);
* generated? the number of the selection's candidates within 2 cm and 15 deg of it;
* the verdict of the selection's hand checks on that pose (grasp, approach, lift);
* the unsafe 5 mm cells that block its rigid hand at the grasp: their map state (unknown /
  occupied on the 1 cm map and on the fine local map), whether the true geometry (less the
  target) reaches them (within a 1 cm voxel's half diagonal), whether the target does, and
  where they lie (TCP frame, and height above the target's lowest point).

Prints one JSON line per scene. Run:
`.venv/bin/python benchmarks/diag_grasp_certified.py [--start 5 --count 2] [--levels 1 2 3 4]`.
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import os
import sys
from collections import Counter

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
from numba import njit

from compass_manip.grasp.candidates import AntipodalProposer
from compass_manip.grasp.checks import GraspChecks, hand_clear, rigid_hand_spheres
from compass_manip.grasp.select import GraspSelectConfig, base_volume_mask, desired_approach
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.motion.primitives import primitives_distance
from compass_manip.robot.ik import PandaIK
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import grasp_only, oracle
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World

STATE = {int(VoxelState.UNKNOWN): "unknown", int(VoxelState.OCCUPIED): "occupied", int(VoxelState.FREE): "free"}


@njit(cache=True)
def _dists(P, prims):
    out = np.empty(P.shape[0])
    for i in range(P.shape[0]):
        out[i] = primitives_distance(P[i], prims, -np.inf)
    return out


def capture_inputs(scene, seed: int) -> dict:
    """The inputs the harness passes to select_grasp (the run stops there)."""
    box = {}

    def capture(target, occ, task, q, sph, config, rng, safe_spheres=None, extra_safe=None, fine_map=None):
        box.update(target=target, occ=occ, task=task, q=q, extra=extra_safe, fine=fine_map, rng=copy.deepcopy(rng))
        raise StopIteration

    orig = grasp_only.select_grasp
    grasp_only.select_grasp = capture
    try:
        grasp_only.run_grasp_only(scene, seed=seed)
    except StopIteration:
        pass
    finally:
        grasp_only.select_grasp = orig
    return box


def rot_angle(Ra: np.ndarray, Rb: np.ndarray) -> np.ndarray:
    """Angles [rad] between rotations Ra (M,3,3) and Rb (3,3)."""
    tr = np.einsum("mij,ij->m", Ra, Rb)
    return np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0))


def sphere_bound_fails(field, W: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(K,) True where a sphere (centres W (K,3), radii r [m]) fails the checkers' bound."""
    res = field.resolution
    f = (W - field.grid_min) / res - 0.5
    i = np.floor(f + 0.5).astype(int)
    inside = np.all((i >= 0) & (i < np.asarray(field.distances.shape)), axis=1)
    out = np.ones(len(W), bool)
    ii = i[inside]
    d = field.distances[ii[:, 0], ii[:, 1], ii[:, 2]]
    off = np.linalg.norm(f[inside] - ii, axis=1) * res
    out[inside] = d - off - 0.5 * math.sqrt(3.0) * res - r[inside] < 0.0
    return out


def blocking_cells(field, W: np.ndarray, r: np.ndarray):
    """World centres (K,3) of the unsafe fine cells the spheres (W (S,3), r (S,)) that fail
    the checkers' bound reach (within r + a cell diagonal), and the failing sphere indices."""
    res = field.resolution
    reach_pad = math.sqrt(3.0) * res
    unsafe = field.distances <= 1e-6
    cells, failing = [], []
    for k in np.nonzero(sphere_bound_fails(field, W, r))[0]:
        failing.append(int(k))
        reach = r[k] + reach_pad
        lo = np.clip(np.floor((W[k] - reach - field.grid_min) / res).astype(int), 0, unsafe.shape)
        hi = np.clip(np.floor((W[k] + reach - field.grid_min) / res).astype(int) + 1, 0, unsafe.shape)
        ijk = np.argwhere(unsafe[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]) + lo
        c = field.grid_min + (ijk + 0.5) * res
        c = c[np.linalg.norm(c - W[k], axis=1) <= reach]
        if len(c):
            cells.append(c)
    cells = np.unique(np.round(np.vstack(cells), 5), axis=0) if cells else np.zeros((0, 3))
    return cells, failing


def classify(cells, scene, occ, fine, T_ref, bottom_z) -> dict:
    """Map state (1 cm / 5 mm) / truth / height class counts of blocking cells, and where they lie."""
    rec = {"n_cells": len(cells)}
    if not len(cells):
        return rec
    tall = oracle.scene_obstacles(scene).arrays()
    rest = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    d_rest, d_all = _dists(cells, rest), _dists(cells, tall)
    h = 0.5 * math.sqrt(3.0) * occ.resolution
    truth = np.where(d_rest <= h, "obstacle", np.where(d_all <= h, "target", "free_in_truth"))
    vox = occ.world_to_voxel(cells)
    st = occ.state[vox[:, 0], vox[:, 1], vox[:, 2]]
    fst = np.full(len(cells), -1)
    if fine is not None:
        fv = fine.world_to_voxel(cells)
        inb = fine.in_grid(fv)
        fst[inb] = fine.state[fv[inb, 0], fv[inb, 1], fv[inb, 2]]
    above = cells[:, 2] - bottom_z
    keys = [f"{STATE[int(a)]}/{STATE.get(int(b), 'none')}/{t}/{'below_bottom' if z < 0 else 'above_bottom'}"
            for a, b, t, z in zip(st, fst, truth, above)]
    rec["by_map_fine_truth_height"] = dict(Counter(keys).most_common())
    loc = (cells - T_ref[:3, 3]) @ T_ref[:3, :3]
    rec["tcp_frame_median_cm"] = [round(100 * float(v), 1) for v in np.median(loc, axis=0)]
    rec["height_above_bottom_cm_min_median"] = [round(100 * float(np.min(above)), 1),
                                                round(100 * float(np.median(above)), 1)]
    rec["truth_dist_median_cm"] = round(100 * float(np.median(d_rest)), 1)
    rec["base_frame_median_m"] = [round(float(v), 2) for v in np.median(cells - np.asarray(scene.robot_base_pos), axis=0)]
    rec["base_dist_median_m"] = round(float(np.median(np.linalg.norm(cells[:, :2] - scene.robot_base_pos[:2], axis=1))), 2)
    return rec


def scene_spheres(level: int, index: int, seed: int):
    """(the certified scene, the planner's sphere model of its robot)."""
    cs = certified_scene(level, index, seed)
    world = World(cs.scene)
    try:
        return cs, panda_sphere_model(world.robot)
    finally:
        world.close()


def diagnose(level: int, index: int, seed: int) -> dict:
    cs, spheres = scene_spheres(level, index, seed)
    scene, cert = cs.scene, cs.certificate
    q_g = np.array(cert.path[cert.path_marks[2]])
    T_c = spheres.kinematics.T_world_tcp(q_g)
    box = capture_inputs(scene, seed)
    rec = {"level": level, "index": index, "cert_pitch_deg": cert.grasp_approach_deg, "cert_yaw_deg": cert.grasp_yaw_deg}
    if not box:
        rec["error"] = "no selection reached"
        return rec
    cfg = GraspSelectConfig()
    target, occ, q = box["target"], box["occ"], box["q"]
    n = desired_approach(target, box["task"])
    rec["cert_angle_to_n_deg"] = round(math.degrees(math.acos(np.clip(T_c[:3, 2] @ n, -1, 1))), 1)
    rec["cert_tcp_below_model_top_cm"] = round(100 * (target.points[:, 2].max() - T_c[2, 3]), 1)
    cands = AntipodalProposer(cfg.candidates).propose(target, box["rng"], toward=n, max_angle=cfg.max_approach_angle)
    dpos = np.linalg.norm(cands.T_world_tcp[:, :3, 3] - T_c[:3, 3], axis=1)
    # the fingers are symmetric: the hand turned 180 deg about its z is the same grasp but for the camera
    flip = T_c[:3, :3] @ np.diag([-1.0, -1.0, 1.0])
    dang = np.minimum(rot_angle(cands.T_world_tcp[:, :3, :3], T_c[:3, :3]),
                      rot_angle(cands.T_world_tcp[:, :3, :3], flip))
    near = (dpos <= 0.02) & (dang <= math.radians(15.0))
    rec.update(n_candidates=len(cands), n_near_cert=int(near.sum()),
               nearest_pos_cm=round(100 * float(dpos.min()), 1) if len(cands) else None,
               nearest_ang_deg=round(math.degrees(float(dang[np.argmin(dpos + 0.1 * dang)])), 1) if len(cands) else None)
    cur = spheres.sphere_centers(q[None])[0]
    extra = box["extra"] | base_volume_mask(spheres, occ)
    ch = GraspChecks(occ, target, spheres, PandaIK(spheres.kinematics), cfg, (cur, spheres.radii + cfg.robot_clearance),
                     extra, q, fine_map=box["fine"])
    local = rigid_hand_spheres(spheres)
    f = ch.fine
    at = bool(hand_clear(f, T_c[None], local)[0])
    appr = {d: bool(all(hand_clear(f, (T_c @ _tz(-k * d))[None], local)[0] for k in (1.0, 0.75, 0.5, 0.25)))
            for d in cfg.pregrasp_distances}
    rec.update(cert_hand_at_grasp=at, cert_approach_free={str(k): v for k, v in appr.items()})
    if len(cands):
        ok = hand_clear(f, cands.T_world_tcp, local)
        rec["cands_hand_free"] = int(ok.sum())
        rec["near_cert_hand_free"] = int((ok & near).sum())
    if len(cands):
        pre_ok = np.zeros(len(cands), bool)
        for d in cfg.pregrasp_distances:
            m = np.ones(len(cands), bool)
            for k in (1.0, 0.75, 0.5, 0.25):
                T = cands.T_world_tcp.copy()
                T[:, :3, 3] -= k * d * T[:, :3, 2]
                m &= hand_clear(f, T, local)
            pre_ok |= m
        rec["near_cert_hand_and_approach_free"] = int((ok & near & pre_ok).sum())
    # the first blocked pose of the certified hand: at the grasp, else along the approach
    T_b, where = T_c, "grasp"
    if at:
        for k in (0.25, 0.5, 0.75, 1.0):
            T = T_c @ _tz(-k * cfg.pregrasp_distances[-1])
            if not hand_clear(f, T[None], local)[0]:
                T_b, where = T, f"approach_{round(100 * k * cfg.pregrasp_distances[-1], 1)}cm"
                break
    rec["cert_blocked_at"] = where if (not at or where != "grasp") else None
    C, r = local
    cells, failing = blocking_cells(f, C @ T_b[:3, :3].T + T_b[:3, 3], r)
    body = rigid_body_names(spheres)
    rec["hand_blocking_links"] = dict(Counter(body[k] for k in failing))
    rec["hand_cells"] = classify(cells, scene, occ, box["fine"], T_b, target.bottom_z)
    # the certified arm configurations (grasp, pre-grasp, lift) on the same field, whole robot
    marks = dict(zip(("view", "pregrasp", "grasp", "lift"), cert.path_marks))
    for name in ("pregrasp", "grasp", "lift"):
        qc = np.array(cert.path[marks[name]])
        rec[f"cert_q_{name}_valid"] = bool(ch.valid(qc[None])[0])
    qg = np.array(cert.path[marks["grasp"]])
    W = spheres.sphere_centers(qg[None])[0]
    cells, failing = blocking_cells(f, W, spheres.radii)
    rec["arm_blocking_links"] = dict(Counter(spheres.link_names[spheres.body_index[k]] for k in failing))
    rec["arm_cells"] = classify(cells, scene, occ, box["fine"], T_c, target.bottom_z)
    # the straight certified path from the view to the pre-grasp: the first configuration it fails at
    path = np.array(cert.path)
    seg = path[marks["view"]:marks["pregrasp"] + 1]
    dense = np.concatenate([np.linspace(seg[i], seg[i + 1], 10, endpoint=False) for i in range(len(seg) - 1)]
                           + [seg[-1:]])
    bad = ~ch.valid(dense)
    rec["cert_transfer_valid_fraction"] = round(float(1.0 - bad.mean()), 2)
    if bad.any():  # what blocks the certified transfer: links and cells over its invalid configurations
        Ws = spheres.sphere_centers(dense[bad])
        links, cells = Counter(), []
        for W in Ws:
            c, failing = blocking_cells(f, W, spheres.radii)
            links.update({spheres.link_names[spheres.body_index[k]] for k in failing})
            cells.append(c)
        cells = np.unique(np.round(np.vstack(cells), 5), axis=0)
        rec["transfer_blocking_links"] = dict(links)
        rec["transfer_cells"] = classify(cells, scene, occ, box["fine"], T_c, target.bottom_z)
        near = grasp_only.near_body_unknown(occ, spheres, np.asarray(world_q_home(scene)))
        v = occ.world_to_voxel(cells)
        rec["transfer_cells_in_near_body_mask"] = int(near[v[:, 0], v[:, 1], v[:, 2]].sum())
    return rec


def world_q_home(scene):
    world = World(scene)
    try:
        return np.asarray(world.robot.q_home)
    finally:
        world.close()


def rigid_body_names(spheres) -> list[str]:
    from compass_manip.grasp.checks import _hand_mask
    keep = _hand_mask(spheres)
    return [spheres.link_names[b] for b in spheres.body_index[keep]]


def _tz(d: float) -> np.ndarray:
    T = np.eye(4)
    T[2, 3] = d
    return T


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--count", type=int, default=2)
    ap.add_argument("--start", type=int, default=5)
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            print(json.dumps(diagnose(level, index, args.seed)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
