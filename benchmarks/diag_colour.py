"""Diagnosis (GROUND TRUTH, read here only): how the detector's colour test labels the pixels
of every object, per true colour, with and without the hue check (`DetectorConfig.hue_check`).

For each certified scene, renders the wrist camera at the certified path's configurations
(home, the good view, the pre-grasp, ...: `Certificate.path` at its marks plus every
`--every`-th row, and `--jitter` configurations drawn around each) with segmentation, and for every object of a chromatic colour counts, per
query colour of the palette, the share of its pixels the test marks (the true colour's
share is the recall, any other's a confusion). Prints the per-colour table (pixels
pooled over objects) and the objects whose pixels another colour's test takes for >= 5 %,
for both rules.
Run: `PYTHONPATH=src:benchmarks python benchmarks/diag_colour.py --levels 1,2,3,4 --scenes 0-9`.
"""
from __future__ import annotations

import argparse
import os
from dataclasses import replace

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from compass_manip.perception.colour import colour_mask
from compass_manip.perception.detector import DetectorConfig
from compass_manip.robot.model import Q_MAX, Q_MIN
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World
from compass_manip.task import COLOURS

CHROMATIC = [c for c in COLOURS if c not in ("white", "grey")]


def scene_counts(level: int, index: int, seed: int, every: int, configs: dict, jitter: int = 0,
                 sigma: float = 0.25) -> list[tuple]:
    """Rows (rule, level, index, object name, true colour, query colour, marked, pixels)."""
    cs = certified_scene(level, index, seed)
    world = World(cs.scene)
    path = np.asarray(cs.certificate.path)
    rows_q = sorted(set(cs.certificate.path_marks) | set(range(0, len(path), every)) | {0})
    colour_of = {world.labels[o.name]: (o.name, o.colour) for o in cs.scene.objects}
    rng = np.random.default_rng([seed, level, index])
    qs = [path[r] for r in rows_q]
    qs += [np.clip(path[r] + rng.normal(0.0, sigma, 7), Q_MIN, Q_MAX) for r in rows_q for _ in range(jitter)]
    out = []
    try:
        for q in qs:
            f = world.render(q, seg=True)
            for rule, cfg in configs.items():
                masks = {c: colour_mask(f.rgb, c, cfg) for c in CHROMATIC}
                for lab, (name, true) in colour_of.items():
                    if true not in CHROMATIC:
                        continue
                    pix = f.seg == lab
                    n = int(pix.sum())
                    if n < 40:
                        continue
                    for c, m in masks.items():
                        out.append((rule, level, index, name, true, c, int((m & pix).sum()), n))
    finally:
        world.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="1,2,3,4")
    ap.add_argument("--scenes", default="0-4")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--every", type=int, default=25, help="also every N-th row of the certified path")
    ap.add_argument("--jitter", type=int, default=3, help="configurations drawn around each of those rows "
                    "(joints + N(0, 0.25 rad)): views the path does not take")
    args = ap.parse_args()
    a, _, b = args.scenes.partition("-")
    scenes = range(int(a), int(b or a) + 1)
    base = DetectorConfig()
    configs = {"direction": replace(base, hue_check=False), "direction+hue": replace(base, hue_check=True)}
    rows = []
    for level in (int(v) for v in args.levels.split(",")):
        for i in scenes:
            rows += scene_counts(level, i, args.seed, args.every, configs, args.jitter)
    for rule in configs:
        print(f"== {rule}: share of each true colour's pixels marked by each query colour's test")
        print("true \\ query " + " ".join(f"{c:>7s}" for c in CHROMATIC) + "   pixels")
        for true in CHROMATIC:
            sel = [r for r in rows if r[0] == rule and r[4] == true]
            if not sel:
                continue
            tot = sum(r[7] for r in sel if r[5] == CHROMATIC[0])
            shares = [sum(r[6] for r in sel if r[5] == c) / tot for c in CHROMATIC]
            print(f"{true:13s} " + " ".join(f"{s:7.3f}" for s in shares) + f" {tot:8d}")
        bad = sorted({(r[1], r[2], r[3], r[4], r[5]) for r in rows if r[0] == rule and r[4] != r[5]
                      and r[6] >= 0.05 * r[7]})
        print(f"objects with >= 5 % of their pixels taken by another colour in some frame: {len(bad)}")
        for b in bad[:40]:
            print("   ", b)


if __name__ == "__main__":
    main()
