"""Are two versions of the scene generator's accepted scenes the same? And how long do they take?

Two modes (ground truth: a diagnosis of scene generation, not a method):

* `gen`: certify (level, index, seed) afresh (`certified_scene(..., refresh=True)`) with the
  code on PYTHONPATH into COMPASS_CACHE_DIR and print one JSON line per scene with its CPU
  (`time.process_time`) and wall seconds, candidates drawn and rejections:
      python benchmarks/diag_scene_same.py gen --jobs 4:0-7:0 3:0-7:0 4:0-3:4343 > new.jsonl
  (LEVEL:FIRST-LAST:SEED). Run it once with main's code (a worktree of main) and once with
  the branch's, each into its own cache folder.
* `cmp`: compare two cache folders entry by entry (the newest entry of each level, index,
  seed in each), print per scene `equal` or the fields that differ:
      python benchmarks/diag_scene_same.py cmp /work/cache-a /work/cache-b [--jobs ...]
  Equal means: `SceneSpec.to_dict()` equal, the certificate's fields equal except the wall
  and stage times (`IGNORED`), the same candidates drawn and the same rejections (in order;
  with --ignore-reasons only their number: reordered gates may record another reason).
Also `times`: summarise the CPU seconds of `gen` outputs per level (median, p90, total).
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time

import numpy as np

#: Certificate fields that only measure how long the work took.
IGNORED = ("stage_times_s", "time_s")


def parse_jobs(specs: list[str]) -> list[tuple[int, int, int]]:
    out = []
    for s in specs:
        lv, rng, seed = s.split(":")
        a, b = (int(v) for v in rng.split("-"))
        out += [(int(lv), i, int(seed)) for i in range(a, b + 1)]
    return out


def gen(jobs) -> None:
    from compass_manip.sim.certify import certified_scene

    for lv, i, seed in jobs:
        c0, w0 = time.process_time(), time.perf_counter()
        cs = certified_scene(lv, i, seed, refresh=True)
        print(json.dumps({"level": lv, "index": i, "seed": seed, "cpu_s": round(time.process_time() - c0, 2),
                          "wall_s": round(time.perf_counter() - w0, 2), "sub_seed": list(cs.scene.seed),
                          "attempts": cs.attempts, "rejections": list(cs.rejections),
                          "stage_times_s": cs.certificate.stage_times_s}), flush=True)


def load_entry(folder: str, lv: int, i: int, seed: int) -> dict | None:
    files = glob.glob(os.path.join(folder, "scenes", f"level{lv}_{i:03d}_seed{seed}_*.json"))
    if not files:
        return None
    with open(max(files, key=os.path.getmtime), encoding="utf-8") as f:
        return json.load(f)


def differences(a: dict, b: dict, ignore_reasons: bool = False) -> list[str]:
    """Names of the fields in which two cache entries differ (empty: the same scene)."""
    out = []
    if a["scene"] != b["scene"]:
        out += [f"scene.{k}" for k in sorted(set(a["scene"]) | set(b["scene"]))
                if a["scene"].get(k) != b["scene"].get(k)]
    ca, cb = a["certificate"], b["certificate"]
    out += [f"certificate.{k}" for k in sorted(set(ca) | set(cb)) if k not in IGNORED and ca.get(k) != cb.get(k)]
    if a["attempts"] != b["attempts"]:
        out.append("attempts")
    if (len(a["rejections"]) != len(b["rejections"])) if ignore_reasons else a["rejections"] != b["rejections"]:
        out.append("rejections")
    return out


def cmp(folder_a: str, folder_b: str, jobs, ignore_reasons: bool) -> int:
    if not jobs:  # every entry of folder_a
        jobs = []
        for p in sorted(glob.glob(os.path.join(folder_a, "scenes", "level*_seed*_*.json"))):
            name = os.path.basename(p).split("_")
            jobs.append((int(name[0][5:]), int(name[1]), int(name[2][4:])))
        jobs = sorted(set(jobs))
    n_diff = 0
    for lv, i, seed in jobs:
        a, b = load_entry(folder_a, lv, i, seed), load_entry(folder_b, lv, i, seed)
        if a is None or b is None:
            print(f"level {lv} scene {i} seed {seed}: missing in {'a' if a is None else 'b'}")
            n_diff += 1
            continue
        d = differences(a, b, ignore_reasons)
        n_diff += bool(d)
        print(f"level {lv} scene {i} seed {seed} sub-seed {a['scene']['seed']}: "
              + ("equal" if not d else "DIFFERENT " + ", ".join(d)))
    print(f"{len(jobs) - n_diff} of {len(jobs)} equal")
    return 1 if n_diff else 0


def times(paths: list[str]) -> None:
    for p in paths:
        rows = [json.loads(line) for line in open(p, encoding="utf-8") if line.startswith("{")]
        for lv in sorted({r["level"] for r in rows}):
            for seed in sorted({r["seed"] for r in rows if r["level"] == lv}):
                rs = [r for r in rows if r["level"] == lv and r["seed"] == seed]
                cpu, wall = np.array([r["cpu_s"] for r in rs]), np.array([r["wall_s"] for r in rs])
                print(f"{p}: level {lv} seed {seed}: {len(rs)} scenes, CPU s median {np.median(cpu):.1f} "
                      f"p90 {np.percentile(cpu, 90):.1f} max {cpu.max():.1f} total {cpu.sum():.0f}; "
                      f"wall s median {np.median(wall):.1f} total {wall.sum():.0f}; "
                      f"candidates {sum(r['attempts'] for r in rs)}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="mode", required=True)
    g = sub.add_parser("gen")
    g.add_argument("--jobs", nargs="+", required=True, help="LEVEL:FIRST-LAST:SEED ...")
    c = sub.add_parser("cmp")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--jobs", nargs="*", default=[])
    c.add_argument("--ignore-reasons", action="store_true",
                   help="compare only the number of rejections, not their reasons")
    t = sub.add_parser("times")
    t.add_argument("files", nargs="+")
    args = ap.parse_args(argv)
    if args.mode == "gen":
        gen(parse_jobs(args.jobs))
        return 0
    if args.mode == "cmp":
        return cmp(args.a, args.b, parse_jobs(args.jobs), args.ignore_reasons)
    times(args.files)
    return 0


if __name__ == "__main__":
    sys.exit(main())
