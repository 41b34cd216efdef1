"""Grasp check precision: how many hand poses that are free in truth the grasp's hand check
accepts on the 1 cm map (split into 5 mm cells) versus with a 5 mm local grid near the target.

Per certified scene (levels 1-4, scene indices --start.., seed 0), the hand poses are the
certification's antipodal candidates (`sim.oracle.grasp_candidates`, GROUND TRUTH, read here
only), kept when the rigid hand (link 7, flange, hand, camera, open fingers; sphere model)
clears the scene's true geometry less the target at margin 0 -- the certificate's own test.
The scene's certified grasp (`oracle.find_grasp`) is counted separately. Two map sources:

* fully observed: the true geometry rasterised (GROUND TRUTH, this benchmark only) at 1 cm
  and at 5 mm in a box 0.2 m around the target: a voxel is occupied when the geometry holds
  one of its 4^3 sub-cube centres; the target's own voxels are free (a perfect carve). This
  isolates the resolution.
* depth (the method's data): the grasp-only harness's map and fine local map from the same
  depth frames (`sim.grasp_only`, as `compass run --grasp-only` builds them), with the
  target model's carve and the robot's way; the checks of `grasp.checks.GraspChecks`.

Each pose is checked with `grasp.checks.hand_clear` at the grasp (the first check of
`select_grasp`). Prints grasp.precision.* JSON lines (accepted / truth-free counts).
Run: `.venv/bin/python benchmarks/bench_grasp_precision.py [--count N] [--start I]`.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
from numba import njit

from compass_manip.bench.stats import emit_value, load_average
from compass_manip.grasp.checks import GraspChecks, hand_clear, rigid_hand_spheres
from compass_manip.grasp.field import checked_field
from compass_manip.grasp.select import GraspSelectConfig, base_volume_mask
from compass_manip.motion.primitives import primitives_distance
from compass_manip.robot.ik import PandaIK
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim import oracle
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from diag_grasp_certified import capture_inputs  # noqa: E402 (the harness's inputs to select_grasp)


@njit(cache=True)
def _occupied(origin, res, shape, prims, n_sub):
    """(nx,ny,nz) True where the geometry holds one of the voxel's n_sub^3 sub-cube centres
    (a board face on a voxel boundary does not mark the voxel beside it)."""
    out = np.zeros((shape[0], shape[1], shape[2]), np.bool_)
    h = 0.5 * math.sqrt(3.0) * res
    p = np.empty(3)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                p[0] = origin[0] + (i + 0.5) * res
                p[1] = origin[1] + (j + 0.5) * res
                p[2] = origin[2] + (k + 0.5) * res
                if primitives_distance(p, prims, -np.inf) > h:
                    continue
                for a in range(n_sub):
                    for b in range(n_sub):
                        for c in range(n_sub):
                            p[0] = origin[0] + (i + (a + 0.5) / n_sub) * res
                            p[1] = origin[1] + (j + (b + 0.5) / n_sub) * res
                            p[2] = origin[2] + (k + (c + 0.5) / n_sub) * res
                            if primitives_distance(p, prims, 0.0) < 0.0:
                                out[i, j, k] = True
                                break
                        if out[i, j, k]:
                            break
                    if out[i, j, k]:
                        break
    return out


def truth_free_poses(scene, spheres) -> tuple[np.ndarray, int | None]:
    """(M,4,4) candidate TCP poses whose rigid hand clears the true geometry (target
    excluded) at margin 0, and the index among them of the certified grasp (or None)."""
    prims = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    C, r = rigid_hand_spheres(spheres)
    poses = [T for T, _ in oracle.grasp_candidates(scene)]
    keep = []
    for T in poses:
        W = C @ T[:3, :3].T + T[:3, 3]
        keep.append(all(primitives_distance(W[k], prims, -np.inf) >= r[k] for k in range(len(r))))
    free = np.array([T for T, k in zip(poses, keep) if k]).reshape(-1, 4, 4)
    return free, keep


def fully_observed(scene, spheres, poses, u: int = 2) -> tuple[int, int]:
    """Accepted poses (1 cm split, 5 mm grid) on the truth-rasterised maps (module doc)."""
    prims = oracle.scene_obstacles(scene, exclude_target=True).arrays()
    tgt = np.array(scene.target.pos)
    res = 0.01
    origin = np.floor((tgt - 0.45) / res) * res
    shape = np.array([90, 90, 90])
    coarse = _occupied(origin, res, shape, prims, 4)
    a = np.array([25, 25, 25])
    b = np.array([65, 65, 65])  # the inner box: 0.2 m around the target
    fine = _occupied(origin + a * res, res / u, (b - a) * u, prims, 4)
    local = rigid_hand_spheres(spheres)
    f1 = checked_field(coarse, origin, res, a, b, u)
    f2 = checked_field(coarse, origin, res, a, b, u, fine)
    return int(hand_clear(f1, poses, local).sum()), int(hand_clear(f2, poses, local).sum())


def from_depth(scene, spheres, poses, seed: int) -> tuple[int, int] | None:
    """Accepted poses on the harness's depth maps without / with its fine local map."""
    box = capture_inputs(scene, seed)
    if not box:
        return None
    cfg = GraspSelectConfig()
    occ = box["occ"]
    cur = spheres.sphere_centers(box["q"][None])[0]
    extra = box["extra"] | base_volume_mask(spheres, occ)
    out = []
    for fine in (None, box["fine"]):
        ch = GraspChecks(occ, box["target"], spheres, PandaIK(spheres.kinematics), cfg,
                         (cur, spheres.radii + cfg.robot_clearance), extra, box["q"], fine_map=fine)
        out.append(int(hand_clear(ch.fine, poses, rigid_hand_spheres(spheres)).sum()))
    return out[0], out[1]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--count", type=int, default=1, help="scenes per level (default 1)")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-depth", action="store_true", help="only the fully observed maps")
    args = ap.parse_args()
    tot = {"free": 0, "full_1cm": 0, "full_fine": 0, "depth_1cm": 0, "depth_fine": 0, "depth_free": 0,
           "cert": 0, "cert_1cm": 0, "cert_fine": 0}
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            scene = certified_scene(level, index, args.seed).scene
            world = World(scene)
            try:
                spheres = panda_sphere_model(world.robot)
                poses, _ = truth_free_poses(scene, spheres)
                cert = oracle.find_grasp(world)
            finally:
                world.close()
            rec = {"level": level, "index": index, "truth_free_poses": len(poses)}
            if len(poses):
                c1, c2 = fully_observed(scene, spheres, poses)
                rec.update(full_1cm=c1, full_fine=c2)
                tot["free"] += len(poses)
                tot["full_1cm"] += c1
                tot["full_fine"] += c2
                if not args.no_depth:
                    d = from_depth(scene, spheres, poses, args.seed)
                    if d is not None:
                        rec.update(depth_1cm=d[0], depth_fine=d[1])
                        tot["depth_free"] += len(poses)
                        tot["depth_1cm"] += d[0]
                        tot["depth_fine"] += d[1]
            if cert is not None:
                c1, c2 = fully_observed(scene, spheres, cert.T_world_tcp[None])
                rec.update(certified_1cm=bool(c1), certified_fine=bool(c2))
                tot["cert"] += 1
                tot["cert_1cm"] += c1
                tot["cert_fine"] += c2
            print(json.dumps(rec), file=sys.stderr, flush=True)
    ctx = {"scenes": len(args.levels) * args.count, "load": load_average()}
    emit_value("grasp.precision.truth_free_poses", tot["free"], "poses", **ctx)
    emit_value("grasp.precision.accepted_full_1cm", tot["full_1cm"], "poses", **ctx)
    emit_value("grasp.precision.accepted_full_fine", tot["full_fine"], "poses", **ctx)
    emit_value("grasp.precision.certified_accepted_1cm", tot["cert_1cm"], "grasps", n=tot["cert"], **ctx)
    emit_value("grasp.precision.certified_accepted_fine", tot["cert_fine"], "grasps", n=tot["cert"], **ctx)
    if not args.no_depth:
        emit_value("grasp.precision.accepted_depth_1cm", tot["depth_1cm"], "poses", n=tot["depth_free"], **ctx)
        emit_value("grasp.precision.accepted_depth_fine", tot["depth_fine"], "poses", n=tot["depth_free"], **ctx)
    return 0


if __name__ == "__main__":
    sys.exit(main())
