"""Capture the grasp-only harness's `select_grasp` inputs per scene (pickled), so selection
variants can be replayed on identical maps without re-running the harness.

Run: `PYTHONPATH=src:benchmarks python benchmarks/capture_select_inputs.py --levels 1 3 --count 10 --dir DIR`;
each scene gives DIR/L{level}_{index}.pkl (the harness stops at the selection)."""
from __future__ import annotations

import argparse
import glob
import os
import pickle
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

from compass_manip.sim.certify import certified_scene
from diag_hand_rejections import capture, scene_arguments


def capture_arguments(ap: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """--dir (the captures' folder), --seed (the scene set's) and --only (L:I pairs) of the
    scripts that read captures (`read_captures`)."""
    ap.add_argument("--dir", required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", default=None, help="comma-separated L:I pairs")
    return ap


def read_captures(directory: str, only: str | None = None):
    """Yield (level, index, box) for each DIR/L{level}_{index}.pkl in name order; only: a
    comma-separated list of L:I pairs to keep (None: all)."""
    keep = None if not only else set(only.split(","))
    for path in sorted(glob.glob(os.path.join(directory, "L*_*.pkl"))):
        level, index = (int(x) for x in os.path.basename(path)[1:-4].split("_"))
        if keep is not None and f"{level}:{index}" not in keep:
            continue
        with open(path, "rb") as f:
            yield level, index, pickle.load(f)


def main() -> int:
    ap = scene_arguments(argparse.ArgumentParser())
    ap.add_argument("--dir", required=True)
    args = ap.parse_args()
    os.makedirs(args.dir, exist_ok=True)
    for level in args.levels:
        for index in range(args.start, args.start + args.count):
            box = capture(certified_scene(level, index, args.seed).scene, args.seed)
            with open(os.path.join(args.dir, f"L{level}_{index}.pkl"), "wb") as f:
                pickle.dump(box, f)
            print(level, index, sorted(box), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
