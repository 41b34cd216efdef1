"""Diagnosis (GROUND TRUTH, read here only): the severe levels' GRASP end to end against the
grasp-only harness on the same scene.

Per scene (L:I pairs, one seed) the trial (`TrialConfig()` or a `trial_variants` entry) runs to
its end; its INSPECT steps (`GraspInspector.last` and the plan of every step), the near-field
scan's views and its first `select_grasp` call's inputs are kept. The harness
(`sim.grasp_only`, its defaults, INSPECT with the looks up, the escape and the view groups)
runs up to its selection with its INSPECT steps kept the same way. Both captures go through
`diag_severe.diagnose` (the on-neck hands: hand stage, arm stage, the blocking cells by map
state, truth and region in the target's frame: behind / before the rail, above the box, in
front, beside). Then the two maps are compared on the 1 cm voxels within `--radius` of the
trial's target model (per region: seen free / occupied / unknown on each map) and on the
trial's arm-blocking unknown voxels (free in truth): what the harness's map knew of them.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_sevt.py --seed 5151 --only 2:0,4:1`.
One JSON line per scene on stdout.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import pickle
import sys
import tempfile
from collections import Counter

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import diag_severe
import trial_variants
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.sim import grasp_only
from compass_manip.sim.certify import certified_scene
from compass_manip.trial import grasp_stage, grasp_views, runner
from compass_manip.trial.config import TrialConfig
from diag_hand_rejections import capture as harness_capture

STATES = {int(VoxelState.FREE): "free", int(VoxelState.OCCUPIED): "occ", int(VoxelState.UNKNOWN): "unk"}


class StepLog:
    """Patches `GraspInspector.__call__` to keep each step's summary (what it saw and planned)."""

    def __init__(self) -> None:
        self.steps: list[dict] = []
        self._orig = grasp_views.GraspInspector.__call__

    def __enter__(self):
        log, orig = self, self._orig

        def call(insp, q, det):
            p = orig(insp, q, det)
            rec = {k: v for k, v in insp.last.items() if k != "optimistic_rejections"}
            rec.update(planned=bool(p.planned), reached=p.path is not None, n_calls=int(getattr(p, "n_calls", 0)))
            rec["needed"] = sorted(rec.get("needed", []))[:6]
            log.steps.append(rec)
            return p
        grasp_views.GraspInspector.__call__ = call
        return self

    def __exit__(self, *exc):
        grasp_views.GraspInspector.__call__ = self._orig


def trial_capture(level: int, index: int, seed: int, config: TrialConfig) -> dict:
    """The trial run to its end; its first selection's inputs, INSPECT steps, scan, result."""
    box: dict = {}
    orig_sel = grasp_stage.select_grasp
    scanners, orig_scanner = [], runner.NearFieldScanner

    def sel(target, occ, task, q, sph, cfg, rng, **kw):
        first = "target" not in box
        if first:
            box.update(target=target, occ=copy.deepcopy(occ), task=task, q=np.array(q), config=cfg,
                       rng=copy.deepcopy(rng), extra_safe=np.array(kw["extra_safe"]),
                       fine_map=copy.deepcopy(kw.get("fine_map")))
        res = orig_sel(target, occ, task, q, sph, cfg, rng, **kw)
        if first:
            box["select_failure"] = None if res.failure is None else res.failure.name
            box["rejections"] = {k.name: v for k, v in res.rejections.items() if v}
        return res

    class Scanner(orig_scanner):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            scanners.append(self)

    grasp_stage.select_grasp, runner.NearFieldScanner = sel, Scanner
    try:
        with StepLog() as log:
            run = runner.run_trial_full(runner.TrialSpec("compass", level, index, 0, seed), config)
    finally:
        grasp_stage.select_grasp, runner.NearFieldScanner = orig_sel, orig_scanner
    r = run.result
    box["trial"] = {"success": r.success, "failure": None if r.failure is None else r.failure.name,
                    "found": r.found, "collisions": r.collisions, "n_inspected": run.outcome.n_inspected}
    box["inspect_steps"] = log.steps
    if scanners:
        s = scanners[0]
        box["scan"] = {"views": s.views, "stopped": s.stopped}
    return box


def compare_maps(trial: dict, harness: dict, frame, radius: float) -> dict:
    """Per region of the 1 cm voxels within radius [m] of the trial's target centre: 'trial
    state>harness state' counts."""
    occ_t, occ_h = trial["occ"], harness["occ"]
    c = occ_t.voxel_centers().reshape(-1, 3)
    centre = np.asarray(trial["target"].centre, float)
    keep = np.linalg.norm(c - centre, axis=1) <= radius
    c = c[keep]
    st_t = occ_t.state.reshape(-1)[keep]
    vh = occ_h.world_to_voxel(c)
    ok = occ_h.in_grid(vh)
    st_h = np.full(len(c), -1)
    st_h[ok] = occ_h.state[tuple(vh[ok].T)]
    reg = frame.region(c)
    out: dict = {}
    for g in np.unique(reg):
        m = reg == g
        cnt = Counter(f"{STATES.get(int(a), 'out')}>{STATES.get(int(b), 'out')}" for a, b in zip(st_t[m], st_h[m]))
        out[str(g)] = dict(sorted(cnt.items()))
    return out


def strip(box: dict) -> dict:
    return {k: box[k] for k in ("target", "occ", "task", "q", "config", "rng", "extra_safe", "fine_map",
                                "T_world_cam") if k in box}


def diagnose_capture(capture: dict, directory: str, level: int, index: int, args) -> dict:
    """`diag_severe.diagnose` on one captured selection, pickled into directory as it reads it."""
    os.makedirs(directory, exist_ok=True)
    with open(os.path.join(directory, f"L{level}_{index}.pkl"), "wb") as f:
        pickle.dump(strip(capture), f)
    return diag_severe.diagnose(level, index, args.seed, args.max_arm, directory)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=5151)
    ap.add_argument("--only", required=True, help="comma-separated L:I pairs")
    ap.add_argument("--variant", default="default")
    ap.add_argument("--max-arm", type=int, default=60)
    ap.add_argument("--radius", type=float, default=0.35)
    ap.add_argument("--no-harness", action="store_true")
    args = ap.parse_args()
    config = TrialConfig() if args.variant == "default" else getattr(trial_variants, args.variant + "_config")()
    tmp = tempfile.mkdtemp(prefix="diag_sevt_")
    for pair in args.only.split(","):
        level, index = (int(x) for x in pair.split(":"))
        rec: dict = {"level": level, "scene": index, "seed": args.seed, "variant": args.variant}
        t = trial_capture(level, index, args.seed, config)
        rec.update(trial=t["trial"], trial_inspect=t["inspect_steps"], trial_scan=t.get("scan"),
                   trial_select_failure=t.get("select_failure"),
                   trial_rejections=t.get("rejections"))
        frame = diag_severe.Frame(certified_scene(level, index, args.seed).scene)
        if "target" in t:
            rec["trial_diag"] = diagnose_capture(t, os.path.join(tmp, "trial"), level, index, args)
        if not args.no_harness:
            with StepLog() as log:
                h = harness_capture(certified_scene(level, index, args.seed).scene, args.seed)
            rec["harness_inspect"] = log.steps
            if "target" in h:
                rec["harness_diag"] = diagnose_capture(h, os.path.join(tmp, "harness"), level, index, args)
                if "target" in t:
                    rec["maps"] = compare_maps(t, h, frame, args.radius)
        print(json.dumps(rec, default=lambda o: o.item() if hasattr(o, "item") else str(o)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
