"""Run one trial: `run_trial(TrialSpec(method, level, scene, trial, seed), config)`.

The scene is the certified scene (level, scene index, seed); trials of one scene differ by
their trial seed: the method's generator is `np.random.default_rng(SeedSequence((seed,
level, scene, trial)))`. The result's metrics may consult the simulator's oracle (truth of
the accepted detection, the target's surroundings); the method never does.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..errors import CompassInputError, instance_of
from ..exploration.registry import available_methods, make_method
from ..perception.buffer import DetectionBuffer
from ..perception.detector import DETECTORS
from ..perception.self_mask import SelfMaskedDetector
from ..robot.kinematics import PandaKinematics
from ..robot.spheres import panda_sphere_model
from ..sim.certify import certified_scene
from ..sim.levels import check_level
from ..sim.oracle import OracleSegmentationDetector, detection_is_target, target_surroundings
from ..sim.world import World
from .config import GRASP_ABLATION_METHOD, ORACLE_DETECTOR, TrialConfig
from .grasp_stage import assumed_unknown_free, run_grasp_stage
from .grasp_map import GraspMap, GraspWorld
from .grasp_looks import BaseLooks
from .grasp_scan import NearFieldScanner, survey_checker
from .grasp_views import GraspInspector
from .inspect import plan_inspect_view
from .verify import LookPlanner
from .machine import MachineOutcome, TrialMachine
from .metrics import MetricsRecorder
from .observer import _EVENTS, ObserverGroup
from .oracle_method import ORACLE_METHOD, make_oracle_method
from .result import TrialFailure, TrialResult


@dataclass(frozen=True)
class TrialSpec:
    """One trial: a registered method (`trial_methods()`), level 1..4, scene index, trial
    index and base seed (each an int 0 <= x < 2**63); checked when built (`check_spec`)."""

    method: str
    level: int
    scene: int
    trial: int = 0
    seed: int = 0

    def __post_init__(self) -> None:
        check_spec(self)


def trial_methods() -> tuple[str, ...]:
    """Every method a trial can run: the registered exploration methods, the grasp ablation
    (COMPASS, unconstrained grasp selection) and the oracle reference (built here, never by
    the registry, so no method package can reach it)."""
    return (*available_methods(), GRASP_ABLATION_METHOD, ORACLE_METHOD)


def check_spec(spec: TrialSpec) -> TrialSpec:
    """Raise CompassInputError (one line naming what is allowed) on a bad spec."""
    if not isinstance(spec, TrialSpec):
        raise CompassInputError(f"spec = {spec!r:.60} is not allowed; "
                                "use a TrialSpec(method, level, scene, trial, seed)")
    if spec.method not in trial_methods():
        names = ", ".join(trial_methods())
        raise CompassInputError(f"method {spec.method!r} is not registered; use one of {names}")
    check_level(spec.level)
    for name in ("scene", "trial", "seed"):
        v = getattr(spec, name)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 <= v < 2**63:
            raise CompassInputError(f"{name} {v!r} is not allowed; use an integer 0 <= {name} < 2**63")
    return spec


def trial_rng(spec: TrialSpec) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence((spec.seed, spec.level, spec.scene, spec.trial)))


@dataclass(frozen=True, eq=False)
class TrialRun:
    """A result with what the CLI draws and the benchmark reads: the machine's outcome,
    the scene and the metrics recorder (per-decision compute times and phases)."""

    result: TrialResult
    outcome: MachineOutcome
    scene: object
    metrics: MetricsRecorder


def run_trial(spec: TrialSpec, config: TrialConfig | None = None, progress=None) -> TrialResult:
    """Run one trial and return its metrics."""
    return run_trial_full(spec, config, progress).result


def run_trial_full(spec: TrialSpec, config: TrialConfig | None = None, progress=None, observer=None) -> TrialRun:
    """Run one trial; `observer` (a `trial.observer.TrialObserver`, e.g. a video or Rerun
    recorder) is told of every event and closed at the end, also when the trial raises."""
    config = instance_of(config, TrialConfig, "config", TrialConfig())
    check_spec(spec)
    if progress is not None and not callable(progress):
        raise CompassInputError(f"progress = {progress!r:.40} is not allowed; use None or a function of one line")
    missing = [] if observer is None else [e for e in (*sorted(_EVENTS), "close")
                                           if not callable(getattr(observer, e, None))]
    if missing:
        raise CompassInputError(f"observer {type(observer).__name__} has no {', '.join(missing)}; use None or a "
                                "trial.observer.TrialObserver")
    method_name = spec.method
    if spec.method == GRASP_ABLATION_METHOD:
        method_name = "compass"
        select = replace(config.grasp.select, constrained=False)
        config = replace(config, grasp=replace(config.grasp, select=select))
    wall0 = time.perf_counter()
    scene = certified_scene(spec.level, spec.scene, spec.seed).scene
    world = World(scene)
    task = scene.task(config.time_limit_s)
    rng = trial_rng(spec)
    q0 = np.asarray(world.robot.q_home, float)
    # issue 10: the oracle reference is given the target's true pose here (never via the registry)
    if spec.method == ORACLE_METHOD:
        method = make_oracle_method(scene, task, config.method, rng, q0, world.camera.K)
    else:
        method = make_method(method_name, task, config.method, rng, q0, world.camera.K)
    oracle = config.detector_kind == ORACLE_DETECTOR
    detector = OracleSegmentationDetector(world.target_label) if oracle else SelfMaskedDetector(
        DETECTORS[config.detector_kind](config.detector), panda_sphere_model(world.robot))
    buffer = DetectionBuffer(detector, task.target, config.buffer)
    metrics = MetricsRecorder(PandaKinematics(world.robot), target_surroundings(scene, config.surroundings_margin))
    grasp, inspect = None, None
    own = getattr(getattr(method, "world", None), "kin", None)  # methods with their own world model
    gmap = GraspMap(world.robot, task=task) if config.grasp.enabled and config.grasp.grasp_map else None
    observers = observer if gmap is None else ObserverGroup([gmap] + ([observer] if observer is not None else []))
    n_inspect = config.grasp.inspect.n_views
    rules = method.world.config if own is not None else None  # the method's rules for unknown space
    if config.grasp.enabled and config.grasp.inspect.n_views > 0 and own is not None:
        outward = np.asarray(task.space.outward, float)
        insp_rng = np.random.default_rng(np.random.SeedSequence((spec.seed, spec.level, spec.scene, spec.trial, 12)))

        if config.grasp.inspect.mode == "grasp":  # the grasp hypotheses' unknown voxels (trial.grasp_views)
            spheres, q_home = panda_sphere_model(world.robot), np.asarray(world.robot.q_home)
            near = None if not (config.grasp.near_body_free or config.grasp.outside_free) else (
                lambda occ: assumed_unknown_free(occ, config.grasp, spheres, q_home, task, rules))
            wm = method.world if gmap is None else GraspWorld(
                gmap, method.world, config.grasp.fine_margin if config.grasp.fine_map else None,
                config.grasp.select.field_upsample)
            inspect = GraspInspector(wm, world.camera.K, task, config.grasp.target, config.grasp.select,
                                     config.grasp.inspect, insp_rng, near)
        else:
            def inspect(q, detection):  # on the method's own map and validity checker
                return plan_inspect_view(method.world.checker, method.world.kin, method.occupancy, world.camera.K,
                                         detection.points_world, outward, q, config.grasp.inspect, insp_rng)
    if gmap is not None and config.grasp.scan.max_views > 0 and own is not None:  # near-field scan first
        scan_rng = np.random.default_rng(np.random.SeedSequence((spec.seed, spec.level, spec.scene, spec.trial, 13)))
        survey = None
        if config.grasp.scan.assumed_free:  # the scan may stand where the grasp's assumption lets the arm go
            sph, qh = panda_sphere_model(world.robot), np.asarray(world.robot.q_home)
            survey = lambda: survey_checker(method.world, lambda occ: assumed_unknown_free(  # noqa: E731
                occ, config.grasp, sph, qh, task, None))
        inspect = NearFieldScanner(lambda: gmap.occ, method.world, world.camera.K,
                                   (world.camera.width, world.camera.height), world.robot.q_home,
                                   world.robot.base_pos, config.grasp.scan, scan_rng, then=inspect,
                                   way_of=lambda: gmap.way, checker_of=survey)
        if isinstance(inspect.then, GraspInspector):  # INSPECT scores the way's neighbours too
            inspect.then.more_candidates = inspect.near_way
        n_inspect += config.grasp.scan.max_views
    if config.grasp.looks.max_looks > 0 and own is not None:  # looks outside the cabinet when INSPECT ends
        scanner = inspect if isinstance(inspect, NearFieldScanner) else None
        inner = scanner.then if scanner is not None else inspect
        if isinstance(inner, GraspInspector):
            looks_rng = np.random.default_rng(np.random.SeedSequence((spec.seed, spec.level, spec.scene, spec.trial,
                                                                      15)))
            n0 = n_inspect  # INSPECT keeps every call it had; the looks, the way back and one more call on top
            looks = BaseLooks(inner, task, config.grasp.looks, looks_rng,
                              inner_budget=lambda: n0 - (scanner.views if scanner is not None else 0))
            if scanner is not None:
                scanner.then = looks
            else:
                inspect = looks
            n_inspect += config.grasp.looks.max_looks + 2
    if config.grasp.enabled:
        grasp_rng = np.random.default_rng(np.random.SeedSequence((spec.seed, spec.level, spec.scene, spec.trial, 11)))
        charge = None if config.clock.measured else config.clock.planning_charge_s

        inspector = inspect.then if isinstance(inspect, NearFieldScanner) else inspect
        inspector = inspector.inspector if isinstance(inspector, BaseLooks) else inspector

        looker = None
        if config.grasp.verify is not None and own is not None:  # look before moving (trial.verify)
            look_rng = np.random.default_rng(np.random.SeedSequence((spec.seed, spec.level, spec.scene, spec.trial, 14)))
            looker = LookPlanner(method.world, world.camera.K, world.robot.base_pos, config.grasp.verify, look_rng)
        grasp_config = config.grasp if own is not None else replace(config.grasp, verify=None)

        def grasp(q, detection, moved, look=None):  # INSPECT's grasp hypotheses are checked first
            pinned = inspector.pinned if isinstance(inspector, GraspInspector) else None
            sweeps = inspector.ik_sweeps if isinstance(inspector, GraspInspector) else None
            swept = None if own is None else (lambda: method.world.swept) if gmap is None else (lambda: gmap.swept)
            grasp_occ = method.occupancy if gmap is None else gmap.occ  # every frame so far integrated
            return run_grasp_stage(world, grasp_occ, detection, task, q, moved, grasp_config, grasp_rng, charge,
                                   grasp_map=gmap, pinned=pinned, method_rules=rules, looker=looker, look=look,
                                   method_swept=swept, ik_sweeps=sweeps)
    try:
        outcome = TrialMachine(world, method, buffer, metrics, config, progress, pass_frames=oracle,
                               grasp=grasp, observer=observers,
                               inspect=inspect, n_inspect=n_inspect).run()
    finally:
        buffer.close()
        world.close()
        if observer is not None:
            observer.close()
    failure = outcome.failure
    true_det = None
    if outcome.found is not None:
        true_det = detection_is_target(scene, outcome.found.detection)
        if not true_det:
            failure = TrialFailure.FALSE_DETECTION
    found = outcome.found is not None and bool(true_det)
    limit = config.time_limit_s
    t_find = outcome.t_found if found else limit
    pft = metrics.path_length_at(outcome.t_found if found else min(outcome.t_end, limit))
    g = outcome.grasp
    med, p90 = metrics.decision_ms()
    result = TrialResult(
        method=spec.method, level=spec.level, scene=spec.scene, trial=spec.trial, seed=spec.seed, failure=failure,
        tft_s=t_find, pft_m=pft, mpsr=metrics.mpsr, am=metrics.am, gpq=None if g is None else g.gpq,
        collisions=metrics.collisions,
        explored_curve=tuple(metrics.explored), decisions=metrics.decisions, planning_ms_median=med,
        planning_ms_p90=p90, wall_s=time.perf_counter() - wall0, true_detection=true_det,
        found=found, grasp_s=None if g is None else g.duration_s, lift_m=None if g is None else g.lift_m,
        grasp_looks=None if g is None else g.n_looks,
    )
    return TrialRun(result, outcome, scene, metrics)
