"""Diagnosis (GROUND TRUTH, read here only): why the selection's hand stage rejects hands that
are free in truth.

Per scene (levels, indices --start..; seed) the grasp-only harness runs up to its selection
(inputs captured, the selection not run). The selection's hand stage is replayed on the same
checked field: in-cone candidates, the rigid hand at the grasp (`HAND_IN_COLLISION`), along
the approach (`HAND_APPROACH_BLOCKED`) and the lift. Each hand rejected at the grasp or on
the approach is checked against the scene's true geometry (less the target: the open
fingers straddle it) with the planner's rigid-hand sphere model (margin 0, as certification
checks a hand): at the grasp pose, and at the approach's 1/4..1 fractions of the shortest
pre-grasp distance. For every GT-free hand the unsafe 5 mm cells of the checked field that
block it (within a sphere's radius + a cell diagonal of a sphere failing the checkers'
bound) are classified:

* unknown: the cell's label (fine map where it reaches, else the 1 cm map) is unknown;
  split by truth (free / obstacle within a map voxel) and by "shadow" (the segment from
  the detection camera to the cell passes through the target: the target hides it);
* occupied_target: occupied, within one voxel (of the labelling map) of the target's true
  surface and not of anything else (the carve missed it);
* occupied_resolution: occupied within one voxel of another object's true surface;
* occupied_map_error: occupied where truth is free (farther than a voxel from everything);
* outside: outside the checked box / no label (`free` cells never block).

A hand is counted under every kind that blocks it and under `only_<kind>` when one kind
alone blocks it. Prints one JSON line per scene and a total.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_hand_rejections.py --levels 1 3 --count 10`.
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

from compass_manip.grasp.candidates import AntipodalProposer, propose_in_cone
from compass_manip.grasp.checks import (GraspChecks, first_clear, hand_clear, lift_steps, pregrasp_steps,
                                        rigid_hand_spheres)
from compass_manip.grasp.select import GraspSelectConfig, approach_angles, base_volume_mask, desired_approach
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.robot.ik import PandaIK
from compass_manip.sim import grasp_only, oracle
from diag_grasp_certified import _dists, blocking_cells, scene_spheres

KINDS = ("unknown_free", "unknown_obstacle", "occupied_target", "occupied_resolution", "occupied_map_error",
         "outside")


def capture(scene, seed: int) -> dict:
    """The harness's inputs to select_grasp and the detection view's camera pose."""
    box: dict = {}
    orig_sel, orig_det = grasp_only.select_grasp, grasp_only.oracle_detection

    def sel(target, occ, task, q, sph, config, rng, **kw):
        box.update(target=target, occ=occ, task=task, q=q, config=config, rng=copy.deepcopy(rng), **kw)
        raise StopIteration

    def det(world, frame):
        box["T_world_cam"] = np.array(frame.T_world_cam)
        return orig_det(world, frame)

    grasp_only.select_grasp, grasp_only.oracle_detection = sel, det
    try:
        grasp_only.run_grasp_only(scene, seed=seed)
    except StopIteration:
        pass
    finally:
        grasp_only.select_grasp, grasp_only.oracle_detection = orig_sel, orig_det
    return box


def gt_free(prims, T: np.ndarray, local) -> np.ndarray:
    """(M,) the rigid hand at each TCP pose (M,4,4) clears the true geometry (margin 0)."""
    C, r = local
    W = np.einsum("mij,kj->mki", T[:, :3, :3], C) + T[:, None, :3, 3]
    d = _dists(np.ascontiguousarray(W.reshape(-1, 3)), prims).reshape(len(T), -1)
    return np.all(d - r[None] >= 0.0, axis=1)


def label_of(cells, occ, fine):
    """(state per cell or -1 outside, resolution [m] of the labelling map per cell)."""
    st = np.full(len(cells), -1)
    res = np.full(len(cells), occ.resolution)
    v = occ.world_to_voxel(cells)
    ok = occ.in_grid(v)
    st[ok] = occ.state[v[ok, 0], v[ok, 1], v[ok, 2]]
    if fine is not None:
        fv = fine.world_to_voxel(cells)
        inb = fine.in_grid(fv)
        st[inb] = fine.state[fv[inb, 0], fv[inb, 1], fv[inb, 2]]
        res[inb] = fine.resolution
    return st, res


def classify(cells, occ, fine, rest, tgt, cam) -> np.ndarray:
    st, res = label_of(cells, occ, fine)
    d_rest, d_tgt = _dists(cells, rest), _dists(cells, tgt)
    kind = np.full(len(cells), "outside", dtype=object)
    unk = st == int(VoxelState.UNKNOWN)
    kind[unk] = np.where(d_rest[unk] <= occ.resolution, "unknown_obstacle", "unknown_free")
    occd = st == int(VoxelState.OCCUPIED)
    kind[occd & (d_rest <= res)] = "occupied_resolution"
    kind[occd & (d_rest > res) & (d_tgt <= res)] = "occupied_target"
    kind[occd & (d_rest > res) & (d_tgt > res)] = "occupied_map_error"
    kind[st == int(VoxelState.FREE)] = "outside"  # free labels cannot be unsafe but for the box's outside
    return kind, shadowed(cells, cam, tgt) & unk


def shadowed(cells, cam, tgt, n: int = 24) -> np.ndarray:
    """(K,) the segment from the camera cam (3,) to each cell passes inside the target."""
    s = np.linspace(0.02, 0.98, n)
    P = cam[None, None] + s[None, :, None] * (cells[:, None] - cam[None, None])
    return np.any(_dists(np.ascontiguousarray(P.reshape(-1, 3)), tgt).reshape(len(cells), n) < 0.0, axis=1)


def hand_stage(box: dict, spheres, rng):
    """The selection's hand stage on a captured `box` (its config, target, map, q, fine map,
    task, extra_safe, proposer): (desired approach n, candidates, the `GraspChecks`, the rigid
    hand's spheres, indices of the candidates within the approach cone, their TCP poses T, and
    the hand's clearance at the grasp, pre-grasp and lift), candidates drawn with `rng`."""
    cfg, target, occ, q = box["config"], box["target"], box["occ"], np.asarray(box["q"])
    n = desired_approach(target, box["task"])
    proposer = box.get("proposer") or AntipodalProposer(cfg.candidates)
    cands = propose_in_cone(proposer, target, rng, n, cfg.max_approach_angle)
    cur = spheres.sphere_centers(q[None])[0]
    extra = base_volume_mask(spheres, occ) | box["extra_safe"]
    ch = GraspChecks(occ, target, spheres, PandaIK(spheres.kinematics), cfg,
                     (cur, spheres.radii + cfg.robot_clearance), extra, q, fine_map=box.get("fine_map"))
    local = rigid_hand_spheres(spheres)
    within = np.nonzero(approach_angles(cands, n) <= cfg.max_approach_angle)[0]
    T = cands.T_world_tcp[within]
    at = hand_clear(ch.fine, T, local, cfg.voxel_extent)
    pre = first_clear(ch.fine, T, local, pregrasp_steps(cfg.pregrasp_distances), cfg.voxel_extent)
    lift = first_clear(ch.fine, T, local, lift_steps(cfg.lift_heights), cfg.voxel_extent)
    return n, cands, ch, local, within, T, at, pre, lift


def diagnose(level: int, index: int, seed: int) -> dict:
    cs, spheres = scene_spheres(level, index, seed)
    scene = cs.scene
    box = capture(scene, seed)
    rec = {"level": level, "index": index}
    if "target" not in box:
        rec["error"] = "no selection reached"
        return rec
    cfg: GraspSelectConfig = box["config"]
    target, occ, q, fine = box["target"], box["occ"], box["q"], box.get("fine_map")
    n, cands, ch, local, within, T, at, pre, lift = hand_stage(box, spheres, box["rng"])
    rest = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    tgt = PrimitiveSet.from_shapes(list(scene.target.parts)).arrays()
    d_short = cfg.pregrasp_distances[-1]
    fr = (1.0, 0.75, 0.5, 0.25)
    gt_at = gt_free(rest, T, local)
    gt_app = np.ones(len(T), bool)
    for f in fr:
        Tf = T.copy()
        Tf[:, :3, 3] -= f * d_short * Tf[:, :3, 2]
        gt_app &= gt_free(rest, Tf, local)
    rej_at, rej_app = ~at, at & np.isnan(pre)
    rec.update(n_candidates=len(cands), in_cone=len(within), hand_in_collision=int(rej_at.sum()),
               approach_blocked=int(rej_app.sum()), lift_blocked=int((at & ~np.isnan(pre) & np.isnan(lift)).sum()),
               passed=int((at & ~np.isnan(pre) & ~np.isnan(lift)).sum()),
               gt_free_of_hand_in_collision=int((rej_at & gt_at).sum()),
               gt_free_of_approach_blocked=int((rej_app & gt_at & gt_app).sum()))
    hands, cells_by_kind, shadow = Counter(), Counter(), Counter()
    cam = box["T_world_cam"][:3, 3]
    C, r = local
    for stage, sel in (("grasp", rej_at & gt_at), ("approach", rej_app & gt_at & gt_app)):
        idx = np.nonzero(sel)[0]
        for i in idx:
            poses = [T[i]] if stage == "grasp" else []
            if stage == "approach":
                for f in fr:
                    Tf = T[i].copy()
                    Tf[:3, 3] -= f * d_short * Tf[:3, 2]
                    poses.append(Tf)
            cs = []
            for P in poses:
                c, _ = blocking_cells(ch.fine, C @ P[:3, :3].T + P[:3, 3], r)
                if len(c):
                    cs.append(c)
            if not cs:
                hands[f"{stage}:margin_only"] += 1
                continue
            cells = np.unique(np.vstack(cs), axis=0)
            kind, sh = classify(cells, occ, fine, rest, tgt, cam)
            ks = set(kind)
            for k in ks:
                hands[f"{stage}:{k}"] += 1
            if len(ks) == 1:
                hands[f"{stage}:only_{next(iter(ks))}"] += 1
            cells_by_kind.update(Counter(kind))
            shadow["unknown_cells_in_shadow"] += int(sh.sum())
            shadow["unknown_cells"] += int(np.isin(kind, ("unknown_free", "unknown_obstacle")).sum())
    # the arm stage: hands that passed, in the selection's order (score first), up to max_checked
    gt = oracle.ground_truth_checker(scene, exclude_target=True)
    passed = np.nonzero(at & ~np.isnan(pre) & ~np.isnan(lift))[0]
    passed = passed[np.argsort(-cands.score[within[passed]], kind="stable")][: cfg.max_checked]
    arm, arm_cells = Counter(), Counter()
    for i in passed:
        qs, why = ch.check(T[i], q, pre[i], lift[i], True)
        arm[why or "ok"] += 1
        if why != "IK_IN_COLLISION":
            continue
        r_ik = ch.ik_first(T[i], q)
        good = r_ik.solutions[gt.are_valid(r_ik.solutions)]
        if not len(good):
            continue
        arm["IK_IN_COLLISION:gt_free_solution"] += 1
        cells, _ = blocking_cells(ch.fine, spheres.sphere_centers(good[:1])[0], spheres.radii)
        if len(cells):
            kind, _ = classify(cells, occ, fine, rest, tgt, cam)
            arm_cells.update(Counter(kind))
            for k in set(kind):
                arm[f"IK_IN_COLLISION:gt_free:{k}"] += 1
    rec["arm"] = dict(sorted(arm.items()))
    rec["arm_cells"] = dict(arm_cells)
    rec["hands"] = dict(sorted(hands.items()))
    rec["cells"] = dict(cells_by_kind)
    rec["shadow"] = dict(shadow)
    return rec


def scene_arguments(ap: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The scene set's arguments these diagnosis scripts share (--count, --start, --levels, --seed)."""
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 3])
    ap.add_argument("--seed", type=int, default=0)
    return ap


def main() -> int:
    ap = scene_arguments(argparse.ArgumentParser())
    ap.add_argument("--only", default=None, help="comma-separated L:I pairs to run (default all)")
    args = ap.parse_args()
    only = None if args.only is None else {tuple(int(x) for x in p.split(":")) for p in args.only.split(",")}
    total: dict = {}
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            if only is not None and (level, index) not in only:
                continue
            rec = diagnose(level, index, args.seed)
            print(json.dumps(rec), flush=True)
            for key in ("hands", "cells", "shadow", "arm", "arm_cells"):
                total.setdefault(key, Counter()).update(rec.get(key, {}))
            for key in ("in_cone", "hand_in_collision", "approach_blocked", "gt_free_of_hand_in_collision",
                        "gt_free_of_approach_blocked", "passed"):
                total.setdefault("counts", Counter())[key] += rec.get(key, 0)
    print(json.dumps({"total": {k: dict(v) for k, v in total.items()}}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
