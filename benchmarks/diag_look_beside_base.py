"""Diagnosis (GROUND TRUTH, read here only): after COMPASS's near-field scan, can any
configuration valid for the method's own checker point the wrist camera at the space beside
the base where a low horizontal grasp puts the elbow?

COMPASS's method is built as the trial builds it, the home frame observed, then the NFA run
decision by decision (four frames along each view's path, as the trial's 3 Hz frames do
roughly). Then, per side of the base (y < 0 and y > 0) and per look point (where the elbow
of a low grasp stands: x 0-0.2 m, |y| 0.22-0.25 m, z 0.45-0.6 m from the base), camera
configurations looking at it from 0.3 / 0.45 / 0.6 m (`robot.ik.ik_look_at`, 48 directions
within 150 deg of straight down, 4 rolls, 6 q7 samples) are counted: IK solutions, those valid
for the method's checker (`WorldModel.checker`: unknown space inside Omega_safe unsafe), and
for the valid ones the most sampled points of each base primitive (ground truth) in their
frustum. Second, `--probe`: where the elbow stands for horizontal grasps ahead of the base
(IK of a TCP pose approaching along +x), the least twisted solution's joints 1 and 3 and its
elbow (link 4's spheres' centre) relative to the base.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_look_beside_base.py --seed 7777 --level 3 --scene 5 [--probe]`.
"""
from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from compass_manip.exploration.base import Phase  # noqa: E402
from compass_manip.robot.ik import PandaIK, ik_look_at  # noqa: E402
from compass_manip.robot.model import RobotConfig  # noqa: E402
from compass_manip.robot.spheres import Q_HOME, panda_sphere_model  # noqa: E402
from compass_manip.sim.certify import certified_scene  # noqa: E402
from compass_manip.sim.world import World  # noqa: E402
from compass_manip.trial.config import TrialConfig  # noqa: E402
from compass_manip.trial.inspect import frustum_mask  # noqa: E402
from diag_nfa_near_field import method_at_home  # noqa: E402

LOOK_POINTS = ((0.05, 0.25, 0.5), (0.2, 0.25, 0.45), (-0.05, 0.22, 0.6))


def probe_elbow() -> None:
    """Horizontal grasps ahead of the base: the least twisted IK solution and its elbow."""
    rc = RobotConfig()
    ik, sp = PandaIK(), panda_sphere_model(rc)
    link4 = [i for i, b in enumerate(sp.body_index) if sp.link_names[b] == "panda_link4"]
    base = np.asarray(rc.base_pos, float)
    for x, z in ((0.55, 0.25), (0.6, 0.45), (0.75, 0.6)):
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2] = (0, 0, -1), (0, 1, 0), (1, 0, 0)
        T[:3, 3] = base + (x, 0.0, z)
        r = ik.solve(T, "tcp", Q_HOME, 17, None)
        if not r.success:
            print(f"TCP at x {x} z {z} m, approach +x: no IK")
            continue
        S = np.asarray(r.solutions)
        elbow = sp.sphere_centers(S)[:, link4].mean(1) - base
        k = int(np.argmin(np.abs(S[:, 0]) + np.abs(S[:, 2])))
        print(f"TCP at x {x} z {z} m, approach +x: {len(S)} solutions; least twisted q1 {S[k, 0]:.2f} q3 {S[k, 2]:.2f} "
              f"rad, its elbow y {elbow[k, 1]:+.2f} z {elbow[k, 2]:.2f} m; |elbow y| {np.abs(elbow[:, 1]).min():.2f}"
              f"-{np.abs(elbow[:, 1]).max():.2f} m over all")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=7777)
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--scene", type=int, default=5)
    ap.add_argument("--probe", action="store_true", help="also print the elbow of horizontal grasps ahead")
    args = ap.parse_args()
    if args.probe:
        probe_elbow()
    scene = certified_scene(args.level, args.scene, args.seed).scene
    world, cfg = World(scene), TrialConfig()
    q0 = np.asarray(world.robot.q_home, float)
    method, prims, points = method_at_home(world, scene, cfg)
    method.observe(world.render(q0, rgb=False, seg=False).observation())
    q = q0
    for _ in range(cfg.method.nfa.max_views + 1):
        d = method.decide()
        if d.path is None or d.phase != Phase.NFA:
            break
        path = np.asarray(d.path)
        method.executed(path)
        for qq in path[:: max(1, len(path) // 4)]:
            method.observe(world.render(qq, rgb=False, seg=False).observation())
        q = path[-1]
    checker, K = method.world.checker, world.camera.K
    rng = np.random.default_rng(0)
    base = np.asarray(world.robot.base_pos, float)
    print(f"seed {args.seed} level {args.level} scene {args.scene}; base primitives {[p.name for p in prims]}")
    for side in (-1, 1):
        for pt in LOOK_POINTS:
            p = base + np.asarray(pt) * (1, side, 1)
            n_ik = n_valid = 0
            seen: dict = {}
            for dist in (0.3, 0.45, 0.6):
                r = ik_look_at(p, dist, q, rng, n_samples=48, max_polar_deg=150.0, n_q7=6)
                if not r.success:
                    continue
                S = np.asarray(r.solutions)
                ok = checker.are_valid(S)
                n_ik, n_valid = n_ik + len(S), n_valid + int(ok.sum())
                if ok.any():
                    T = method.world.kin.T_world_cam_batch(S[ok])
                    for name, P in points.items():
                        seen[name] = max(seen.get(name, 0), int(frustum_mask(T, K, P, 1.0).sum(1).max()))
            print(f"  look at {np.round(p - base, 2)} from the base: IK {n_ik}, valid {n_valid}, "
                  f"most points of each base primitive in a valid view's frustum {seen}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
