"""`compass scenes LEVEL`: generate, certify and describe the benchmark scenes."""
from __future__ import annotations

import json
import os
import sys
import time

from ..errors import CompassInputError

HELP = "generate and certify the confined scenes of a level; print their difficulty"


def add_arguments(p) -> None:
    p.add_argument("level", help="difficulty level 1, 2, 3 or 4, or 'all'")
    p.add_argument("--count", type=int, default=20, help="scenes per level (default 20)")
    p.add_argument("--seed", type=int, default=0, help="base seed of the whole set (default 0)")
    p.add_argument("--out", default=None, help="write scene JSON, overview and start-camera PNGs here")
    p.add_argument("--json", action="store_true", help="print one JSON list on stdout")


def parse_levels(text: str) -> list[int]:
    if text == "all":
        return [1, 2, 3, 4]
    if text not in ("1", "2", "3", "4"):
        raise CompassInputError(f"level {text!r} is not allowed; use 1, 2, 3, 4 or all")
    return [int(text)]


def run(args) -> int:
    levels = parse_levels(args.level)
    if not 1 <= args.count <= 1000:
        raise CompassInputError(f"--count {args.count} is not allowed; use 1..1000")
    if args.seed < 0 or args.seed >= 2**63:
        raise CompassInputError(f"--seed {args.seed} is not allowed; use 0 <= seed < 2**63")

    from tqdm import tqdm

    from ..sim.certify import certified_scene

    rows = []
    jobs = [(lv, i) for lv in levels for i in range(args.count)]
    for lv, i in tqdm(jobs, desc="certifying scenes", unit="scene", file=sys.stderr, disable=None):
        t0 = time.perf_counter()
        cs = certified_scene(lv, i, args.seed)
        c = cs.certificate
        rows.append({
            "level": lv, "index": i, "seed": args.seed, "sub_seed": list(cs.scene.seed),
            "certified": c.certified, "start_visibility": round(c.start_visibility, 4),
            "view_visibility_fraction": round(c.view_visibility_fraction, 4),
            "free_config_fraction": round(c.free_config_fraction, 4),
            "n_valid_views": c.n_valid_views, "attempts": cs.attempts,
            "time_s": round(time.perf_counter() - t0, 3),
        })
        if args.out:
            _write(cs, args.out)
    if args.json:
        print(json.dumps(rows))
    else:
        _print_table(rows)
    return 0


def _write(cs, out: str) -> None:
    from ..viz.images import save_frame_png, save_rgb_png
    from ..sim.world import World, render_overview

    scene = cs.scene
    stem = os.path.join(out, f"level{scene.level}_{scene.index:03d}")
    os.makedirs(out, exist_ok=True)
    record = {"scene": scene.to_dict(), "certificate": {
        k: (v.value if hasattr(v, "value") else v) for k, v in cs.certificate.__dict__.items()}}
    tmp = stem + ".json.tmp"
    with open(tmp, "w") as f:
        json.dump(record, f, indent=1)
    os.replace(tmp, stem + ".json")
    world = World(scene)
    try:
        save_rgb_png(render_overview(world), stem + "_overview.png")
        frame = world.render(world.robot.q_home)
        save_frame_png(frame, stem + "_start_camera.png", world.target_label,
                       f"level {scene.level} scene {scene.index}: start wrist camera")
    finally:
        world.close()


def _print_table(rows: list[dict]) -> None:
    head = f"{'level':>5} {'index':>5} {'sub-seed':>16} {'cert':>4} {'start_vis':>9} {'view_vis_frac':>13} {'free_cfg_frac':>13} {'tries':>5} {'time_s':>6}"
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['level']:>5} {r['index']:>5} {str(tuple(r['sub_seed'])):>16} {'yes' if r['certified'] else 'no':>4} "
              f"{r['start_visibility']:>9.3f} {r['view_visibility_fraction']:>13.3f} {r['free_config_fraction']:>13.3f} "
              f"{r['attempts']:>5} {r['time_s']:>6.2f}")
    levels = sorted({r["level"] for r in rows})
    print()
    print(f"{'level':>5} {'scenes':>6} {'certified':>9} {'mean start_vis':>14} {'mean view_vis_frac':>18} {'mean free_cfg_frac':>18}")
    for lv in levels:
        rs = [r for r in rows if r["level"] == lv]
        mean = lambda k: sum(r[k] for r in rs) / len(rs)  # noqa: E731
        print(f"{lv:>5} {len(rs):>6} {sum(r['certified'] for r in rs):>9} {mean('start_visibility'):>14.3f} "
              f"{mean('view_visibility_fraction'):>18.3f} {mean('free_config_fraction'):>18.3f}")
