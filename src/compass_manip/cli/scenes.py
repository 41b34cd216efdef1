"""`compass scenes LEVEL`: generate, certify and describe the benchmark scenes."""
from __future__ import annotations

import json
import os
import re
import sys
import time
from collections import Counter

import numpy as np

from ..errors import CompassInputError
from ..paths import check_output_dir

HELP = "generate and certify the confined scenes of a level; print their difficulty"

#: (key, header, format) of the per-scene table
COLUMNS = (
    ("level", "lv", "{:>2}"), ("index", "idx", "{:>3}"), ("sub_seed", "sub-seed", "{:>14}"),
    ("start_visibility", "start", "{:>5.2f}"), ("best_fixed_view_visibility", "fv_best", "{:>7.2f}"),
    ("fv_solvable", "fv_ok", "{:>5}"), ("best_outside_view_visibility", "out_best", "{:>8.2f}"),
    ("view_camera_outside_m", "cam_out_m", "{:>9.2f}"), ("view_visibility_fraction", "view_vis", "{:>8.2f}"),
    ("free_config_fraction", "free_cfg", "{:>8.2f}"), ("views_removed_by_obstacles", "v_rm", "{:>5.2f}"),
    ("grasps_removed_by_obstacles", "g_rm", "{:>5.2f}"), ("grasp_approach_deg", "appr°", "{:>5.0f}"),
    ("grasp_yaw_deg", "yaw°", "{:>5.0f}"),
    ("n_objects", "obj", "{:>3}"), ("n_distractors", "dis", "{:>3}"), ("attempts", "tries", "{:>5}"),
    ("time_s", "time_s", "{:>6.2f}"),
)


def add_arguments(p) -> None:
    p.add_argument("level", help="difficulty level 1, 2, 3 or 4, or 'all'")
    p.add_argument("--count", type=int, default=20, help="scenes per level (default 20)")
    p.add_argument("--seed", type=int, default=0, help="base seed of the whole set (default 0)")
    p.add_argument("--out", default=None,
                   help="write scene JSON, overview and start-camera PNGs and a contact sheet per level here")
    p.add_argument("--json", action="store_true", help="print one JSON list on stdout")


def parse_levels(text: str) -> list[int]:
    if text == "all":
        return [1, 2, 3, 4]
    if text not in ("1", "2", "3", "4"):
        raise CompassInputError(f"level {text!r} is not allowed; use 1, 2, 3, 4 or all")
    return [int(text)]


def certificate_record(cs) -> dict:
    """The certificate of a certified scene as plain JSON data (failure as its name or None)."""
    c = cs.certificate
    out = {}
    for k, v in c.__dict__.items():
        if k == "failure":
            v = v.name if v is not None else None
        elif isinstance(v, tuple):
            v = json.loads(json.dumps(v))
        out[k] = v
    out["certified"] = c.certified
    return out


def run(args) -> int:
    levels = parse_levels(args.level)
    if not 1 <= args.count <= 1000:
        raise CompassInputError(f"--count {args.count} is not allowed; use 1..1000")
    if args.seed < 0 or args.seed >= 2**63:
        raise CompassInputError(f"--seed {args.seed} is not allowed; use 0 <= seed < 2**63")

    if args.out is not None:
        args.out = check_output_dir(args.out)  # before any work (an empty --out is refused, not ignored)

    from tqdm import tqdm

    from ..sim.certify import certified_scene

    rows, overviews = [], {lv: [] for lv in levels}
    jobs = [(lv, i) for lv in levels for i in range(args.count)]
    for lv, i in tqdm(jobs, desc="certifying scenes", unit="scene", file=sys.stderr, disable=None):
        t0 = time.perf_counter()
        cs = certified_scene(lv, i, args.seed, refresh=True)  # measures certification time, fills the cache
        c = cs.certificate
        rows.append({
            "level": lv, "index": i, "seed": args.seed, "sub_seed": list(cs.scene.seed),
            "certified": c.certified, "start_visibility": round(c.start_visibility, 4),
            "best_fixed_view_visibility": round(c.best_fixed_view_visibility, 4), "fv_solvable": c.fv_solvable,
            "best_outside_view_visibility": _round(c.best_outside_view_visibility),
            "view_camera_outside_m": _round(c.view_camera_outside_m), "target_row": cs.scene.extra.get("target_row"),
            "obstacle_variant": cs.scene.extra.get("obstacle_variant", ""),
            "view_visibility_fraction": round(c.view_visibility_fraction, 4),
            "free_config_fraction": round(c.free_config_fraction, 4),
            "views_removed_by_obstacles": round(c.views_removed_by_obstacles, 4),
            "grasps_removed_by_obstacles": round(c.grasps_removed_by_obstacles, 4),
            "grasp_approach_deg": c.grasp_approach_deg, "grasp_yaw_deg": c.grasp_yaw_deg, "lift_height": round(c.lift_height, 4),
            "n_objects": c.n_objects, "n_distractors": c.n_colour_distractors + c.n_shape_distractors,
            "n_valid_views": c.n_valid_views, "plan_checks_max": c.plan_checks_max, "attempts": cs.attempts, "rejections": list(cs.rejections),
            "time_s": round(time.perf_counter() - t0, 3),
        })
        if args.out:
            overviews[lv].append(_write(cs, args.out))
    if args.out:
        from ..viz.contact_sheet import save_contact_sheet

        for lv, ims in overviews.items():
            save_contact_sheet(ims, os.path.join(args.out, f"level{lv}_contact_sheet.png"),
                               [f"L{lv} #{i}" for i in range(len(ims))], title=f"level {lv}: overviews")
    if args.json:
        print(json.dumps(rows))
    else:
        print_table(rows)
    return 0


def _round(v: float | None) -> float | None:
    return None if v is None else round(float(v), 4)


def _write(cs, out: str) -> np.ndarray:
    """Write one scene's JSON (scene + certificate), overview and start-camera PNGs; return the overview."""
    from ..viz.images import save_frame_png, save_rgb_png
    from ..sim.world import World, render_overview

    scene = cs.scene
    stem = os.path.join(out, f"level{scene.level}_{scene.index:03d}")
    os.makedirs(out, exist_ok=True)
    record = {"scene": scene.to_dict(), "certificate": certificate_record(cs), "attempts": cs.attempts}
    tmp = stem + ".json.tmp"
    with open(tmp, "w") as f:
        json.dump(record, f, indent=1)
    os.replace(tmp, stem + ".json")
    world = World(scene)
    try:
        overview = render_overview(world, 480, 360)
        save_rgb_png(overview, stem + "_overview.png")
        frame = world.render(world.robot.q_home, seg=True)
        save_frame_png(frame, stem + "_start_camera.png", world.target_label,
                       f"level {scene.level} scene {scene.index}: start wrist camera ({scene.task().target.text})")
    finally:
        world.close()
    return overview


def _width(fmt: str) -> int:
    return int(re.search(r">(\d+)", fmt).group(1))


def _cell(fmt: str, v) -> str:
    w = _width(fmt)
    if v is None:
        return f"{'-':>{w}}"
    if isinstance(v, bool):
        return f"{'yes' if v else 'no':>{w}}"
    if isinstance(v, list):
        return f"{str(tuple(v)):>{w}}"
    return fmt.format(v)


def print_table(rows: list[dict]) -> None:
    head = " ".join(f"{h:>{_width(fmt)}}" for _, h, fmt in COLUMNS)
    print(head)
    print("-" * len(head))
    for r in rows:
        print(" ".join(_cell(fmt, r[k]) for k, _, fmt in COLUMNS))
    print()
    print_summary(rows)


def print_summary(rows: list[dict]) -> None:
    """Per level: scenes, FV-solvable share and means/medians of the difficulty columns."""
    keys = ("start_visibility", "best_fixed_view_visibility", "view_visibility_fraction", "free_config_fraction",
            "views_removed_by_obstacles", "grasps_removed_by_obstacles", "n_objects")
    print(f"{'level':>5} {'scenes':>6} {'fv_solvable':>11} " + " ".join(f"{k[:14]:>14}" for k in keys)
          + f" {'appr_deg_med':>12} {'|yaw|_deg_med':>13} {'time_s_med':>10} {'time_s_p90':>10}")
    for lv in sorted({r["level"] for r in rows}):
        rs = [r for r in rows if r["level"] == lv]
        means = [np.mean([r[k] for r in rs]) for k in keys]
        appr = [r["grasp_approach_deg"] for r in rs if r["grasp_approach_deg"] is not None]
        yaw = [abs(r["grasp_yaw_deg"]) for r in rs if r["grasp_yaw_deg"] is not None]
        times = [r["time_s"] for r in rs]
        print(f"{lv:>5} {len(rs):>6} {sum(r['fv_solvable'] for r in rs) / len(rs):>11.2f} "
              + " ".join(f"{m:>14.3f}" for m in means)
              + f" {np.median(appr) if appr else float('nan'):>12.0f} {np.median(yaw) if yaw else float('nan'):>13.0f}"
              + f" {np.median(times):>10.2f} {np.percentile(times, 90):>10.2f}")
    for lv in sorted({r["level"] for r in rows}):
        rs = [r for r in rows if r["level"] == lv]
        rej = Counter(x for r in rs for x in r["rejections"])
        removed = ""
        if lv >= 3:  # per kind: the gate needs each >= the threshold on every scene
            removed = (f"; removed by base obstacles, min / mean: views {min(r['views_removed_by_obstacles'] for r in rs):.2f}"
                       f" / {np.mean([r['views_removed_by_obstacles'] for r in rs]):.2f},"
                       f" grasps {min(r['grasps_removed_by_obstacles'] for r in rs):.2f}"
                       f" / {np.mean([r['grasps_removed_by_obstacles'] for r in rs]):.2f}")
        print(f"level {lv}: rejected candidates by reason: "
              + (", ".join(f"{k} {n}" for k, n in rej.most_common()) or "none") + removed)
