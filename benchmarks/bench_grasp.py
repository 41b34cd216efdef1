"""Grasping benchmark: grasp-only trials over certified scenes, constraints on and off.

Per scene (level L, index i, seed 0): the grasp-only harness (`sim.grasp_only`: oracle start
view and oracle segmentation detection, map from depth, `grasp.select.select_grasp`,
physics grasp-and-lift with `sim.grasp_exec`) runs once with the paper's constraints and
once without (each after the trial's grasp-aware INSPECT views, `--inspect-views 0`: none). Prints JSON lines (grasp.*) and, with --out, one JSON line per trial.

Run: `.venv/bin/python benchmarks/bench_grasp.py [--count N] [--levels 1 2 3 4] [--out f.jsonl]`.
`make bench` runs the default: scene indices 0-1 of each level (8 scenes), constraints on
and off, a few minutes. Figures: grasp.select_ms (selection = candidates + constraints +
the path to the pre-grasp, constraints on; median / p90 [ms]), grasp.only_success_rate (on
that fixed set, constraints on), the side-by-side on/off success and collision counts, and
the selected grasps that failed in physics by reason (grasp.exec_failures.*).
The numbers in docs/grasping.md and docs/grasping_log.md name their own --start/--count.
"""
from __future__ import annotations

import argparse
import ast
import json
import os
import sys
import time
import contextlib
import copy
import pickle
from dataclasses import replace

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.bench.stats import emit_samples, emit_value, load_average
from compass_manip.grasp.candidates import DEEP_EDGE, AntipodalProposer, CandidateConfig, propose_in_cone
from compass_manip.grasp.select import GraspSelectConfig, desired_approach
from compass_manip.sim.certify import certified_scene
from compass_manip.mapping.occupancy import MapConfig
from compass_manip.motion.planner import PlannerConfig
from compass_manip.sim import grasp_only
from compass_manip.sim.grasp_only import GraspOnlyConfig, run_grasp_only
from compass_manip.sim.near_field import WIDE_SCAN
from compass_manip.sim.oracle import NECK_MIN_HEIGHT


def neck_of(scene) -> tuple[np.ndarray, float, float, float] | None:
    """Ground truth (the scene's spec, for this benchmark only): the target bottle's neck where
    the oracle has neck candidates (`sim.oracle.grasp_candidates`: at least NECK_MIN_HEIGHT
    long), as (axis xy (2,), radius, z bottom, z top) [m], else None."""
    tgt = scene.target
    if tgt.category != "bottle" or len(tgt.parts) < 2 or 2 * tgt.parts[1].half_extents[2] < NECK_MIN_HEIGHT - 1e-9:
        return None
    neck = tgt.parts[1]
    h = np.asarray(neck.half_extents, dtype=np.float64)
    return np.asarray(neck.pos[:2], dtype=np.float64), float(h[0]), float(neck.pos[2] - h[2]), float(neck.pos[2] + h[2])
from compass_manip.trial.inspect import InspectConfig


def neck_stats(scene, r, seed: int) -> dict | None:
    """For a target bottle with a graspable neck (ground truth: `sim.oracle.neck_of`): of the
    in-cone candidates the selection's proposer makes on the harness's target model (its own
    generator), how many close on the neck (TCP within the neck's height and 1 cm of its
    radius from its axis) with an approach within 15 deg of horizontal, and whether the
    selected grasp is such a one."""
    neck = neck_of(scene)
    if neck is None or r.target is None or r.selection is None:
        return None
    xy, radius, z0, z1 = neck
    target, cfg = r.target, GraspSelectConfig()
    n = desired_approach(target, scene.task())
    cands = propose_in_cone(AntipodalProposer(cfg.candidates), target, np.random.default_rng([seed, 77]), n,
                            cfg.max_approach_angle)

    def on_neck(T):
        p, z = T[..., :3, 3], T[..., :3, 2]
        return ((p[..., 2] >= z0) & (p[..., 2] <= z1) & (np.linalg.norm(p[..., :2] - xy, axis=-1) <= radius + 0.01)
                & (np.abs(z[..., 2]) <= np.sin(np.radians(15.0))))

    s = r.selection
    return {"candidates": len(cands), "on_neck_horizontal": int(np.count_nonzero(on_neck(cands.T_world_tcp))),
            "selected_on_neck": None if s.T_world_tcp is None else bool(on_neck(s.T_world_tcp))}


def trial_record(level: int, index: int, constrained: bool, r, wall: float, neck: dict | None = None) -> dict:
    return {"level": level, "index": index, "constrained": constrained, **r.to_dict(), "wall_s": round(wall, 2),
            "neck": neck}


@contextlib.contextmanager
def capturing(directory: str | None, level: int, index: int):
    """With a directory: the harness's `select_grasp` inputs are pickled there (then the
    selection runs as usual)."""
    if directory is None:
        yield
        return
    orig = grasp_only.select_grasp

    def sel(target, occ, task, q, sph, config, rng, **kw):
        os.makedirs(directory, exist_ok=True)
        with open(os.path.join(directory, f"L{level}_{index}.pkl"), "wb") as f:
            pickle.dump(dict(target=target, occ=occ, task=task, q=q, config=config, rng=copy.deepcopy(rng), **kw), f)
        return orig(target, occ, task, q, sph, config, rng, **kw)

    grasp_only.select_grasp = sel
    try:
        yield
    finally:
        grasp_only.select_grasp = orig


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--count", type=int, default=2, help="scenes per level (default 2)")
    ap.add_argument("--start", type=int, default=0, help="first scene index (default 0)")
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="append one JSON line per trial to this file")
    ap.add_argument("--variants", default="on,off", help="on, off or on,off")
    ap.add_argument("--no-fine-map", action="store_true", help="check near the target on the 1 cm map only")
    ap.add_argument("--inspect-views", type=int, default=None,
                    help="grasp-aware INSPECT views before the selection (default: InspectConfig's; 0: off)")
    ap.add_argument("--no-near-scan", action="store_true",
                    help="no greedy near-field scan (sim.near_field); the old harness's map")
    ap.add_argument("--wide-scan", action="store_true",
                    help="the wider near-field scan (sim.near_field.WIDE_SCAN: joint 1 within +-2.2 rad)")
    ap.add_argument("--octomap-rule", action="store_true",
                    help="the map with OctoMap's update rule (no surface guard, no sticky hits)")
    ap.add_argument("--near-body-free", action="store_true",
                    help="take the unknown space links 0-4 sweep near home as free (the old assumption)")
    ap.add_argument("--min-visibility", type=float, default=None,
                    help="the oracle start's minimum target visibility (default GraspOnlyConfig's, 0.15)")
    ap.add_argument("--plan-budget", type=float, default=None,
                    help="a wall-clock planner budget per call [s] for the selection and INSPECT instead of "
                         "their configs' edge-check budget (max_checks); outcomes then depend on the load")
    ap.add_argument("--capture", default=None,
                    help="also pickle each constrained selection's inputs to DIR/L{level}_{index}.pkl "
                         "(the format of capture_select_inputs.py, for replay_select.py)")
    ap.add_argument("--inspect-set", nargs="*", default=[],
                    help="InspectConfig field=value overrides (python literals), e.g. n_up=0 escape=False")
    ap.add_argument("--select-set", nargs="*", default=[],
                    help="GraspSelectConfig field=value overrides (python literals; PlannerConfig(...) allowed), e.g. "
                         "max_failed_plans=6 'planner=PlannerConfig()' (main's budget before branch gmod); "
                         "'candidates=CandidateConfig(**DEEP_EDGE)' (branch gdeep's depth samples and edge cones)")
    args = ap.parse_args()
    inspect = InspectConfig() if args.inspect_views is None else InspectConfig(n_views=args.inspect_views)
    inspect = replace(inspect, **{k: ast.literal_eval(v) for k, v in (s.split("=", 1) for s in args.inspect_set)})
    if args.plan_budget is not None:
        inspect = replace(inspect, planner=replace(inspect.planner, time_budget=args.plan_budget, max_checks=None))
    variants = [v == "on" for v in args.variants.split(",")]
    recs = []
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            scene = certified_scene(level, index, args.seed).scene
            for constrained in variants:
                select = GraspSelectConfig(constrained=constrained)
                select = replace(select, **{k: eval(v, {"PlannerConfig": PlannerConfig,  # noqa: S307 (a bench flag)
                                                        "CandidateConfig": CandidateConfig, "DEEP_EDGE": DEEP_EDGE})
                                            for k, v in (a.split("=", 1) for a in args.select_set)})
                if args.plan_budget is not None:
                    select = replace(select, planner=replace(select.planner, time_budget=args.plan_budget, max_checks=None))
                config = GraspOnlyConfig(select=select, fine_map=not args.no_fine_map,
                                         inspect=inspect, near_body_free=args.near_body_free,
                                         **({} if args.min_visibility is None
                                            else {"min_visibility": args.min_visibility}),
                                         map=MapConfig(surface_guard=False, sticky_hits=0) if args.octomap_rule
                                         else MapConfig(),
                                         **({"near_field_scan": None} if args.no_near_scan
                                            else {"near_field_scan": WIDE_SCAN} if args.wide_scan else {}))
                t0 = time.perf_counter()
                with capturing(args.capture if constrained else None, level, index):
                    r = run_grasp_only(scene, config, seed=args.seed)
                wall = time.perf_counter() - t0
                rec = trial_record(level, index, constrained, r, wall, neck_stats(scene, r, args.seed))
                recs.append(rec)
                print(json.dumps(rec), file=sys.stderr, flush=True)
                if args.out:
                    with open(args.out, "a") as f:
                        f.write(json.dumps(rec) + "\n")
    summarize(recs, len(args.levels) * args.count)
    return 0


def summarize(recs: list[dict], n_scenes: int) -> None:
    ctx = {"scenes": n_scenes, "load": load_average()}
    on = [r for r in recs if r["constrained"] is True]
    if on:
        emit_value("grasp.only_success_rate", sum(r["success"] for r in on) / len(on), "fraction", n=len(on), **ctx)
        emit_samples("grasp.select_ms", [1e3 * r["select_time_s"] for r in on if r["select_time_s"] is not None],
                     "ms", **ctx)
    for constrained, tag in ((True, "on"), (False, "off")):
        rs = [r for r in recs if r["constrained"] is constrained]
        if not rs:
            continue
        n = len(rs)
        emit_value(f"grasp.success_rate.constraints_{tag}", sum(r["success"] for r in rs) / n, "fraction", n=n, **ctx)
        emit_value(f"grasp.collision_trials.constraints_{tag}", sum(bool(r["collisions"]) for r in rs), "trials",
                   n=n, **ctx)
        failed = [r["exec_failure"] for r in rs if r["selection_failure"] is None and r["exec_failure"] is not None]
        emit_value(f"grasp.exec_failures.constraints_{tag}", len(failed), "trials", n=n,
                   by_reason={k: failed.count(k) for k in sorted(set(failed))}, **ctx)
        sel = [r for r in rs if r["select_time_s"] is not None]
        emit_samples(f"grasp.select_time.constraints_{tag}", [1e3 * r["select_time_s"] for r in sel], "ms", **ctx)
        ok = [r["gpq"] for r in rs if r["selection_failure"] is None and r["gpq"] is not None]
        if ok:
            emit_value(f"grasp.gpq_mean.constraints_{tag}", float(np.mean(ok)), "gpq", n=len(ok), **ctx)


if __name__ == "__main__":
    sys.exit(main())
