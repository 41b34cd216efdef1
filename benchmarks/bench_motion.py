"""Motion planning benchmark: queries in Level-3/4 scenes and the MotionBenchMaker families.

Scene queries: for each of a few Level-3 and Level-4 scenes, the map is the ground-truth
geometry voxelised at 1 cm (a voxel is unsafe when a primitive or the floor touches it) as
a `DistanceGrid`; starts are the home pose or random valid configurations, goals random valid
configurations with the TCP inside the cabinet. A query counts as feasible when it is solved
within the normal budget or within a 10x budget retry. Returned paths are replayed in the
MuJoCo scene every 0.005 rad to count ground-truth contacts. MotionBenchMaker: every problem
of data/mbm-panda.tar.bz2 with our sphere model and planner.

Prints one JSON object per line (see COMMON.md). Run: `python benchmarks/bench_motion.py`.
"""
from __future__ import annotations

import json
import os
import sys
import time

import numpy as np
from scipy import ndimage

from compass_manip.geometry import make_T, rot_z
from compass_manip.bench.mbm import family_stats, load_problems, solve_problems
from compass_manip.bench.stats import emit, median_p90
from compass_manip.motion.planner import PlannerConfig, plan
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.motion.timing import densify, ee_path_length, joint_path_length, time_parameterize
from compass_manip.motion.validity import DistanceGrid, ValidityChecker
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.robot.spheres import panda_sphere_model

#: shipped with the repository (data/README.md: MotionBenchMaker via KavrakiLab/vamp, Apache-2.0)
MBM_ARCHIVE = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "data", "mbm-panda.tar.bz2")
GRID_LO, GRID_HI, GRID_RES = np.array([-0.7, -1.0, -0.1]), np.array([1.4, 1.0, 1.4]), 0.01
SCENES = [(3, 0), (3, 1), (4, 0), (4, 1)]
PAIRS_PER_SCENE = 30
BUDGET_S = 1.0




def scene_primitives(scene) -> PrimitiveSet:
    """The scene's primitives (boxes/cylinders yawed about z, spheres) as a PrimitiveSet."""
    boxes, cyls, sph = [], [], []
    for p in scene.all_primitives():
        T = make_T(rot_z(p.yaw), p.pos)
        if p.shape == "box":
            boxes.append((T, np.array(p.size)))
        elif p.shape == "cylinder":
            cyls.append((T, p.size[0], p.size[1]))
        else:
            sph.append((np.array(p.pos), p.size[0]))
    return PrimitiveSet.from_lists(boxes=boxes, spheres=sph, cylinders=cyls)


def ground_truth_grid(scene) -> DistanceGrid:
    """Distance field of the voxels touched by any primitive or lying below the floor."""
    n = np.round((GRID_HI - GRID_LO) / GRID_RES).astype(int)
    axes = [GRID_LO[i] + (np.arange(n[i]) + 0.5) * GRID_RES for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    unsafe = Z <= scene.floor_z + 0.5 * GRID_RES
    reach = 0.5 * np.sqrt(3.0) * GRID_RES
    for p in scene.all_primitives():
        c, s = np.cos(p.yaw), np.sin(p.yaw)
        dx, dy, dz = X - p.pos[0], Y - p.pos[1], Z - p.pos[2]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        if p.shape == "box":
            e = np.stack([np.abs(lx) - p.size[0], np.abs(ly) - p.size[1], np.abs(dz) - p.size[2]])
            d = np.linalg.norm(np.maximum(e, 0.0), axis=0)
        elif p.shape == "cylinder":
            er = np.hypot(lx, ly) - p.size[0]
            d = np.hypot(np.maximum(er, 0.0), np.maximum(np.abs(dz) - p.size[1], 0.0))
        else:
            d = np.sqrt(dx * dx + dy * dy + dz * dz) - p.size[0]
        unsafe |= d <= reach
    dist = ndimage.distance_transform_edt(~unsafe).astype(np.float32) * GRID_RES
    return DistanceGrid(dist, GRID_LO, GRID_RES)


def sample_queries(scene, checker, kin, rng, n_pairs):
    """(starts, goals): the home pose or random valid starts; valid goals with the TCP in the cabinet."""
    lo, hi = np.array(scene.cabinet.interior_min), np.array(scene.cabinet.interior_max)
    goals, starts = [], []
    while len(goals) < n_pairs or len(starts) < n_pairs:
        Q = rng.uniform(Q_MIN, Q_MAX, size=(4000, 7))
        ok = checker.are_valid(Q)
        V = Q[ok]
        if len(V) == 0:
            continue
        p = kin.T_world_tcp_batch(V)[:, :3, 3]
        inside = np.all((p > lo + 0.03) & (p < hi - 0.03), axis=1)
        goals += list(V[inside])
        starts += list(V[~inside])
    home_ok = checker.is_valid(Q_HOME)
    out = []
    for k in range(n_pairs):
        s = Q_HOME if (home_ok and k % 2 == 0) else starts[k]
        out.append((s, goals[k]))
    return out


def bench_scenes(sm) -> None:
    from compass_manip.robot.kinematics import PandaKinematics
    from compass_manip.sim.levels import generate_scene
    from compass_manip.sim.world import World

    kin = PandaKinematics()
    rows = {"numba": [], "ompl": []}
    feasible, gt_paths, gt_states, durations, ee_len, j_len = 0, 0, 0, [], [], []
    n_queries = 0
    for level, index in SCENES:
        scene = generate_scene(level, index, np.random.default_rng([level, index]))
        checker = ValidityChecker(sm, grid=ground_truth_grid(scene))
        world = World(scene)
        rng = np.random.default_rng([7, level, index])
        for k, (qs, qg) in enumerate(sample_queries(scene, checker, kin, rng, PAIRS_PER_SCENE)):
            n_queries += 1
            res = {}
            for backend in ("numba", "ompl"):
                config = PlannerConfig(time_budget=BUDGET_S, backend=backend)
                r = plan(qs, qg, checker, config, np.random.default_rng([level, index, k]))
                rows[backend].append((r.success, 1e3 * r.plan_time_s))
                res[backend] = r
            r = res["numba"]
            if not (r.success or res["ompl"].success):
                retry = plan(qs, qg, checker, PlannerConfig(time_budget=10 * BUDGET_S), np.random.default_rng(99))
                feasible += retry.success
            else:
                feasible += 1
            if r.success:
                dense = densify(r.path, 0.005)
                hits = sum(world.in_collision(q, include_self=True) for q in dense)
                gt_states += hits
                gt_paths += hits > 0
                durations.append(time_parameterize(r.path).duration)
                ee_len.append(ee_path_length(r.path, kin))
                j_len.append(joint_path_length(r.path))
        world.close()
    for backend, suffix in (("numba", ""), ("ompl", "_ompl")):
        ok = np.array([s for s, _ in rows[backend]])
        t = [ms for _, ms in rows[backend]]
        emit(f"motion.plan_ms{suffix}", **median_p90(t), unit="ms", n=len(t))
        emit(f"motion.plan_success{suffix}", value=round(float(ok.sum() / max(feasible, 1)), 4),
             unit="ratio", solved=int(ok.sum()), feasible=int(feasible), queries=n_queries)
    emit("motion.gt_collision_paths", value=int(gt_paths), unit="paths", states_in_contact=int(gt_states),
         paths=len(durations))
    emit("motion.traj_duration_s", **median_p90(durations), unit="s")
    emit("motion.ee_path_length_m", **median_p90(ee_len), unit="m")
    emit("motion.joint_path_length_rad", **median_p90(j_len), unit="rad")


def bench_mbm() -> None:
    """As `compass mbm`: finger opening from each problem, fine-sphere refinement on."""
    if not os.path.isfile(MBM_ARCHIVE):
        raise SystemExit(f"bench_motion: {os.path.normpath(MBM_ARCHIVE)} is missing; it ships with the repository")
    problems = load_problems(MBM_ARCHIVE)
    config = PlannerConfig(time_budget=BUDGET_S)
    outcomes = solve_problems(problems, config, seed=0)
    solved = sum(o.solved for o in outcomes)
    rejected = sum(o.rejection is not None and o.rejection.in_collision for o in outcomes)
    outside = sum(o.rejection is not None and not o.rejection.in_collision for o in outcomes)
    emit("motion.mbm_success", value=round(solved / len(outcomes), 4), unit="ratio", solved=solved,
         rejected=rejected, outside_limits=outside, problems=len(outcomes),
         solved_of_accepted=round(solved / max(len(outcomes) - rejected - outside, 1), 4))
    t = [o.plan_ms for o in outcomes if o.rejection is None]
    if t:
        emit("motion.mbm_plan_ms", **median_p90(t), unit="ms", n=len(t))
    for s in family_stats(outcomes):
        emit(f"motion.mbm.{s.family}", **s.as_json(), unit="ms")


def main() -> None:
    t0 = time.perf_counter()
    sm = panda_sphere_model()
    bench_scenes(sm)
    bench_mbm()
    print(f"bench_motion: {time.perf_counter() - t0:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
