"""Simulator benchmark: frame rendering, ray-cast depth, contact checks, scene certification.

Prints one JSON object per line. Run: `.venv/bin/python benchmarks/bench_sim.py`.
"""
from __future__ import annotations

import json
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.bench.stats import emit_samples, emit_value
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World


def _time(fn, n: int) -> list[float]:
    fn()  # warm up
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t0) * 1e3)
    return out


def main() -> None:
    world = World(certified_scene(4, 0, 0).scene)
    rng = np.random.default_rng(0)
    poses = [np.clip(Q_HOME + rng.uniform(-0.2, 0.2, 7), Q_MIN, Q_MAX) for _ in range(16)]
    it = iter(poses * 100)
    step = lambda: world.set_q(next(it))  # noqa: E731
    emit_samples("sim.render_depth_320x240_ms", _time(lambda: (step(), world.render_depth()), 60), "ms")
    emit_samples("sim.render_rgb_320x240_ms", _time(lambda: (step(), world.render_rgb()), 60), "ms")
    emit_samples("sim.render_seg_320x240_ms", _time(lambda: (step(), world.render_seg()), 60), "ms")
    emit_samples("sim.raycast_depth_320x240_ms", _time(lambda: (step(), world.raycast_depth()), 30), "ms")
    emit_samples("sim.contact_check_us", [t * 1e3 for t in _time(lambda: world.contacts(next(it), include_self=True), 300)], "us")
    world.close()
    for level in (1, 2, 3, 4):
        times, attempts = [], []
        for i in range(10):
            t0 = time.perf_counter()
            cs = certified_scene(level, i, 0)
            times.append((time.perf_counter() - t0) * 1e3)
            attempts.append(cs.attempts)
        emit_samples(f"sim.generate_certify_level{level}_ms", times, "ms")
        print(json.dumps({"name": f"sim.certify_attempts_level{level}", "value": float(np.mean(attempts)),
                          "unit": "attempts per accepted scene"}), flush=True)


if __name__ == "__main__":
    main()
