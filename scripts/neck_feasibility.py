"""Feasibility of the severe layout "a tall target behind a low wide box, grasped
horizontally over it" on hand-built scenes (a measurement, not a test; docs/scenes.md,
"Third attempt").

A cabinet 0.32 m deep with its opening at x = 0.43 m and one shelf; the target (a tall
narrow box, or with --cat bottle a bottle whose neck is --neck m long) in the bottom storey
(floor z = 0.27 m), a box (the occluder) `gap` m in front of it, its top `dh` m below the
target's top; an optional face-frame rail under the shelf. Per variant: best visibility over
the reference fixed-view set (3 x 3 grid | FV baseline's views), the best view of a scan of
poses aimed at the target (from 10 cm outside the opening to 10 cm before the target), with
--stages how far each grasp candidate gets per approach pitch, and the certificate (grasp,
views, paths, physics). The bottle's neck radius and mass come from the environment
variables NECK_R [m] (default 0.013) and MASS [kg] (default 0.2).

  python scripts/neck_feasibility.py --grid H:H_T:DH:W_O:D_O:GAP:X_T:RAIL [--cat box|bottle]
  (each field a comma-separated list; every combination is one variant)
"""
from __future__ import annotations

import argparse
import itertools
import os
import time
from collections import Counter

import numpy as np

from compass_manip.geometry import look_at
from compass_manip.sim import oracle
from compass_manip.sim.certify import CertifyConfig, certify
from compass_manip.sim.objects import build_object
from compass_manip.sim.scenes import CabinetSpec, SceneSpec
from compass_manip.sim.world import World


NECK_R = float(os.environ.get("NECK_R", "0.013"))
MASS = float(os.environ.get("MASS", "0.2"))


def build(H, h_t, dh, w_o, d_o, gap, x_t, rail, cat="box", y_t=0.0, neck=0.065):
    x0, depth, y0, y1, z0 = 0.43, 0.32, -0.32, 0.32, 0.27
    shelf = z0 + H + 0.02
    cab = CabinetSpec((x0, y0, z0), (x0 + depth, y1, shelf + 0.28), (0.04, 0.04, 0.04, 0.0), (shelf,), (),
                      rail=rail)
    if cat == "box":
        t = build_object("target", "box", "red", (0.05, 0.05, h_t), 0.15, x_t, y_t, z0, 0.0, "target")
        r_t = 0.025
    else:
        t = build_object("target", "bottle", "red", (0.032, h_t - neck, NECK_R, neck), MASS, x_t, y_t, z0, 0.0,
                         "target")
        r_t = 0.032
    occ = build_object("occ1", "box", "blue", (d_o, w_o, h_t - dh), 0.4, x_t - r_t - gap - d_o / 2, y_t,
                       z0, 0.0, "occluder")
    dec = build_object("dec1", "cereal_box", "green", (0.06, 0.18, 0.18), 0.4, 0.65, 0.22, shelf, 0.3, "decoy")
    cd = build_object("cd1", "book", "red", (0.03, 0.15, 0.16), 0.3, 0.62, -0.22, shelf, 0.0, "colour_distractor")
    sd = build_object("sd1", t.category, "blue", (0.05, 0.05, 0.12) if cat == "box" else (0.03, 0.1, 0.012, 0.04),
                      0.2, 0.55, 0.24, z0, 0.0, "shape_distractor")
    return SceneSpec(level=2, index=0, seed=(9, 2, 0, 0), cabinet=cab, target=t, clutter=(occ, dec, cd, sd),
                     extra={})


def inside_best(world, scene):
    lo, _ = scene.cabinet.opening()
    t = np.asarray(scene.target.pos, float)
    zf, zc = scene.cabinet.rows()[0]
    best = (0.0, None)
    for x in np.arange(lo[0] - 0.10, t[0] - 0.10, 0.03):
        for z in np.arange(zf + 0.10, zc - 0.02, 0.03):
            for y in (t[1] - 0.15, t[1] - 0.08, t[1], t[1] + 0.08, t[1] + 0.15):
                v = world.visibility_from(look_at(np.array([x, y, z]), t), stride=3, with_robot=False)
                if v > best[0]:
                    best = (v, f"x={x:.2f} y={y:+.2f} z={z:.2f}")
    return best


def grasp_stages(world, scene) -> Counter:
    ik = oracle.robot_ik(world.robot)
    full = oracle.ground_truth_checker(scene)
    nt = oracle.ground_truth_checker(scene, exclude_target=True)
    home = np.asarray(world.robot.q_home)
    stat = Counter()
    for T, deg in oracle.grasp_candidates(scene):
        sols = oracle.grasp_solutions(ik, T, home, 12)
        ok = nt.are_valid(sols) if len(sols) else np.zeros(0, bool)
        if len(sols) == 0:
            stat[(int(deg), "noik")] += 1
        elif not ok.any():
            stat[(int(deg), "coll")] += 1
        else:
            g = oracle.first_valid_grasp(ik, T, sols, full, nt, world)
            stat[(int(deg), "OK" if g is not None else "pre/lift")] += 1
    return stat


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--grid", default="0.33:0.24:0.06:0.24:0.05:0.03:0.62:0.0")
    ap.add_argument("--cat", default="box")
    ap.add_argument("--neck", type=float, default=0.065, help="bottle neck height [m]")
    ap.add_argument("--no-certify", action="store_true")
    ap.add_argument("--stages", action="store_true")
    a = ap.parse_args()
    axes = [[float(v) for v in s.split(",")] for s in a.grid.split(":")]
    cfg = CertifyConfig()
    for H, h_t, dh, w_o, d_o, gap, x_t, rail in itertools.product(*axes):
        scene = build(H, h_t, dh, w_o, d_o, gap, x_t, rail, a.cat, neck=a.neck)
        w = World(scene)
        fv = oracle.fixed_view_visibilities(w)
        ib = inside_best(w, scene)
        line = (f"H={H:.2f} h_t={h_t:.2f} dh={dh:.3f} w_o={w_o:.2f} d_o={d_o:.2f} gap={gap:.2f} x_t={x_t:.2f} "
                f"rail={rail:.2f}: FV grid {max(fv[:9]):.2f} base {max(fv[9:]):.2f} | inside {ib[0]:.2f} ({ib[1]})")
        if a.stages:
            st = grasp_stages(w, scene)
            line += " | " + " ".join(f"{k[0]}{k[1]}:{n}" for k, n in sorted(st.items()))
        if not a.no_certify:
            t0 = time.perf_counter()
            c = certify(scene, cfg, w)
            line += (f" | cert {c.failure.name if c.failure else 'OK'} start {c.start_visibility:.2f} "
                     f"grasp {c.grasp_approach_deg}/{c.grasp_yaw_deg} view {c.best_view_visibility:.2f} "
                     f"vvf {c.view_visibility_fraction:.2f} lift {c.lift_height:.3f} t {time.perf_counter() - t0:.1f}s")
        w.close()
        print(line, flush=True)


if __name__ == "__main__":
    main()
