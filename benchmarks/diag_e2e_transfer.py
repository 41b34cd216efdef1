"""Diagnosis (GROUND TRUTH, read here only): what the trial's executed grasp manoeuvre swept
through, and whether a look the trial can reach would have seen it.

Per trial (COMPASS, the variant's config) the grasp stage's `execute_grasp` call is
intercepted: before it runs, the voxels of the grasp map that the arm's spheres (+9 mm, the
checker's bound) sweep along the transfer (q_current -> pre-grasp) and along the grasp's own
motions (pre-grasp -> grasp -> lift) are split by the map's state and the grasp stage's
rules (seen free, seen occupied, the robot's own space, taken as free by the near-body
assumption, the target's carve, other unknown), each with the number that is occupied in
truth (scene primitives, within the voxel's centre). For the near-body voxels of the
transfer, a `trial.verify.LookPlanner` view (the method's checker, as look before moving
plans) is planned and its frame rendered at the view's end configuration after the grasp
(ground truth is only read here): how many of them that one frame turns known, and how many
of those occupied. Then the grasp executes as in the trial; its collisions are printed.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_e2e_transfer.py --levels 3 --scenes 4 --seed 101`.
One JSON line per trial on stdout.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import trial_variants
from compass_manip.grasp.carve import target_carve
from compass_manip.mapping.observe import integrate_observation
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.groundtruth import inside_primitive
from compass_manip.trial import grasp_stage, runner
from compass_manip.trial.config import TrialConfig
from compass_manip.trial.grasp_stage import assumed_unknown_free, own_space
from compass_manip.trial.verify import LookPlanner, VerifyConfig, manoeuvre, swept_mask, transfer_path


def truth(scene, centres: np.ndarray) -> np.ndarray:
    """(N,) bool: voxel centres (N,3) [m] inside a scene primitive or below the floor (GROUND TRUTH)."""
    out = centres[:, 2] <= scene.floor_z
    for p in scene.all_primitives():
        out |= inside_primitive(p, centres)
    return out


def split(occ, mask, own, near, carve, scene) -> dict:
    """Counts of the swept mask's voxels by class, each as [n, n occupied in truth]."""
    state = occ.state
    classes = {"free": state == VoxelState.FREE, "occupied": state == VoxelState.OCCUPIED}
    unk = state == VoxelState.UNKNOWN
    classes["own"] = unk & own
    classes["near_body"] = unk & ~own & near
    classes["carve"] = unk & ~own & ~near & carve
    classes["unknown"] = unk & ~own & ~near & ~carve
    out = {}
    for k, m in classes.items():
        idx = np.argwhere(mask & m)
        gt = truth(scene, occ.voxel_to_world(idx)) if len(idx) else np.zeros(0, bool)
        out[k] = [int(len(idx)), int(gt.sum())]
    return out


def base_primitive_states(occ, near, own, scene) -> dict:
    """Per static primitive named base* (GROUND TRUTH): the map's voxels whose centres lie in
    it, as [seen occupied, seen free, unknown taken as free (near-body / own), unknown]."""
    out = {}
    idx = np.argwhere(np.ones(occ.shape, bool))
    centres = occ.voxel_to_world(idx)
    for p in scene.static_primitives():
        if not p.name.startswith("base"):
            continue
        v = idx[inside_primitive(p, centres)]
        if not len(v):
            continue
        st = occ.state[tuple(v.T)]
        unk = st == VoxelState.UNKNOWN
        taken = unk & (near[tuple(v.T)] | own[tuple(v.T)])
        out[p.name] = [int(np.count_nonzero(st == VoxelState.OCCUPIED)), int(np.count_nonzero(st == VoxelState.FREE)),
                       int(np.count_nonzero(taken)), int(np.count_nonzero(unk & ~taken))]
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="default")
    ap.add_argument("--levels", type=int, nargs="+", default=[3])
    ap.add_argument("--scenes", type=int, nargs="+", default=[4])
    ap.add_argument("--seed", type=int, default=101)
    args = ap.parse_args()
    config = TrialConfig() if args.variant == "default" else getattr(trial_variants, args.variant + "_config")()
    box: dict = {}
    orig_stage, orig_exec, orig_make = runner.run_grasp_stage, grasp_stage.execute_grasp, runner.make_method

    def make(*a, **k):
        box["method"] = m = orig_make(*a, **k)
        return m

    def stage(world, occupancy, detection, task, q, moved, cfg, rng, charge, **kw):
        box.update(world=world, occ=occupancy, task=task, moved=moved, cfg=cfg, kw=kw)
        return orig_stage(world, occupancy, detection, task, q, moved, cfg, rng, charge, **kw)

    def execute(world, sel, q, exec_cfg):
        occ, cfg, kw = box["occ"], box["cfg"], box["kw"]
        spheres = panda_sphere_model(world.robot)
        own = own_space(occ, spheres, box["moved"], cfg)
        if cfg.method_swept and kw.get("method_swept") is not None:
            own |= np.asarray(kw["method_swept"](), bool) & (occ.state != VoxelState.OCCUPIED)
        near = assumed_unknown_free(occ, cfg, spheres, np.asarray(world.robot.q_home), box["task"],
                                    kw.get("method_rules"))
        target = grasp_stage.build_target_model(
            np.asarray(box["points"]), box["cam"], box["task"].target, occ, cfg.target)
        carve = target_carve(occ, target, cfg.select.clearance)
        Qt, Qg = transfer_path(sel, 0.02), manoeuvre(sel, 0.02, transfer=False)
        mt, mg = swept_mask(occ, spheres, Qt, 0.009), swept_mask(occ, spheres, Qg, 0.009)
        rec = {"transfer": split(occ, mt, own, near, np.zeros_like(carve), world.scene),
               "grasp": split(occ, mg, own, near, carve, world.scene)}
        nb = np.argwhere(mt & (occ.state == VoxelState.UNKNOWN) & ~own & near)
        if len(nb):
            c = occ.voxel_to_world(nb)
            gt = truth(world.scene, c)
            base = np.asarray(world.robot.base_pos, float)
            rec["near_body_bbox_rel_base"] = [np.round(c.min(0) - base, 2).tolist(), np.round(c.max(0) - base, 2).tolist()]
            if gt.any():
                rec["near_body_truth_occ_bbox_rel_base"] = [np.round(c[gt].min(0) - base, 2).tolist(),
                                                           np.round(c[gt].max(0) - base, 2).tolist()]
            # which links sweep them
            names = []
            for b in range(len(spheres.link_names)):
                sub = spheres.body_index == b
                if not sub.any():
                    continue
                m = np.zeros(occ.shape, bool)
                from compass_manip.mapping.distance import mark_in_spheres
                C = np.ascontiguousarray(spheres.sphere_centers(Qt)[:, sub].reshape(-1, 3))
                mark_in_spheres(m, occ.grid_min, occ.resolution, C, np.tile(spheres.radii[sub] + 0.009, len(Qt)))
                k = int(np.count_nonzero(m[tuple(nb[gt].T)])) if gt.any() else 0
                if k:
                    names.append([spheres.link_names[b], k])
            rec["truth_occ_near_body_by_link"] = names
            looker = LookPlanner(box["method"].world, world.camera.K, world.robot.base_pos, VerifyConfig(),
                                 np.random.default_rng(7))
            p = looker(np.asarray(q), occ, c, box["moved"])
            rec["look"] = {"planned": p.planned, "path": p.path is not None, "gain": float(p.gain),
                           "n_valid": int(p.n_valid)}
            box["look_q"] = None if p.path is None else np.asarray(p.path)[-1]
            box["look_vox"], box["look_gt"] = nb, gt
        rec["base_primitives"] = base_primitive_states(occ, near, own, world.scene)
        box["occ_copy"] = copy.deepcopy(occ)
        box["rec"] = rec
        out = orig_exec(world, sel, q, exec_cfg)
        rec["exec"] = [f"{c.phase}:{c.robot_geom}->{c.other_geom}" for c in out.collisions] + \
            [None if out.failure is None else out.failure.name]
        if box.get("look_q") is not None:  # the look's frame (rendered after the grasp; the scene's walls are static)
            occ2 = box["occ_copy"]
            f = world.render(box["look_q"], t=0.0, rgb=False)
            integrate_observation(occ2, f.observation(), spheres, 1.5)
            st = occ2.state[tuple(box["look_vox"].T)]
            rec["look_seen"] = {"known": int(np.count_nonzero(st != VoxelState.UNKNOWN)),
                                "occupied": int(np.count_nonzero(st == VoxelState.OCCUPIED)),
                                "truth_occ_seen": int(np.count_nonzero((st != VoxelState.UNKNOWN) & box["look_gt"]))}
        return out

    orig_sg = grasp_stage.run_grasp_stage

    def stage_points(world, occupancy, detection, *a, **k):
        box["points"] = np.asarray(detection.points_world, float).reshape(-1, 3)
        box["cam"] = np.asarray(detection.T_world_cam)[:3, 3]
        return stage(world, occupancy, detection, *a, **k)

    runner.run_grasp_stage, grasp_stage.execute_grasp, runner.make_method = stage_points, execute, make
    try:
        for level in args.levels:
            for scene in args.scenes:
                box.clear()
                run = runner.run_trial_full(runner.TrialSpec("compass", level, scene, 0, args.seed), config)
                r, g = run.result, run.outcome.grasp
                print(json.dumps({"level": level, "scene": scene, "seed": args.seed, "success": r.success,
                                  "failure": None if r.failure is None else r.failure.name,
                                  "n_inspected": run.outcome.n_inspected,
                                  "rejections": None if g is None or g.selection is None else
                                  {k.name: v for k, v in g.selection.rejections.items()},
                                  **box.get("rec", {})}), flush=True)
    finally:
        runner.run_grasp_stage, grasp_stage.execute_grasp, runner.make_method = orig_sg, orig_exec, orig_make
    return 0


if __name__ == "__main__":
    sys.exit(main())
