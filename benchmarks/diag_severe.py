"""Diagnosis (GROUND TRUTH, read here only): what stops the severe levels' neck grasps.

Per scene (levels 2/4, indices --start..; seed) the grasp-only harness runs up to its
selection with its default config (INSPECT included) and the inputs are captured. Then:

* the selection itself on those inputs (its failure and rejection counts);
* the in-cone candidates and, of them, the ones on the neck (TCP within the neck's height and
  1 cm of its axis, approach within 15 deg of level): how many the rigid hand's checks reject
  at the grasp, on the approach and on the lift, how many of those are free in truth, and the
  unsafe 5 mm cells that block the GT-free ones;
* the on-neck hands that pass: the arm stage's verdict (`GraspChecks.check_shorter`) and,
  for each rejected one, the cells blocking the whole robot at the first failing
  configuration (grasp, pre-grasp or lift of its first IK solution free in truth);
* the certified grasp (the certificate's path): the hand's verdict, the arm configurations';
* whether the held target (the model's points) is clear along each lift height (a scene-wide
  verdict: every candidate's lift needs it), and where the model's back and centre lie against
  the true bottle (x: along the opening's inward normal).

Blocking cells are classified by map state (fine map where it reaches, else 1 cm), by truth
(obstacle within a 1 cm voxel's half diagonal of the scene less the target, else free) and by
region in the target's frame (u along the inward approach from the neck's axis, v lateral,
z against the occluder's top): `above_box` (u within the box's depth, z > 0), `behind`
(u > neck radius), `in_front` (u before the box's front), `beside`, `below_box_top`.
Prints one JSON line per scene. Run:
`PYTHONPATH=src:benchmarks python benchmarks/diag_severe.py --levels 2 4 --count 10`.
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import os
import pickle
import sys
from collections import Counter

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.grasp.candidates import AntipodalProposer, propose_in_cone
from compass_manip.grasp.checks import (GraspChecks, first_clear, hand_clear, lift_steps, offset_pose,
                                        pregrasp_steps, rigid_hand_spheres)
from compass_manip.grasp.select import (GraspSelectConfig, approach_angles, base_volume_mask, desired_approach,
                                        select_grasp)
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.robot.ik import PandaIK
from compass_manip.sim import oracle
from compass_manip.sim.scenes import BOARD_THICKNESS
from diag_grasp_certified import _dists, blocking_cells, scene_spheres
from diag_hand_rejections import capture, gt_free, label_of, scene_arguments

STATE = {int(VoxelState.UNKNOWN): "unknown", int(VoxelState.OCCUPIED): "occupied", int(VoxelState.FREE): "free",
         -1: "outside"}


class Frame:
    """The target's frame (ground truth): u along the inward approach (+x of the scene) from
    the neck's axis, v lateral, z against the occluder's top."""

    def __init__(self, scene):
        tgt = scene.target
        self.axis = np.asarray(tgt.parts[1].pos[:2], dtype=np.float64)
        self.r_neck = float(tgt.parts[1].half_extents[0])
        occl = [o for o in scene.objects if o.role == "occluder"]
        lo, hi = occl[0].aabb() if occl else (np.full(3, np.nan), np.full(3, np.nan))
        self.box_lo, self.box_hi = np.asarray(lo), np.asarray(hi)
        self.neck_top = float(tgt.aabb()[1][2])
        cab = scene.cabinet
        self.x_open = float(cab.interior_min[0])
        shelf = min((z for z in cab.shelves if z > self.neck_top), default=float(cab.interior_max[2]))
        self.rail_bottom = shelf - BOARD_THICKNESS - float(cab.rail)

    def uvz(self, P: np.ndarray) -> np.ndarray:
        return np.column_stack([P[:, 0] - self.axis[0], P[:, 1] - self.axis[1], P[:, 2] - self.box_hi[2]])

    def region(self, P: np.ndarray) -> np.ndarray:
        u, v, z = self.uvz(P).T
        box_u0 = self.box_lo[0] - self.axis[0]
        out = np.full(len(P), "beside", dtype=object)
        lateral = np.abs(P[:, 1] - 0.5 * (self.box_lo[1] + self.box_hi[1])) <= 0.5 * (self.box_hi[1] - self.box_lo[1])
        out[(u > self.r_neck)] = "behind"
        out[(u >= box_u0) & (u <= -self.r_neck) & lateral & (z > 0)] = "above_box"
        out[(u >= box_u0) & (u <= self.r_neck) & (z <= 0)] = "below_box_top"
        out[(u < box_u0)] = "in_front"
        near_rail = (P[:, 0] >= self.x_open - 0.05) & (P[:, 0] <= self.x_open + 0.15) & (P[:, 2] >= self.rail_bottom - 0.05)
        out[near_rail] = np.where(P[near_rail, 0] >= self.x_open, "behind_rail", "before_rail")
        return out


def classify(cells: np.ndarray, occ, fine, rest, frame: Frame) -> Counter:
    """Counter of 'state/truth/region' over blocking cells (K,3) [m]."""
    if not len(cells):
        return Counter()
    st, _ = label_of(cells, occ, fine)
    truth = np.where(_dists(cells, rest) <= 0.5 * math.sqrt(3.0) * occ.resolution, "obstacle", "free")
    reg = frame.region(cells)
    return Counter(f"{STATE[int(s)]}/{t}/{g}" for s, t, g in zip(st, truth, reg))


def robot_cells(field, spheres, q):
    return blocking_cells(field, spheres.sphere_centers(np.asarray(q)[None])[0], spheres.radii)


def visibility(scene, cells: np.ndarray, n: int, rng: np.random.Generator, frame: Frame) -> dict:
    """GROUND TRUTH: of n camera poses looking at the cells (K,3) [m] from 0.15-0.6 m in any
    direction, the ones whose configuration (camera IK, 4 q7 samples) is free of contacts:
    the best fraction of the cells one of them sees (the depth ray reaches the cell), where
    its camera stands (x against the opening plane [m], z against the rail's bottom [m]),
    and the fraction seen by all of them together; split by inside / outside the opening."""
    from compass_manip.geometry import look_at
    from compass_manip.robot.ik import ik_camera
    from compass_manip.robot.model import GRIPPER_MAX_WIDTH
    from compass_manip.sim.world import World
    world = World(scene)
    q_home = np.asarray(world.robot.q_home)
    seen_any = {"inside": np.zeros(len(cells), bool), "outside": np.zeros(len(cells), bool)}
    best = {"inside": (0.0, None), "outside": (0.0, None)}
    n_valid = Counter()
    c0 = cells.mean(axis=0)
    try:
        for _ in range(n):
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            eye = c0 + rng.uniform(0.15, 0.6) * d
            aim = cells[rng.integers(len(cells))]
            T = look_at(eye, aim)
            sols = ik_camera(T, q_home, n_q7=4).solutions
            q = next((x for x in sols[:3] if not world.in_collision(x, GRIPPER_MAX_WIDTH)), None)
            if q is None:
                continue
            f = world.render(q, rgb=False, seg=False)
            Tc = np.linalg.inv(f.T_world_cam)
            pc = cells @ Tc[:3, :3].T + Tc[:3, 3]
            z = pc[:, 2]
            h, w = f.depth.shape
            ok = z > 0.05
            uu = np.full(len(cells), -1)
            vv = np.full(len(cells), -1)
            uu[ok] = np.round(f.K[0, 0] * pc[ok, 0] / z[ok] + f.K[0, 2]).astype(int)
            vv[ok] = np.round(f.K[1, 1] * pc[ok, 1] / z[ok] + f.K[1, 2]).astype(int)
            ok &= (uu >= 0) & (uu < w) & (vv >= 0) & (vv < h)
            seen = np.zeros(len(cells), bool)
            dep = f.depth[vv[ok], uu[ok]]
            seen[ok] = (dep >= z[ok] - 0.005) & (z[ok] <= 3.0)
            where = "inside" if f.T_world_cam[0, 3] >= frame.x_open else "outside"
            n_valid[where] += 1
            seen_any[where] |= seen
            frac = float(seen.mean())
            if frac > best[where][0]:
                pos = f.T_world_cam[:3, 3]
                best[where] = (frac, [round(float(pos[0] - frame.x_open), 3), round(float(pos[2] - frame.rail_bottom), 3)])
    finally:
        world.close()
    return {k: {"valid_poses": n_valid[k], "best_fraction": round(best[k][0], 3), "best_cam_x_z": best[k][1],
                "union_fraction": round(float(seen_any[k].mean()), 3)} for k in ("inside", "outside")}


def diagnose(level: int, index: int, seed: int, max_arm: int, from_dir: str | None = None, n_views: int = 0) -> dict:
    cs, spheres = scene_spheres(level, index, seed)
    scene, cert = cs.scene, cs.certificate
    rec: dict = {"level": level, "index": index}
    path = None if from_dir is None else os.path.join(from_dir, f"L{level}_{index}.pkl")
    if path is not None and os.path.exists(path):
        with open(path, "rb") as f:
            box = pickle.load(f)
    else:
        box = capture(scene, seed)
    if "target" not in box:
        rec["error"] = "no selection reached"
        return rec
    cfg: GraspSelectConfig = box["config"]
    target, occ, q, fine, task = box["target"], box["occ"], box["q"], box.get("fine_map"), box["task"]
    proposer = box.get("proposer") or AntipodalProposer(cfg.candidates)
    sel = select_grasp(target, occ, task, q, spheres, cfg, copy.deepcopy(box["rng"]), proposer=proposer,
                       extra_safe=box.get("extra_safe"), fine_map=fine)
    rec["selection"] = {"failure": None if sel.failure is None else sel.failure.name,
                        "rejections": {k.name: v for k, v in sel.rejections.items() if v}}
    frame = Frame(scene)
    rest = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    n = desired_approach(target, task)
    rec["n"] = [round(float(x), 3) for x in n]
    rec["model_top_vs_neck_top_cm"] = round(100 * (float(target.points[:, 2].max()) - frame.neck_top), 1)
    cands = propose_in_cone(proposer, target, copy.deepcopy(box["rng"]), n, cfg.max_approach_angle)
    within = np.nonzero(approach_angles(cands, n) <= cfg.max_approach_angle)[0]
    T = cands.T_world_tcp[within]
    p, z = T[:, :3, 3], T[:, :3, 2]
    neck_z0 = float(scene.target.parts[1].pos[2] - scene.target.parts[1].half_extents[2])
    on_neck = ((p[:, 2] >= neck_z0) & (p[:, 2] <= frame.neck_top)
               & (np.linalg.norm(p[:, :2] - frame.axis, axis=1) <= frame.r_neck + 0.01) & (np.abs(z[:, 2]) <= 0.26))
    cur = spheres.sphere_centers(np.asarray(q)[None])[0]
    extra = base_volume_mask(spheres, occ) | box["extra_safe"]
    ch = GraspChecks(occ, target, spheres, PandaIK(spheres.kinematics), cfg,
                     (cur, spheres.radii + cfg.robot_clearance), extra, q, fine_map=fine)
    rec["held_target_clear"] = {str(h): ch.held_target_clear(h) for h in cfg.lift_heights}
    rec["model_back_minus_true_back_cm"] = round(100 * (float(target.points[:, 0].max())
                                                        - float(scene.target.aabb()[1][0])), 1)
    rec["model_centre_minus_axis_cm"] = [round(100 * float(v), 1) for v in target.centre[:2] - frame.axis]
    local = rigid_hand_spheres(spheres)
    at = hand_clear(ch.fine, T, local, cfg.voxel_extent)
    pre = first_clear(ch.fine, T, local, pregrasp_steps(cfg.pregrasp_distances), cfg.voxel_extent)
    lift = first_clear(ch.fine, T, local, lift_steps(cfg.lift_heights), cfg.voxel_extent)
    gt_at = gt_free(rest, T, local)
    stage = np.where(~at, "grasp", np.where(np.isnan(pre), "approach", np.where(np.isnan(lift), "lift", "passed")))
    rec["in_cone"] = len(T)
    rec["on_neck"] = int(on_neck.sum())
    rec["on_neck_stage"] = dict(Counter(stage[on_neck]))
    rec["on_neck_stage_gt_free_at_grasp"] = dict(Counter(stage[on_neck & gt_at]))
    rec["tcp_below_neck_top_cm_on_neck"] = (np.percentile(100 * (frame.neck_top - p[on_neck, 2]), [0, 50, 100]).round(1)
                                            .tolist() if on_neck.any() else None)
    C, r = local
    hand_cells, hand_links = Counter(), Counter()
    for i in np.nonzero(on_neck & gt_at & (stage != "passed"))[0]:
        poses = [T[i]]
        if stage[i] == "approach":
            poses = [offset_pose(T[i], -f * cfg.pregrasp_distances[-1]) for f in (0.25, 0.5, 0.75, 1.0)]
        elif stage[i] == "lift":
            poses = [offset_pose(T[i], up=h) for h in (0.025, cfg.lift_heights[-1])]
        cs_ = [blocking_cells(ch.fine, C @ P[:3, :3].T + P[:3, 3], r)[0] for P in poses]
        cells = np.unique(np.vstack(cs_), axis=0) if cs_ else np.zeros((0, 3))
        hand_cells.update(classify(cells, occ, fine, rest, frame))
    rec["hand_cells_gt_free_on_neck"] = dict(hand_cells.most_common(12))
    # the arm stage on the on-neck hands that passed, in score order
    gt = oracle.ground_truth_checker(scene, exclude_target=True)
    lift_clear = {h: ch.held_target_clear(h) for h in cfg.lift_heights}
    passed = np.nonzero(on_neck & (stage == "passed"))[0]
    passed = passed[np.argsort(-cands.score[within[passed]], kind="stable")][:max_arm]
    arm, arm_cells, arm_links = Counter(), Counter(), Counter()
    arm_unknown: list = []  # the arm's blocking cells unknown on the map and free in truth
    for i in passed:
        qs, why, _, _ = ch.check_shorter(T[i], q, pre[i], lift[i], lift_clear)
        arm[why or "ok"] += 1
        if why is None or why == "NO_IK":
            continue
        sol = ch.ik_first(T[i], q).solutions
        good = sol[gt.are_valid(sol)]
        if not len(good):
            arm[f"{why}:no_gt_free_ik"] += 1
            continue
        qg = good[0]
        bad_q = qg if not ch.valid(qg[None])[0] else None
        if bad_q is None:
            for Tq in (offset_pose(T[i], -cfg.pregrasp_distances[-1]), offset_pose(T[i], up=cfg.lift_heights[-1])):
                qn = ch.near(Tq, qg, None)
                if qn is not None and not ch.valid(qn[None])[0]:
                    bad_q = qn
                    break
        if bad_q is None:
            arm[f"{why}:no_invalid_config_found"] += 1
            continue
        cells, failing = robot_cells(ch.fine, spheres, bad_q)
        arm_links.update({spheres.link_names[spheres.body_index[k]] for k in failing})
        arm_cells.update(classify(cells, occ, fine, rest, frame))
        if len(cells):
            st, _ = label_of(cells, occ, fine)
            free = _dists(cells, rest) > 0.5 * math.sqrt(3.0) * occ.resolution
            arm_unknown.append(cells[(st == int(VoxelState.UNKNOWN)) & free])
    rec["arm_on_neck"] = dict(arm)
    rec["arm_links"] = dict(arm_links)
    rec["arm_cells"] = dict(arm_cells.most_common(12))
    cells = np.unique(np.round(np.vstack(arm_unknown), 4), axis=0) if arm_unknown else np.zeros((0, 3))
    rec["arm_unknown_free_cells"] = len(cells)
    if n_views and len(cells):
        rec["arm_unknown_visibility"] = visibility(scene, cells, n_views, np.random.default_rng([seed, level, index]),
                                                   frame)
    # the certified grasp
    if cert.path is not None and len(cert.path_marks) >= 4:
        marks = dict(zip(("view", "pregrasp", "grasp", "lift"), cert.path_marks))
        qg = np.array(cert.path[marks["grasp"]])
        Tc = spheres.kinematics.T_world_tcp(qg)
        cert_rec = {"angle_to_n_deg": round(math.degrees(math.acos(np.clip(Tc[:3, 2] @ n, -1, 1))), 1),
                    "tcp_below_neck_top_cm": round(100 * (frame.neck_top - Tc[2, 3]), 1),
                    "hand_at": bool(hand_clear(ch.fine, Tc[None], local)[0]),
                    "hand_pre": float(first_clear(ch.fine, Tc[None], local, pregrasp_steps(cfg.pregrasp_distances))[0]),
                    "hand_lift": float(first_clear(ch.fine, Tc[None], local, lift_steps(cfg.lift_heights))[0])}
        cells = np.zeros((0, 3))
        for name in ("pregrasp", "grasp", "lift"):
            qc = np.array(cert.path[marks[name]])
            ok = bool(ch.valid(qc[None])[0])
            cert_rec[f"q_{name}_valid"] = ok
            if not ok:
                c, failing = robot_cells(ch.fine, spheres, qc)
                cert_rec[f"q_{name}_links"] = sorted({spheres.link_names[spheres.body_index[k]] for k in failing})
                cells = np.vstack([cells, c])
        if not cert_rec["hand_at"]:
            cells = np.vstack([cells, blocking_cells(ch.fine, C @ Tc[:3, :3].T + Tc[:3, 3], r)[0]])
        cert_rec["cells"] = dict(classify(np.unique(cells, axis=0), occ, fine, rest, frame).most_common(10))
        rec["cert"] = cert_rec
    return rec


def main() -> int:
    ap = scene_arguments(argparse.ArgumentParser())
    ap.add_argument("--max-arm", type=int, default=60, help="on-neck hands passed to the arm stage per scene")
    ap.add_argument("--only", default=None, help="comma-separated L:I pairs (default all)")
    ap.add_argument("--views", type=int, default=0,
                    help="camera poses sampled to test whether the arm's unknown blocking cells can be seen (0: off)")
    ap.add_argument("--from-dir", default=None,
                    help="read the selection's inputs from DIR/L{level}_{index}.pkl (bench_grasp.py --capture) "
                         "where present instead of running the harness")
    args = ap.parse_args()
    only = None if args.only is None else {tuple(int(x) for x in s.split(":")) for s in args.only.split(",")}
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            if only is None or (level, index) in only:
                print(json.dumps(diagnose(level, index, args.seed, args.max_arm, args.from_dir, args.views)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
