"""Diagnosis (GROUND TRUTH, read here only): why a selected grasp fails in physics
(`MISSED`, `SLIP`, `DROP`).

Per captured selection (`bench_grasp.py --capture DIR`: the pickled `select_grasp` inputs)
the selection is replayed (the same candidates and choice: the generator was pickled with
the inputs) and, against the scene's true target (its primitives):

* the target model's error: signed distance of its observed / mirror-completed points to
  the true surface, its normals against the true surface's normal there (finite
  differences of the signed distance), its centre and extents against the true body's
  centre of mass (the parts' volume-weighted centres) and bounding box;
* the chosen candidate: its contacts p1, p2 (model points; the TCP's closing line), the
  model's normals there and the score they give, against the true surface where the
  closing line enters the body from each side (the true contacts, their normals, the true
  required friction and GraspNet score), the line's distance from the true axis / centre of
  mass, the TCP below the true top, the mass and the gravity torque about the closing line;
* in physics (`execute_grasp`, as the harness runs it): every finger-pad / target contact
  at the end of the close, lift and hold (position in the TCP frame at the grasp, the angle
  of the contact normal to the closing line, its normal force), the target's displacement
  and tilt per phase, the finger width.

Prints one JSON line per scene. Run:
`PYTHONPATH=src:benchmarks python benchmarks/diag_exec_failures.py --dir DIR [--only 3:0,3:6]`.
"""
from __future__ import annotations

import argparse
import ast
import json
import math
import os
import sys
from dataclasses import replace

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
from scipy.spatial import cKDTree

from capture_select_inputs import capture_arguments, read_captures
from compass_manip.grasp.candidates import AntipodalProposer, GraspCandidates, PinnedProposer
from compass_manip.grasp.hand_volume import depth_keep
from compass_manip.grasp.quality import graspnet_score, graspnet_score_cones, required_mu
from compass_manip.grasp.select import GraspSelectConfig, select_grasp
from compass_manip.grasp.target import normal_cones
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.robot.model import GRIPPER_MAX_WIDTH
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import grasp_exec
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World


def true_com(target) -> np.ndarray:
    """The body's centre of mass [m]: the parts' centres weighted by volume (mass by volume)."""
    v = np.array([p.volume for p in target.parts])
    c = np.array([p.pos for p in target.parts], dtype=float)
    return (v[:, None] * c).sum(0) / v.sum()


def sdf_normals(prims: PrimitiveSet, P: np.ndarray, h: float = 1e-4) -> np.ndarray:
    """(N,3) unit outward normals of the true surface near points P (gradient of the SDF)."""
    g = np.zeros((len(P), 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        g[:, k] = prims.distance(P + e) - prims.distance(P - e)
    return g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)


def entry_point(prims: PrimitiveSet, start: np.ndarray, d: np.ndarray, length: float) -> np.ndarray | None:
    """The first point where the segment start + t d (t in 0..length) enters the body (SDF < 0),
    to 0.1 mm; None when it never does."""
    t = np.arange(0.0, length, 2e-4)
    dist = prims.distance(start[None] + t[:, None] * d[None])
    inside = np.nonzero(dist < 0.0)[0]
    return None if not len(inside) else start + t[inside[0]] * d


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return round(math.degrees(math.acos(float(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1)))), 1)


def model_error(target, prims: PrimitiveSet, scene_target) -> dict:
    """The target model against the true shape [mm, deg]."""
    d = prims.distance(target.points)
    nt = sdf_normals(prims, target.points)
    ang = np.degrees(np.arccos(np.clip(np.sum(nt * target.normals, axis=1), -1, 1)))
    out = {}
    for name, m in (("observed", target.observed), ("completed", ~target.observed)):
        if m.any():
            out[name] = {"n": int(m.sum()), "dist_mm_median": round(1e3 * float(np.median(np.abs(d[m]))), 1),
                         "dist_mm_p90": round(1e3 * float(np.percentile(np.abs(d[m]), 90)), 1),
                         "outside_mm_max": round(1e3 * float(d[m].max()), 1),
                         "inside_mm_max": round(-1e3 * float(d[m].min()), 1),
                         "normal_deg_median": round(float(np.median(ang[m])), 1),
                         "normal_deg_p90": round(float(np.percentile(ang[m], 90)), 1)}
    com = true_com(scene_target)
    lo, hi = scene_target.aabb()
    out["centre_minus_com_mm"] = [round(1e3 * float(v), 1) for v in target.centre - com]
    out["model_aabb_minus_true_mm"] = {"lo": [round(1e3 * float(v), 1) for v in target.points.min(0) - lo],
                                       "hi": [round(1e3 * float(v), 1) for v in target.points.max(0) - hi]}
    return out


def grasp_truth(sel, target, prims: PrimitiveSet, scene_target) -> dict:
    """The chosen candidate's contacts on the model and in truth."""
    T, w = sel.T_world_tcp, sel.width
    p, y = T[:3, 3], T[:3, 1]
    ends = [p - 0.5 * w * y, p + 0.5 * w * y]
    idx = [int(np.argmin(np.linalg.norm(target.points - e, axis=1))) for e in ends]
    p1, p2 = target.points[idx[0]], target.points[idx[1]]
    n1, n2 = target.normals[idx[0]], target.normals[idx[1]]
    out = {"model_contact_match_mm": round(1e3 * max(float(np.linalg.norm(p1 - ends[0])),
                                                     float(np.linalg.norm(p2 - ends[1]))), 2),
           "model_score": float(graspnet_score(p1, p2, n1, n2)[0]),
           "model_contacts_observed": [bool(target.observed[i]) for i in idx]}
    # the true contacts: where the closing line enters the body from each side (from 6 cm out)
    c1 = entry_point(prims, p - 0.06 * y, y, 0.12)
    c2 = entry_point(prims, p + 0.06 * y, -y, 0.12)
    if c1 is None or c2 is None:
        out["true_line_misses_body"] = True
    else:
        t1, t2 = sdf_normals(prims, np.vstack([c1, c2]))
        out.update(true_width_mm=round(1e3 * float(np.linalg.norm(c2 - c1)), 1),
                   true_required_mu=round(float(required_mu(c1, c2, t1, t2)[0]), 3),
                   true_score=float(graspnet_score(c1, c2, t1, t2)[0]),
                   true_normal_to_line_deg=[angle_deg(-t1, y), angle_deg(-t2, -y)],
                   model_vs_true_contact_mm=[round(1e3 * float(np.linalg.norm(p1 - c1)), 1),
                                             round(1e3 * float(np.linalg.norm(p2 - c2)), 1)],
                   model_vs_true_normal_deg=[angle_deg(n1, t1), angle_deg(n2, t2)])
    com = true_com(scene_target)
    r = com - p
    perp = r - (r @ y) * y
    lo, hi = scene_target.aabb()
    out.update(mass_kg=round(float(scene_target.mass), 3),
               com_from_line_mm=round(1e3 * float(np.linalg.norm(perp)), 1),
               com_in_tcp_frame_mm=[round(1e3 * float(v), 1) for v in T[:3, :3].T @ r],
               tcp_below_true_top_mm=round(1e3 * float(hi[2] - p[2]), 1),
               tcp_above_true_bottom_mm=round(1e3 * float(p[2] - lo[2]), 1),
               gravity_torque_about_line_Nmm=round(1e3 * 9.81 * float(scene_target.mass)
                                                   * float(np.linalg.norm(np.cross(y, np.cross(perp, [0, 0, -1.0])))), 1),
               approach_down_deg=round(math.degrees(math.asin(float(np.clip(-T[2, 2], -1, 1)))), 1),
               closing_line_tilt_deg=round(math.degrees(math.asin(float(np.clip(abs(y[2]), 0, 1)))), 1),
               part_names=[q.name.split("/")[-1] + ":" + q.shape for q in scene_target.parts],
               category=scene_target.category)
    return out


class Recorder:
    """Wraps `grasp_exec._Monitor.check`: keeps the last finger-pad / target contacts per phase."""

    def __init__(self):
        self.last: dict = {}
        self.orig = grasp_exec._Monitor.check

    def __enter__(self):
        rec = self

        def check(mon, phase):
            rec.orig(mon, phase)
            sim, d = mon.sim, mon.sim.data
            f = np.zeros(6)
            rows = []
            for i in range(d.ncon):
                c = d.contact[i]
                g1, g2 = int(c.geom1), int(c.geom2)
                if not ({g1, g2} & mon.skip and {g1, g2} & sim._finger_geoms):
                    continue
                mujoco.mj_contactForce(sim.model, d, i, f)
                normal = np.array(c.frame[:3]) * (1.0 if g1 in sim._finger_geoms else -1.0)  # pad -> target
                rows.append((mon.world._geom_name(g1 if g1 in sim._finger_geoms else g2), np.array(c.pos),
                             normal, float(f[0]), float(np.linalg.norm(f[1:3])), float(c.dist)))
            rec.last[phase] = (rows, sim.body_pos(mon.world.scene.target.name),
                               d.xquat[sim.model.body(mon.world.scene.target.name).id].copy(), sim.finger_width)

        grasp_exec._Monitor.check = check
        return self

    def __exit__(self, *exc):
        grasp_exec._Monitor.check = self.orig


def physics(scene, sel, q_start) -> dict:
    world = World(scene)
    try:
        world.set_q(q_start, GRIPPER_MAX_WIDTH)
        with Recorder() as rec:
            o = grasp_exec.execute_grasp(world, sel, q_start)
    finally:
        world.close()
    T = sel.T_world_tcp
    y = T[:3, 1]
    out = {"failure": None if o.failure is None else o.failure.name, "lift_mm": round(1e3 * o.lift_height, 1),
           "hold_mm": round(1e3 * o.hold_height, 1), "finger_width_mm": round(1e3 * o.finger_width, 1),
           "selected_width_mm": round(1e3 * sel.width, 1),
           "collisions": [f"{c.phase}:{c.robot_geom}->{c.other_geom}" for c in o.collisions]}
    q0 = None
    for ph in ("transfer", "approach", "close", "lift", "hold"):
        if ph not in rec.last:
            continue
        rows, pos, quat, width = rec.last[ph]
        if q0 is None:
            q0 = quat
        tilt = 2 * math.degrees(math.acos(min(1.0, abs(float(np.dot(quat, q0))))))
        out[ph] = {"target_pos": [round(float(v), 4) for v in pos], "target_tilt_deg": round(tilt, 1),
                   "finger_width_mm": round(1e3 * width, 1),
                   "contacts": [{"pad": "left" if "left" in g else "right",
                                 "tcp_frame_mm": [round(1e3 * float(v), 1) for v in T[:3, :3].T @ (p - T[:3, 3])],
                                 "normal_to_line_deg": round(min(angle_deg(n, y), angle_deg(n, -y)), 1),
                                 "normal_N": round(fn, 2), "friction_N": round(ft, 2), "dist_mm": round(1e3 * dd, 2)}
                                for g, p, n, fn, ft, dd in rows]}
    return out


def current_inputs(box: dict, cand_set: dict | None = None):
    """The selection's config and proposer as the current code would make them: the default
    `GraspSelectConfig` (a capture pickles the config of its day) and the captured pinned
    hypotheses (INSPECT's, made by the proposer of that day) in front of a fresh
    `AntipodalProposer`; each pinned candidate's contacts are looked up among the model's
    points and re-scored with their edge cones when the config scores with them, and dropped
    at s = 0 or where the depth rules (`hand_volume.depth_keep`, each hand alone, at the depth
    INSPECT chose) drop it."""
    config = GraspSelectConfig()
    config = replace(config, candidates=replace(config.candidates, **(cand_set or {})))
    cc = config.candidates
    prop = box.get("proposer")
    fresh = AntipodalProposer(cc)
    if not isinstance(prop, PinnedProposer):
        return config, fresh
    pin, t = prop.pinned, box["target"]
    if len(pin) and cc.edge_angle is not None:
        _, i = cKDTree(t.points).query(pin.p1)
        _, j = cKDTree(t.points).query(pin.p2)
        ends = np.unique(np.concatenate([i, j]))
        cones = normal_cones(t.points, t.normals, ends, cc.edge_radius, cc.edge_k, cc.edge_angle)
        s = graspnet_score_cones(pin.p1, pin.p2, cones[np.searchsorted(ends, i)], cones[np.searchsorted(ends, j)])
        pin = GraspCandidates(pin.T_world_tcp, pin.width, s, pin.p1, pin.p2, pin.n1, pin.n2).take(np.nonzero(s > 0)[0])
    if len(pin):  # the depth rules on each pinned hand alone (its depth: the TCP past the contacts' midpoint)
        d = np.sum((pin.T_world_tcp[:, :3, 3] - 0.5 * (pin.p1 + pin.p2)) * pin.approach, axis=1)
        pin = pin.take(np.nonzero(depth_keep(t.points, pin.T_world_tcp, pin.width, d, np.arange(len(pin)), cc))[0])
    return config, PinnedProposer(fresh, pin)


def main() -> int:
    ap = capture_arguments(argparse.ArgumentParser())
    ap.add_argument("--current", action="store_true",
                    help="select with the current code's default config and proposer (`current_inputs`), "
                         "not the captured ones")
    ap.add_argument("--cand-set", nargs="*", default=[],
                    help="with --current: CandidateConfig field=value overrides (python literals)")
    args = ap.parse_args()
    cand_set = {k: ast.literal_eval(v) for k, v in (a.split("=", 1) for a in args.cand_set)}
    for level, index, box in read_captures(args.dir, args.only):
        scene = certified_scene(level, index, args.seed).scene
        world = World(scene)
        spheres = panda_sphere_model(world.robot)
        world.close()
        config, proposer = current_inputs(box, cand_set) if args.current else (box["config"], box.get("proposer"))
        sel = select_grasp(box["target"], box["occ"], box["task"], box["q"], spheres, config, box["rng"],
                           proposer=proposer, extra_safe=box["extra_safe"], fine_map=box.get("fine_map"))
        prims = PrimitiveSet.from_shapes(list(scene.target.parts))
        rec = {"level": level, "index": index, "model": model_error(box["target"], prims, scene.target)}
        if sel.failure is not None:
            rec["selection_failure"] = sel.failure.name
        else:
            rec.update(score=sel.score, lift_height=sel.lift_height, grasp=grasp_truth(sel, box["target"], prims,
                                                                                       scene.target),
                       physics=physics(scene, sel, box["q"]))
        print(json.dumps(rec), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
