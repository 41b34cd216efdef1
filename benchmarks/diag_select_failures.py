"""Diagnosis (GROUND TRUTH, read here only): which check or plan refuses the grasps a failed
selection (`NO_IK`, `NO_APPROACH_PATH`, `NO_PATH`) should have found.

Per captured selection (`bench_grasp.py --capture DIR`):

* the replayed selection: its failure, rejections, and every planner call it made (goals,
  failure, edge checks);
* the scene's certified grasp (the certificate's grasp configuration's TCP): the method's
  hand checks at the grasp, along the approach and the lift, the arm's checks
  (`check_shorter`: its reason), IK (solutions, how many valid for the method and in
  truth), the unsafe cells blocking its hand and its arm by kind (`diag_hand_rejections.classify`:
  unknown free / unknown obstacle in truth, occupied within a voxel of a true surface, of
  the target only, or where truth is free);
* the in-cone candidates (the selection's own draw) that are feasible in truth (rigid hand
  free of the true scene less the target at the grasp, along the shortest pre-grasp and the
  lowest lift, and an IK solution whose whole arm is free in truth at the grasp): how many
  per score, the method's verdict on each (hand stage or the arm's `check_shorter` reason),
  and the blocking cells' kinds for the best few;
* for the planner's goals (and the certified pre-grasp when the arm checks pass): a plan on
  the method's checker with 10x the edge-check budget, and one on the true scene.

Prints one JSON line per scene. Run:
`PYTHONPATH=src:benchmarks python benchmarks/diag_select_failures.py --dir DIR [--only 3:7,1:14]`.
"""
from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import math
import os
import sys
from collections import Counter

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from capture_select_inputs import capture_arguments, read_captures
from compass_manip.grasp import select as select_mod
from compass_manip.grasp.candidates import AntipodalProposer, propose_in_cone
from compass_manip.grasp.checks import (GraspChecks, first_clear, hand_clear, lift_steps, offset_pose,
                                        pregrasp_steps, rigid_hand_spheres)
from compass_manip.grasp.select import approach_angles, base_volume_mask, desired_approach, select_grasp
from compass_manip.motion.planner import plan
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.robot.ik import PandaIK
from compass_manip.sim import oracle
from diag_grasp_certified import blocking_cells, scene_spheres
from diag_hand_rejections import classify, gt_free


def checks_of(box, spheres, exact: bool = False) -> GraspChecks:
    cfg = box["config"]
    q = np.asarray(box["q"])
    cur = spheres.sphere_centers(q[None])[0]
    extra = base_volume_mask(spheres, box["occ"]) | box["extra_safe"]
    return GraspChecks(box["occ"], box["target"], spheres, PandaIK(spheres.kinematics), cfg,
                       (cur, spheres.radii + cfg.robot_clearance), extra, q, fine_map=box.get("fine_map"),
                       exact_everywhere=exact)


def replay(box, spheres) -> tuple[dict, list]:
    """The selection replayed, with its planner calls recorded."""
    calls = []
    orig = select_mod.plan

    def rec_plan(q0, goals, checker, config, rng):
        r = orig(q0, goals, checker, config, rng)
        calls.append({"goals": np.asarray(goals).copy(), "failure": None if r.failure is None else r.failure.name,
                      "n_checks": int(r.n_checks), "checker": checker})
        return r

    select_mod.plan = rec_plan
    try:
        s = select_grasp(box["target"], box["occ"], box["task"], box["q"], spheres, box["config"],
                         copy.deepcopy(box["rng"]), proposer=box.get("proposer"), extra_safe=box["extra_safe"],
                         fine_map=box.get("fine_map"))
    finally:
        select_mod.plan = orig
    out = {"failure": None if s.failure is None else s.failure.name, "score": s.score,
           "rejections": {k.name: v for k, v in s.rejections.items()},
           "plans": [{k: v for k, v in c.items() if k not in ("goals", "checker")} | {"n_goals": len(c["goals"])}
                     for c in calls]}
    return out, calls


def kinds_of(ch, box, scene, cells) -> dict:
    if not len(cells):
        return {}
    rest = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    tgt = PrimitiveSet.from_shapes(list(scene.target.parts)).arrays()
    kind, _ = classify(cells, box["occ"], box.get("fine_map"), rest, tgt, np.zeros(3))
    return dict(Counter(kind))


def arm_blockers(ch, box, scene, spheres, q) -> dict:
    """Links and cell kinds blocking the whole arm at configuration q (7,)."""
    W = spheres.sphere_centers(np.asarray(q)[None])[0]
    cells, failing = blocking_cells(ch.fine, W, spheres.radii)
    return {"links": dict(Counter(spheres.link_names[spheres.body_index[k]] for k in failing)),
            "cells": kinds_of(ch, box, scene, cells)}


def hand_blockers(ch, box, scene, T) -> dict:
    C, r = rigid_hand_spheres(ch_spheres[0])
    cells, _ = blocking_cells(ch.fine, C @ T[:3, :3].T + T[:3, 3], r)
    return kinds_of(ch, box, scene, cells)


ch_spheres: list = []


def verdict(ch, cfg, T, q, lift_clear) -> tuple[str, tuple | None]:
    """The method's verdict on one TCP pose: a hand stage's rejection or `check_shorter`'s."""
    local = rigid_hand_spheres(ch_spheres[0])
    if not hand_clear(ch.fine, T[None], local, cfg.voxel_extent)[0]:
        return "HAND_IN_COLLISION", None
    pre = first_clear(ch.fine, T[None], local, pregrasp_steps(cfg.pregrasp_distances), cfg.voxel_extent)[0]
    if np.isnan(pre):
        return "HAND_APPROACH_BLOCKED", None
    lift = first_clear(ch.fine, T[None], local, lift_steps(cfg.lift_heights), cfg.voxel_extent)[0]
    if np.isnan(lift):
        return "HAND_LIFT_BLOCKED", None
    qs, why, d, h = ch.check_shorter(T, q, pre, lift, lift_clear)
    return (why or "ok"), qs


def plan_tries(q, goals, ch, scene, cfg, rng) -> dict:
    """A plan to goals (k,7) with 10x the budget on the method's checker, and on the true scene."""
    big = dataclasses.replace(cfg.planner, max_checks=10 * cfg.planner.max_checks)
    r10 = plan(q, goals, ch.plan, big, rng)
    gt = oracle.ground_truth_checker(scene)
    goal_gt = gt.are_valid(goals)
    rgt = plan(q, goals[goal_gt], gt, cfg.planner, rng) if goal_gt.any() else None
    return {"method_10x": r10.failure.name if r10.failure else f"ok ({r10.n_checks} checks)",
            "goals_valid_in_truth": int(goal_gt.sum()),
            "truth": None if rgt is None else (rgt.failure.name if rgt.failure else f"ok ({rgt.n_checks} checks)")}


def diagnose(level: int, index: int, seed: int, box: dict, n_best: int) -> dict:
    cs, spheres = scene_spheres(level, index, seed)
    ch_spheres[:] = [spheres]
    scene, cert = cs.scene, cs.certificate
    cfg = box["config"]
    q = np.asarray(box["q"])
    rec = {"level": level, "index": index, "target": scene.target.category}
    rec["selection"], calls = replay(box, spheres)
    ch = checks_of(box, spheres)
    lift_clear = {h: ch.held_target_clear(h) for h in cfg.lift_heights}
    rec["held_target_clear"] = {str(h): v for h, v in lift_clear.items()}
    gt_full = oracle.ground_truth_checker(scene)
    gt_notgt = oracle.ground_truth_checker(scene, exclude_target=True)
    rest = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    local = rigid_hand_spheres(spheres)
    rng = np.random.default_rng(7)
    # the certified grasp
    marks = dict(zip(("view", "pregrasp", "grasp", "lift"), cert.path_marks))
    q_cg = np.array(cert.path[marks["grasp"]])
    T_c = spheres.kinematics.T_world_tcp(q_cg)
    n = desired_approach(box["target"], box["task"])
    v, qs = verdict(ch, cfg, T_c, q, lift_clear)
    r_ik = ch.ik_first(T_c, q)
    c = {"angle_to_n_deg": round(math.degrees(math.acos(float(np.clip(T_c[:3, 2] @ n, -1, 1)))), 1),
         "verdict": v, "ik_solutions": int(len(r_ik.solutions)) if r_ik.success else 0}
    if r_ik.success:
        c["ik_valid_method"] = int(ch.valid(r_ik.solutions).sum())
        c["ik_valid_truth"] = int(gt_notgt.are_valid(r_ik.solutions).sum())
    c["hand_cells_at_grasp"] = hand_blockers(ch, box, scene, T_c)
    c["hand_cells_at_pregrasp_6cm"] = hand_blockers(ch, box, scene, offset_pose(T_c, -0.06))
    c["hand_cells_at_lift_4cm"] = hand_blockers(ch, box, scene, offset_pose(T_c, up=0.04))
    for name in ("pregrasp", "grasp", "lift"):
        qc = np.array(cert.path[marks[name]])
        c[f"cert_q_{name}"] = {"valid_method": bool(ch.valid(qc[None])[0])} | arm_blockers(ch, box, scene, spheres, qc)
    if qs is not None:
        c["plan"] = plan_tries(q, np.asarray(qs[1])[None], ch, scene, cfg, rng)
    rec["certified"] = c
    # the in-cone candidates feasible in truth
    proposer = box.get("proposer") or AntipodalProposer(cfg.candidates)
    cands = propose_in_cone(proposer, box["target"], copy.deepcopy(box["rng"]), n, cfg.max_approach_angle)
    within = np.nonzero(approach_angles(cands, n) <= cfg.max_approach_angle)[0]
    T = cands.T_world_tcp[within]
    ok = gt_free(rest, T, local)
    for k in (0.25, 0.5, 0.75, 1.0):
        ok &= gt_free(rest, np.array([offset_pose(t, -k * cfg.pregrasp_distances[-1]) for t in T]), local)
    ok &= gt_free(rest, np.array([offset_pose(t, up=cfg.lift_heights[-1]) for t in T]), local)
    rec["in_cone"] = len(within)
    rec["gt_hand_free"] = int(ok.sum())
    idx = np.nonzero(ok)[0]
    idx = idx[np.argsort(-cands.score[within[idx]], kind="stable")]
    feas, verdicts, best = Counter(), Counter(), []
    for i in idx:
        t = T[i]
        r = ch.ik_first(t, q)
        if not r.success:
            continue
        good = r.solutions[gt_notgt.are_valid(r.solutions)]
        if not len(good):
            continue
        s = float(cands.score[within[i]])
        feas[s] += 1
        vv, qs_i = verdict(ch, cfg, t, q, lift_clear)
        verdicts[f"{s}:{vv}"] += 1
        if len(best) < n_best:
            b = {"score": s, "verdict": vv, "tcp": [round(float(x), 3) for x in t[:3, 3]],
                 "angle_deg": round(math.degrees(math.acos(float(np.clip(t[:3, 2] @ n, -1, 1)))), 1)}
            if vv == "HAND_IN_COLLISION":
                b["hand_cells"] = hand_blockers(ch, box, scene, t)
            elif vv == "HAND_APPROACH_BLOCKED":  # every step of the shortest pre-grasp's approach
                b["hand_cells"] = dict(sum((Counter(hand_blockers(ch, box, scene, offset_pose(t, -k * cfg.pregrasp_distances[-1])))
                                            for k in (0.25, 0.5, 0.75, 1.0)), Counter()))
            elif vv == "HAND_LIFT_BLOCKED":
                b["hand_cells"] = dict(sum((Counter(hand_blockers(ch, box, scene, offset_pose(t, up=h)))
                                            for h in (0.01, 0.02, 0.03, 0.04)), Counter()))
            elif vv == "IK_IN_COLLISION":
                b["arm_at_gt_free_ik"] = arm_blockers(ch, box, scene, spheres, good[0])
            elif vv in ("PREGRASP_BLOCKED", "APPROACH_BLOCKED", "LIFT_BLOCKED"):
                qg = good[0]
                qp = ch.near(offset_pose(t, -cfg.pregrasp_distances[-1]), qg, None)
                if qp is not None:
                    b["pregrasp_valid_truth"] = bool(gt_full.are_valid(qp[None])[0])
                    b["pregrasp_plan_valid_method"] = bool(ch.plan.are_valid(qp[None])[0])
                    b["arm_at_pregrasp"] = arm_blockers(ch, box, scene, spheres, qp)
                ql = ch.near(offset_pose(t, up=cfg.lift_heights[-1]), qg, None)
                if ql is not None:
                    b["lift_valid_truth"] = bool(gt_notgt.are_valid(ql[None])[0])
                    b["arm_at_lift"] = arm_blockers(ch, box, scene, spheres, ql)
            elif vv == "ok":
                b["plan"] = plan_tries(q, np.asarray(qs_i[1])[None], ch, scene, cfg, rng)
            best.append(b)
    rec["gt_feasible_by_score"] = {str(k): v for k, v in sorted(feas.items(), reverse=True)}
    rec["gt_feasible_verdicts"] = dict(verdicts.most_common())
    rec["best_gt_feasible"] = best
    # the planner calls that failed: more budget, or the truth
    rec["failed_plans"] = [plan_tries(q, c["goals"], ch, scene, cfg, rng) for c in calls if c["failure"]][:3]
    return rec


def main() -> int:
    ap = capture_arguments(argparse.ArgumentParser())
    ap.add_argument("--best", type=int, default=6, help="feasible-in-truth candidates detailed per scene")
    args = ap.parse_args()
    for level, index, box in read_captures(args.dir, args.only):
        if "target" not in box:
            print(json.dumps({"level": level, "index": index, "error": "no selection reached"}), flush=True)
            continue
        print(json.dumps(diagnose(level, index, args.seed, box, args.best)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
