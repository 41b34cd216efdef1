"""Kinematics, IK and validity-checking benchmark.

Scene: floor under the base + a table top and two shelf-like boxes in front of the robot,
either as known primitives or rasterised into a 1 cm DistanceGrid (as the map provides).
Prints one JSON object per line. Run: `.venv/bin/python benchmarks/bench_validity.py`.
"""
from __future__ import annotations

import json
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numba
import numpy as np

from compass_manip.geometry import make_T, rot_z
from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.motion.validity import DistanceGrid, ValidityChecker, config_valid_kernel
from compass_manip.robot.ik import PandaIK, ik_look_at
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.bench.stats import emit_samples, emit_value
from compass_manip.robot.spheres import panda_sphere_model

BOXES = [
    (make_T(t=[0.0, 0.0, -0.05]), [1.5, 1.5, 0.05]),  # floor
    (make_T(t=[0.6, 0.0, 0.2]), [0.25, 0.5, 0.02]),  # table top
    (make_T(rot_z(0.3), [0.55, 0.45, 0.5]), [0.2, 0.02, 0.3]),  # shelf side
    (make_T(t=[0.55, -0.1, 0.75]), [0.2, 0.3, 0.02]),  # shelf board
]


def _grid(prims: PrimitiveSet, res=0.01) -> DistanceGrid:
    origin = np.array([-1.0, -1.0, -0.1])
    n = (200, 200, 140)
    idx = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1).reshape(-1, 3)
    unsafe = prims.distance(origin + (idx + 0.5) * res).reshape(n) <= 0.5 * res
    return DistanceGrid.from_unsafe_mask(unsafe, origin, res)


def _rate(fn, Q, repeats=5):
    fn(Q[:100])
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(Q)
        t.append(time.perf_counter() - t0)
    return Q.shape[0] / np.median(t)


def main() -> None:
    rng = np.random.default_rng(0)
    kin = PandaKinematics()
    Q = rng.uniform(Q_MIN, Q_MAX, (200_000, 7))

    # --- kinematics -------------------------------------------------------------------
    qs = Q[:2000]
    kin.T_world_tcp(qs[0])
    t = []
    for q in qs:
        t0 = time.perf_counter()
        kin.T_world_tcp(q)
        t.append((time.perf_counter() - t0) * 1e6)
    emit_samples("robot.fk_tcp_us", t, "us")
    emit_value("robot.fk_links_batch_us_per_config", 1e6 / _rate(kin.fk_links_batch, Q[:50_000]), "us")
    t = []
    for q in qs[:500]:
        t0 = time.perf_counter()
        kin.jacobian(q)
        t.append((time.perf_counter() - t0) * 1e6)
    emit_samples("robot.jacobian_us", t, "us")

    # --- IK: random reachable TCP poses ---------------------------------------------------
    solver = PandaIK(kin)
    ok, t, nsol = 0, [], []
    for q in Q[:300]:
        T = kin.T_world_tcp(q)
        t0 = time.perf_counter()
        r = solver.solve(T, "tcp", Q_HOME)
        t.append((time.perf_counter() - t0) * 1e3)
        nsol.append(r.solutions.shape[0])
        if r.success:
            P = kin.T_world_tcp_batch(r.solutions)
            ok += bool(np.all(np.linalg.norm(P[:, :3, 3] - T[:3, 3], axis=1) < 1e-3))
    emit_samples("robot.ik_tcp_ms", t, "ms")
    t = []
    for p in rng.uniform([0.35, -0.35, 0.05], [0.7, 0.35, 0.4], (10, 3)):
        t0 = time.perf_counter()
        ik_look_at(p, 0.35, Q_HOME, ik=solver)
        t.append((time.perf_counter() - t0) * 1e3)
    emit_samples("robot.ik_look_at_24views_ms", t, "ms")
    emit_value("robot.ik_tcp_success", ok / 300, "ratio")
    emit_value("robot.ik_tcp_solutions_mean", np.mean(nsol), "count")

    # --- validity ---------------------------------------------------------------------------
    sm = panda_sphere_model()
    emit_value("robot.n_spheres", sm.n_spheres, "count")
    emit_value("robot.n_self_collision_pairs", len(sm.self_collision_pairs), "count")
    prims = PrimitiveSet.from_lists(boxes=BOXES)
    vc = ValidityChecker(sm, obstacles=prims)
    rate = _rate(vc.are_valid, Q)
    emit_value("motion.validity_checks_per_s", rate, "1/s")
    emit_value("motion.validity_free_fraction", vc.are_valid(Q).mean(), "ratio")
    vg = ValidityChecker(sm, grid=_grid(prims))
    emit_value("motion.validity_checks_per_s_grid", _rate(vg.are_valid, Q), "1/s")
    # one thread, inside numba (what a numba planner pays per state)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    emit_value("motion.validity_checks_per_s_1thread", _rate(vc.are_valid, Q[:100_000], repeats=3), "1/s")
    numba.set_num_threads(threads)
    # one kernel call from Python (what a Python callback pays: tuple-of-arrays unboxing)
    args = vc.kernel_args()
    links = np.empty((kin.n_links, 4, 4))
    W = np.empty((sm.n_spheres, 3))
    config_valid_kernel(Q[0], *args, links, W)
    t0 = time.perf_counter()
    for q in Q[:50_000]:
        config_valid_kernel(q, *args, links, W)
    emit_value("motion.validity_kernel_python_call_us", (time.perf_counter() - t0) / 50_000 * 1e6, "us")
    t = []
    for q in Q[:2000]:
        t0 = time.perf_counter()
        vc.is_valid(q)
        t.append((time.perf_counter() - t0) * 1e6)
    emit_samples("motion.is_valid_us", t, "us")
    # edges of 0.5 rad between random free configurations
    free = Q[:20_000][vc.are_valid(Q[:20_000])][:400]
    ends = [np.clip(q + rng.uniform(-0.5, 0.5, 7), Q_MIN, Q_MAX) for q in free]
    vc.edge_valid(free[0], ends[0], 0.005, adaptive=True)
    for name, res, adaptive in (("motion.edge_valid_0.5rad_us", None, False),
                                ("motion.edge_valid_0.5rad_fine_us", 0.005, False),
                                ("motion.edge_valid_0.5rad_fine_adaptive_us", 0.005, True)):
        t = []
        for q, q1 in zip(free, ends):
            t0 = time.perf_counter()
            vc.edge_valid(q, q1, res, adaptive=adaptive)
            t.append((time.perf_counter() - t0) * 1e6)
        emit_samples(name, t, "us")


if __name__ == "__main__":
    main()
