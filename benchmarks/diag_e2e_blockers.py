"""Diagnosis (GROUND TRUTH, read here only): where the unknown voxels that block one method's
grasp lie, and what another method's trial knew of the same voxels at its GRASP.

Per scene each method's trial (the same code and config; `--methods compass ig`) runs up to
its first `select_grasp` call, whose inputs are captured and which is then run (its failure and
rejections printed). On the captured inputs (the grasp map, its fine map, the target model, the
robot's own space and the near-body assumption), as `diag_hand_rejections.diagnose`:

* hands: in-cone candidates rejected at the grasp (`HAND_IN_COLLISION`) whose rigid hand is
  free in truth: the unsafe 5 mm cells that block them;
* arms: hands that pass the hand checks, in the selection's order (up to `max_checked`),
  through the arm's checks; for `IK_IN_COLLISION` ones with an IK solution free in truth, the
  unsafe cells that block that solution's spheres (its first such solution).

The blocking cells (as 1 cm voxels of the grasp map) are split by kind (unknown free / unknown
obstacle in truth, seen occupied) and by region: `cabinet` (inside the confined space's box),
`opening` (up to 15 cm in front of it, within its y extent grown by 5 cm), `beside_base`
(farther back, |y - base y| >= 0.2 m), `front_base` (farther back, |y| < 0.2 m). Then for every
other method's capture, the same voxels on its map at its GRASP: seen free, seen occupied,
unknown but its own space (the way its arm moved, grown, and its start shell), unknown but
taken as free by the near-body assumption, or unknown and unsafe.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_e2e_blockers.py --seed 5151 --only 1:0,2:3`.
One JSON line per scene.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import sys
from collections import Counter

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import trial_variants
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import oracle
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World
from compass_manip.trial import grasp_stage, runner
from compass_manip.trial.config import TrialConfig
from compass_manip.trial.grasp_stage import assumed_unknown_free
from diag_grasp_certified import _dists, blocking_cells
from diag_hand_rejections import gt_free, hand_stage

REGIONS = ("cabinet", "opening", "beside_base", "front_base")


def capture(method: str, level: int, index: int, seed: int, config: TrialConfig) -> dict:
    """The trial's first select_grasp inputs (and its result, the selection run once)."""
    box: dict = {}
    orig_sel, orig_stage = grasp_stage.select_grasp, runner.run_grasp_stage

    def sel(target, occ, task, q, sph, cfg, rng, **kw):
        box.update(target=target, occ=copy.deepcopy(occ), task=task, q=np.array(q), config=cfg,
                   rng=copy.deepcopy(rng), spheres=sph, **kw)
        box["fine_map"] = copy.deepcopy(kw.get("fine_map"))
        box["result"] = orig_sel(target, occ, task, q, sph, cfg, rng, **kw)
        raise StopIteration

    def stage(world, occupancy, detection, *a, **k):
        box["T_world_cam"] = np.array(detection.T_world_cam)
        box["q_home"] = np.asarray(world.robot.q_home, float)
        return orig_stage(world, occupancy, detection, *a, **k)

    scanners, orig_scanner = [], runner.NearFieldScanner

    class Scanner(orig_scanner):  # kept to read its views and why it stopped
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            scanners.append(self)

    grasp_stage.select_grasp, runner.run_grasp_stage, runner.NearFieldScanner = sel, stage, Scanner
    try:
        run = runner.run_trial_full(runner.TrialSpec(method, level, index, 0, seed), config)
        box["no_grasp"] = None if run.result.failure is None else run.result.failure.name
    except StopIteration:
        pass
    finally:
        grasp_stage.select_grasp, runner.run_grasp_stage, runner.NearFieldScanner = orig_sel, orig_stage, orig_scanner
    if scanners:
        s = scanners[0]
        box["scan"] = {"views": s.views, "stopped": s.stopped, "gains": list(s.gains)}
        ins = getattr(s.then, "inspector", s.then)  # trial.grasp_looks.BaseLooks wraps INSPECT
        if ins is not None and hasattr(ins, "last"):
            box["inspect_last"] = {k: v for k, v in ins.last.items() if k != "optimistic_rejections"}
        if hasattr(s.then, "log"):
            box["looks"] = {"looks": s.then.looks, "returned": s.then.returned, "stopped": s.then.stopped,
                            "inner_calls": s.then.inner_calls, "log": s.then.log}
    return box


def regions(centres: np.ndarray, task) -> np.ndarray:
    """(N,) region names of world points (N,3) [m] (module doc)."""
    sp = task.space
    lo, hi = np.asarray(sp.interior_min), np.asarray(sp.interior_max)
    base = np.asarray(task.robot_base_pos, float)
    inside = np.all((centres >= lo) & (centres <= hi), axis=1)
    front = (centres[:, 0] >= lo[0] - 0.15) & (centres[:, 1] >= lo[1] - 0.05) & (centres[:, 1] <= hi[1] + 0.05)
    beside = np.abs(centres[:, 1] - base[1]) >= 0.2
    return np.where(inside, "cabinet", np.where(front, "opening", np.where(beside, "beside_base", "front_base")))


def blockers(box: dict, scene, rest, tgt, max_arm: int = 400) -> tuple[dict, np.ndarray, np.ndarray]:
    """(counts, blocking hand voxels (K,3), blocking arm voxels (L,3)) of one capture."""
    cfg, target, occ, q, fine = box["config"], box["target"], box["occ"], box["q"], box["fine_map"]
    spheres = box["spheres"]
    n, cands, ch, local, within, T, at, pre, lift = hand_stage(box, spheres, copy.deepcopy(box["rng"]))
    gt_at = gt_free(rest, T, local)
    C, r = local
    hand_cells = []
    for i in np.nonzero(~at & gt_at)[0]:
        c, _ = blocking_cells(ch.fine, C @ T[i][:3, :3].T + T[i][:3, 3], r)
        if len(c):
            hand_cells.append(c)
    gt = oracle.ground_truth_checker(scene, exclude_target=True)
    passed = np.nonzero(at & ~np.isnan(pre) & ~np.isnan(lift))[0]
    passed = passed[np.argsort(-cands.score[within[passed]], kind="stable")][:max_arm]
    arm, arm_cells = Counter(), []
    lift_clear = {h: ch.held_target_clear(h) for h in cfg.lift_heights}
    for i in passed:
        _, why = ch.check(T[i], q, pre[i], lift[i], lift_clear)
        arm[why or "ok"] += 1
        if why != "IK_IN_COLLISION":
            continue
        sol = ch.ik_first(T[i], q).solutions
        good = sol[gt.are_valid(sol)]
        if not len(good):
            continue
        arm["IK_IN_COLLISION:gt_free_solution"] += 1
        c, _ = blocking_cells(ch.fine, spheres.sphere_centers(good[:1])[0], spheres.radii)
        if len(c):
            arm_cells.append(c)
    counts = {"in_cone": int(len(within)), "hand_blocked": int((~at).sum()), "hand_blocked_gt_free": int((~at & gt_at).sum()),
              "hand_passed": int(len(passed)), "arm": dict(sorted(arm.items()))}

    def vox(cells):
        if not cells:
            return np.zeros((0, 3), np.int64)
        v = occ.world_to_voxel(np.vstack(cells))
        return np.unique(v[occ.in_grid(v)], axis=0)
    return counts, vox(hand_cells), vox(arm_cells)


def split(vox: np.ndarray, box: dict, scene, rest) -> dict:
    """Counts of blocking voxels by region and kind (on the capture's own map)."""
    occ = box["occ"]
    if not len(vox):
        return {}
    c = occ.voxel_to_world(vox)
    st = occ.state[tuple(vox.T)]
    d = _dists(np.ascontiguousarray(c), rest)
    kind = np.where(st == VoxelState.OCCUPIED, "occupied",
                    np.where(d <= occ.resolution, "unknown_obstacle", "unknown_free"))
    reg = regions(c, box["task"])
    out = Counter(f"{g}:{k}" for g, k in zip(reg, kind))
    return dict(sorted(out.items()))


def other_view(vox: np.ndarray, mine: dict, other: dict) -> dict:
    """What `other`'s capture knew of my unknown blocking voxels, by region."""
    if not len(vox):
        return {}
    vox = vox[mine["occ"].state[tuple(vox.T)] == VoxelState.UNKNOWN]
    occ = other["occ"]
    st = occ.state[tuple(vox.T)]
    near = other["assumed"][tuple(vox.T)]
    own = other["extra_safe"][tuple(vox.T)] & ~near
    cls = np.where(st == VoxelState.FREE, "seen_free", np.where(st == VoxelState.OCCUPIED, "seen_occupied",
                   np.where(own, "own", np.where(near, "near_body", "unknown"))))
    reg = regions(occ.voxel_to_world(vox), mine["task"])
    return dict(sorted(Counter(f"{g}:{k}" for g, k in zip(reg, cls)).items()))


def region_totals(box: dict) -> dict:
    """Per region: the capture's map voxels seen (free / occupied), its own space, near-body, unknown."""
    occ = box["occ"]
    c = occ.voxel_centers().reshape(-1, 3)
    reg = regions(c, box["task"]).reshape(occ.shape)
    base = np.asarray(box["task"].robot_base_pos, float)
    keep = (np.abs(c[:, 1] - base[1]) <= 0.6).reshape(occ.shape) & (c[:, 2] <= 1.15).reshape(occ.shape) \
        & (c[:, 0] >= base[0] - 0.35).reshape(occ.shape)  # Omega_safe's box
    st = occ.state
    near = box["assumed"]
    own = box["extra_safe"] & ~near
    out = {}
    for g in REGIONS:
        m = keep & (reg == g)
        unk = m & (st == VoxelState.UNKNOWN)
        out[g] = [int(np.count_nonzero(m & (st == VoxelState.FREE))), int(np.count_nonzero(m & (st == VoxelState.OCCUPIED))),
                  int(np.count_nonzero(unk & own)), int(np.count_nonzero(unk & near & ~own)),
                  int(np.count_nonzero(unk & ~own & ~near))]
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=5151)
    ap.add_argument("--only", required=True, help="comma-separated L:I pairs")
    ap.add_argument("--methods", nargs="+", default=["compass", "ig"])
    ap.add_argument("--variant", default="default")
    args = ap.parse_args()
    config = TrialConfig() if args.variant == "default" else getattr(trial_variants, args.variant + "_config")()
    for pair in args.only.split(","):
        level, index = (int(x) for x in pair.split(":"))
        scene = certified_scene(level, index, args.seed).scene
        world = World(scene)
        spheres = panda_sphere_model(world.robot)
        world.close()
        rest = oracle.scene_obstacles(scene, exclude_target=True).arrays()
        tgt = PrimitiveSet.from_shapes(list(scene.target.parts)).arrays()
        caps, recs = {}, {}
        for m in args.methods:
            box = capture(m, level, index, args.seed, config)
            rec = {"method": m}
            if "result" not in box:
                rec["no_selection"] = box.get("no_grasp")
                recs[m] = rec
                continue
            sel = box["result"]
            box["assumed"] = assumed_unknown_free(box["occ"], config.grasp, spheres, box["q_home"], box["task"], None)
            rec.update(select_failure=None if sel.failure is None else sel.failure.name,
                       rejections={k.name: v for k, v in sel.rejections.items() if v},
                       score=None if sel.failure is not None else round(float(sel.score), 2),
                       scan=box.get("scan"), inspect_last=box.get("inspect_last"), looks=box.get("looks"))
            counts, hv, av = blockers(box, scene, rest, tgt)
            box["hand_vox"], box["arm_vox"] = hv, av
            rec.update(counts, hand_voxels=split(hv, box, scene, rest), arm_voxels=split(av, box, scene, rest),
                       regions=region_totals(box))
            caps[m], recs[m] = box, rec
        for m, box in caps.items():
            for o, other in caps.items():
                if o != m:
                    recs[m][f"arm_voxels_on_{o}"] = other_view(box["arm_vox"], box, other)
                    recs[m][f"hand_voxels_on_{o}"] = other_view(box["hand_vox"], box, other)
        print(json.dumps({"level": level, "scene": index, "seed": args.seed, "methods": recs}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
