"""Diagnosis: why a selected grasp does (not) lift in physics, and whether the certified
grasp of the same scene lifts with `execute_grasp`.

Per certified scene (levels, indices --start..; seed 0) the grasp-only harness runs as in
`bench_grasp.py --variants on`; its execution's phase trace (`GraspOutcome.phases`: the
target's displacement and the pads touching it after the transfer, approach, close, lift,
hold) is printed with GROUND TRUTH about the selected grasp (read here only, from the scene's
primitives): the part the closing line crosses at the TCP's height, the chord it cuts there
against the selected width, the line's distance from the part's axis, the TCP below the
target's top, and the approach's and closing line's angles to the horizontal. Then the
certificate's own grasp (view -> pre-grasp -> grasp -> lift) is executed with
`execute_grasp` (lift 4 cm, as certified).

Prints one JSON line per scene. Run:
`.venv/bin/python benchmarks/diag_grasp_exec.py [--start 5 --count 3] [--levels 1 2 3 4]`.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from types import SimpleNamespace

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.sim.certify import certified_scene
from compass_manip.sim.grasp_exec import execute_grasp
from compass_manip.sim.grasp_only import GraspOnlyConfig, run_grasp_only
from compass_manip.sim.world import World


def grasp_geometry(scene, T_world_tcp: np.ndarray, width: float) -> dict:
    """GROUND TRUTH: the selected grasp against the target's upright primitives [mm, deg]."""
    parts = scene.target.parts
    p, y, z = T_world_tcp[:3, 3], T_world_tcp[:3, 1], T_world_tcp[:3, 2]
    top = max(q.pos[2] + (q.size[2] if q.shape == "box" else q.size[-1]) for q in parts)
    part = next((q for q in parts if q.shape == "cylinder" and abs(p[2] - q.pos[2]) <= q.size[1]), None)
    out = {"width_selected_mm": round(1e3 * width, 1), "tcp_below_top_mm": round(1e3 * (top - p[2]), 1),
           "approach_down_deg": round(math.degrees(math.asin(float(np.clip(-z[2], -1, 1)))), 1),
           "closing_line_tilt_deg": round(math.degrees(math.asin(float(np.clip(abs(y[2]), 0, 1)))), 1)}
    if part is not None:  # the horizontal closing line's distance from the axis and the chord there
        yh = y[:2] / max(float(np.linalg.norm(y[:2])), 1e-9)
        d = p[:2] - np.asarray(part.pos[:2])
        off = abs(d[0] * yh[1] - d[1] * yh[0])
        r = part.size[0]
        out.update(part=part.name.split("/")[-1], diameter_mm=round(2e3 * r, 1), off_axis_mm=round(1e3 * off, 1),
                   chord_mm=round(2e3 * math.sqrt(max(r * r - off * off, 0.0)), 1))
    return out


def certified_grasp_outcome(cs) -> dict:
    """The certificate's grasp executed with `execute_grasp` (view -> pre-grasp -> grasp -> lift)."""
    P = np.asarray(cs.certificate.path)
    v, pg, g, lf = cs.certificate.path_marks
    sel = SimpleNamespace(failure=None, path=P[v:pg + 1], q_pregrasp=P[pg], q_grasp=P[g], q_lift=P[lf],
                          lift_height=0.04)
    world = World(cs.scene)
    try:
        o = execute_grasp(world, sel)
    finally:
        world.close()
    return {"failure": o.failure.name if o.failure else None, "lift_m": round(o.lift_height, 4),
            "hold_m": round(o.hold_height, 4), "certificate_lift_m": round(cs.certificate.lift_height, 4)}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--count", type=int, default=2)
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            cs = certified_scene(level, index, args.seed)
            r = run_grasp_only(cs.scene, GraspOnlyConfig(), seed=args.seed)
            s, o = r.selection, r.outcome
            rec = {"level": level, "index": index, "target": cs.scene.target.category,
                   "mass_kg": round(cs.scene.target.mass, 3),
                   "selection_failure": None if s is None or s.failure is None else s.failure.name}
            if s is not None and s.failure is None:
                rec.update(score=s.score, commanded_lift_m=s.lift_height,
                           exec_failure=o.failure.name if o.failure else None,
                           lift_m=round(o.lift_height, 4), hold_m=round(o.hold_height, 4),
                           finger_width_mm=round(1e3 * o.finger_width, 1),
                           collisions=[f"{c.phase}:{c.robot_geom}->{c.other_geom}" for c in o.collisions],
                           phases=[{"phase": p.phase, "moved_mm": round(1e3 * p.moved, 1), "pads": p.pads,
                                    "touched_by": list(p.touched_by)} for p in o.phases],
                           **grasp_geometry(cs.scene, s.T_world_tcp, s.width))
            rec["certified_grasp"] = certified_grasp_outcome(cs)
            print(json.dumps(rec), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
