"""`compass run`: one trial of a registered method on a certified scene, with its metrics."""
from __future__ import annotations

import json
import os
import sys

from ..errors import CompassInputError
from ..paths import check_output_dir, check_output_file

HELP = "run one trial (find, then grasp) of an exploration method and print its metrics"


def add_arguments(p) -> None:
    p.add_argument("--method", default=None, help="registered method (default compass)")
    p.add_argument("--level", type=int, required=True, help="difficulty level 1..4")
    p.add_argument("--scene", type=int, required=True, help="scene index >= 0")
    p.add_argument("--seed", type=int, default=0, help="base seed of the scene set (default 0)")
    p.add_argument("--trial", type=int, default=0, help="trial index >= 0 (its own random stream)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument("--time-limit", type=float, default=None, help="simulated time limit [s] (default 200)")
    p.add_argument("--out", default=None, help="folder for result.json and the PNGs")
    p.add_argument("--video", default=None, metavar="PATH.mp4",
                   help="write an MP4 of the trial on the simulated timeline (10 frames per simulated second)")
    p.add_argument("--record", default=None, metavar="PATH.rrd",
                   help="write a Rerun recording (needs the [viz] extra: rerun-sdk)")
    p.add_argument("--find-only", action="store_true", help="stop at FOUND (no GRASP state)")
    p.add_argument("--grasp-only", action="store_true",
                   help="grasp alone: start from a view that sees the target (picked by the oracle)")
    p.add_argument("--unconstrained", action="store_true",
                   help="grasp selection without the paper's constraints (its ablation)")


def check_out(out: str | None) -> str | None:
    """The output folder (created), or None; one-line CompassInputError if it cannot be written."""
    return None if out is None else check_output_dir(out)


def check_media_path(path: str | None, option: str, suffix: str) -> str | None:
    """The absolute path of a video / recording file to write (its folder must exist and be
    writable, the name must end in `suffix`), or None; one-line CompassInputError otherwise."""
    if path is None:
        return None
    check_media_name(path, option, suffix)
    return check_output_file(path, option)


def check_media_name(path: str | None, option: str, suffix: str) -> None:
    """One-line CompassInputError unless `path` is None or a file name ending in `suffix`
    (more than the suffix alone). Touches nothing on disk."""
    name = "" if path is None else os.path.basename(os.fspath(path))
    if path is not None and (not name.lower().endswith(suffix) or len(name) == len(suffix)):
        raise CompassInputError(f"{option} {path!r} is not allowed; give a file name ending in {suffix}")


def run_checked_trial(command: str, spec_args: tuple, time_limit: float, out: str | None,
                      video: str | None = None, record: str | None = None,
                      find_only: bool = False, constrained: bool = True):
    """Check a trial's spec, time limit [s], output folder, video and recording paths (and
    that rerun-sdk is installed for a recording) before any work, run it with a progress
    line on stderr; returns (TrialRun, TrialConfig, output folder or None).
    find_only: no GRASP state; constrained False: the grasp selection's ablation."""
    from ..trial.runner import TrialSpec, check_spec

    spec = check_spec(TrialSpec(*spec_args))
    if not 0 < time_limit <= 3600:
        raise CompassInputError(f"--time-limit {time_limit} s is not allowed; use 0 < limit <= 3600 s")
    check_media_name(video, "--video", ".mp4")  # what needs no disk first: a bad name leaves no --out folder
    check_media_name(record, "--record", ".rrd")
    if record is not None:
        from ..viz.rerun_log import require_rerun

        require_rerun()
    out = check_out(out)  # created here: demo's video lies in it
    video = check_media_path(video, "--video", ".mp4")
    record = check_media_path(record, "--record", ".rrd")
    from ..grasp.select import GraspSelectConfig
    from ..trial.config import GraspTrialConfig, TrialConfig
    from ..trial.observer import ObserverGroup
    from ..trial.runner import run_trial_full

    grasp = GraspTrialConfig(enabled=not find_only, select=GraspSelectConfig(constrained=constrained))
    config = TrialConfig(time_limit_s=time_limit, grasp=grasp)
    title = f"{spec.method} L{spec.level} s{spec.scene} t{spec.trial}"
    observers = []
    if video is not None:
        from ..viz.video import VideoRecorder

        observers.append(VideoRecorder(video, title=title))
    if record is not None:
        from ..viz.rerun_log import RerunRecorder

        observers.append(RerunRecorder(record, title=title))
    print(f"compass {command}: {spec.method} on level {spec.level} scene {spec.scene} trial {spec.trial} "
          f"seed {spec.seed}", file=sys.stderr)
    result_run = run_trial_full(spec, config, lambda line: print(f"\r  {line}", end="", file=sys.stderr, flush=True),
                                observer=ObserverGroup(observers) if observers else None)
    print("", file=sys.stderr)
    for option, path in (("video", video), ("recording", record)):
        if path is not None:
            print(f"compass {command}: {option} written to {path}", file=sys.stderr)
    return result_run, config, out


def run_grasp_only(args) -> int:
    """`--grasp-only`: the grasp-only harness on the certified scene (oracle start view)."""
    from ..grasp.select import GraspSelectConfig
    from ..sim.certify import certified_scene
    from ..sim.grasp_only import GraspOnlyConfig, run_grasp_only as harness
    from ..sim.levels import check_level
    from ..trial.runner import TrialSpec, check_spec

    given = [opt for opt, used in (("--find-only", args.find_only), ("--out", args.out is not None),
                                   ("--method", args.method not in (None, "compass")),
                                   ("--time-limit", args.time_limit is not None), ("--video", args.video is not None),
                                   ("--record", args.record is not None)) if used]
    if given:
        raise CompassInputError(f"--grasp-only does not take {', '.join(given)}; it runs COMPASS's grasp alone "
                                "from an oracle view (allowed with it: --level --scene --seed --trial --json "
                                "--unconstrained)")
    check_level(args.level)
    spec = check_spec(TrialSpec("compass", args.level, args.scene, args.trial, args.seed))
    scene = certified_scene(spec.level, spec.scene, spec.seed).scene
    print(f"compass run --grasp-only: level {spec.level} scene {spec.scene} trial {spec.trial} seed {spec.seed} "
          f"(start view chosen by the oracle)", file=sys.stderr)
    config = GraspOnlyConfig(select=GraspSelectConfig(constrained=not args.unconstrained))
    record = {"level": spec.level, "scene": spec.scene, "trial": spec.trial, "seed": spec.seed,
              "constrained": not args.unconstrained, **harness(scene, config, seed=spec.trial).to_dict()}
    if args.json:
        print(json.dumps(record))
    else:
        for k, v in record.items():
            print(f"{k:>20}: {v}")
    return 0


def run(args) -> int:
    if args.grasp_only:
        return run_grasp_only(args)
    if args.find_only and args.unconstrained:
        raise CompassInputError("--unconstrained changes the grasp selection, which --find-only skips; "
                                "give one of them")
    method = "compass" if args.method is None else args.method
    from ..trial.config import GRASP_ABLATION_METHOD

    if args.find_only and method == GRASP_ABLATION_METHOD:
        raise CompassInputError(f"--method {method} differs from compass only in its grasp, which --find-only "
                                "skips; give one of them")
    time_limit = 200.0 if args.time_limit is None else args.time_limit
    result_run, config, out = run_checked_trial(
        "run", (method, args.level, args.scene, args.trial, args.seed), time_limit, args.out,
        video=args.video, record=args.record,
        find_only=args.find_only, constrained=not args.unconstrained)
    record = result_run.result.to_dict()
    if out is not None:
        save_trial(result_run, config, out)
    if args.json:
        print(json.dumps(record))
    else:
        for k, v in record.items():
            if k == "explored_curve":
                v = f"{len(v)} points, final {v[-1][1] if v else None}"
            print(f"{k:>20}: {v}")
        if out is not None:
            print(f"{'outputs':>20}: {os.path.abspath(out)}")
    return 0


def save_trial(result_run, config, out: str) -> dict:
    """Write result.json, camera_path.png and explored.png; return their paths."""
    from ..sim.world import World, render_overview
    from ..trial.plots import save_camera_path_png, save_explored_png

    r = result_run.result
    paths = {k: os.path.join(out, n) for k, n in
             (("json", "result.json"), ("camera_path", "camera_path.png"), ("explored", "explored.png"))}
    with open(paths["json"], "w") as f:
        json.dump({"result": r.to_dict(), "config": config.to_dict(), "scene": result_run.scene.to_dict(),
                   "states": [s.value for s in result_run.outcome.states]}, f, indent=1)
    world = World(result_run.scene)
    try:
        world.set_q(result_run.outcome.q_end)
        overview = render_overview(world)
    finally:
        world.close()
    grasped = r.found and r.grasp_s is not None
    grasp_note = ", " + (r.failure.name.lower() if r.failure else "grasped") if grasped else ""
    title = (f"{r.method}, level {r.level} scene {r.scene} trial {r.trial}: "
             f"{'found at %.1f s' % r.tft_s if r.found else r.failure.name.lower()}"
             f"{grasp_note}")
    save_camera_path_png(result_run.scene, overview, result_run.outcome.camera_path, paths["camera_path"], title)
    save_explored_png(r.explored_curve, paths["explored"], r.tft_s if r.found else None,
                      config.time_limit_s)
    return {k: os.path.abspath(v) for k, v in paths.items()}
