"""Ground-truth certification and measured difficulty of generated scenes.

A candidate scene is accepted only when, with the simulator's ground truth (`oracle`) and the
planner's own conservative sphere model on the ground-truth geometry:
1. home is free of contacts (MuJoCo, self included) and valid for the sphere model;
1b. home clearance (`home_clearance`): nothing of the scene lies in the shell around the
   robot's spheres at home that a method's world model assumes free (its start margins,
   read from `WorldModelConfig`, plus half its voxel diagonal);
2. the start camera sees < `max_start_visibility` of the target;
3. severe levels (2, 4), if `reject_fv_solvable_severe`: no pose of the reference fixed-view
   set sees >= `min_view_visibility` (always measured and recorded as `fv_solvable`);
3b. severe levels, if `reject_outside_visible_severe`: no camera pose of the dense outside
   sample (`outside_views`: farther than AT_OPENING = 0.10 m in front of the opening plane,
   anywhere a Panda wrist reaches, looking in) sees >= `min_view_visibility` (checked after
   the grasps, which reject more candidates at lower cost; always measured at the severe
   levels); a good sampled view found later in that zone fails the scene the same way, so a
   certified severe view lies inside or at the opening;
4. a reachable grasp exists whose pre-grasp, grasp and lift and the straight segments
   between them are collision-free (checked before the views: it fails more often); at the
   severe levels with the sphere model grown by `severe_grasp_margin` (1 cm: a grasp that
   keeps only millimetres to the box below it, the rail above or the back wall is one no
   map of 1 cm voxels with a 5 mm fine map around the target can show to be free);
5. a reachable, collision-free camera pose sees >= `min_view_visibility` of the target;
   moderate levels (1, 3): one of them is reached on a path along which the camera's
   distance to the target never grows (monotonic approach, checked with step 7);
6. levels 3, 4: the base obstacles remove >= `min_obstacle_removal` of the good views and,
   on its own, of the valid grasps the same scene has without them (per kind at the
   `per_kind_obstacle_levels`, both; the severe levels' good views counted over their inside
   poses too, `view_search.search_views`, level 4's grasps over the dense neck family too,
   `dense_grasp_levels`; level 4's obstacles are aimed, `aimed_obstacles`);
7. home -> good view -> pre-grasp plan (`motion.planner.plan`), then pre-grasp -> grasp -> lift;
8. physics: following pre-grasp -> grasp, closing and lifting holds the target.
The first failing step is the certificate's `failure`; None means certified.
"""
from __future__ import annotations

import enum
import time
from dataclasses import dataclass, replace

import numpy as np

from ..errors import CompassInputError, check_field_types, instance_of, check_ranges
from ..motion.planner import PlannerConfig, plan
from ..robot.model import Q_MAX, Q_MIN
from ..types import Trajectory
from . import oracle
from .levels import check_level, generate_scene
from .oracle import GroundTruthGrasp, find_grasp  # noqa: F401  (re-exported for older callers)
from .physics import grasp_and_lift
from . import outside_views, scene_cache
from .aimed_obstacles import AIMED_LEVELS, aim, layout_samples
from .home_clearance import home_clearance
from .layout_grasps import layout_grasps
from .scenes import SceneSpec
from .view_search import best_exact_visibility, sample_view_poses, search_views  # noqa: F401
from .world import World


class NoCertifiedScene(CompassInputError):
    """No candidate of (level, index, seed) passed certification within
    `CertifyConfig.max_attempts`: the message names them, the rejections' counts and what
    to do (another seed or index); the CLI prints it as one line, a sweep records it."""


class CertFailure(enum.Enum):
    HOME_IN_COLLISION = "home configuration in collision"
    HOME_CLEARANCE = "scene geometry in the start shell a method assumes free"
    TARGET_VISIBLE_AT_START = "target visible from the start camera"
    FIXED_VIEW_SEES_TARGET = "a reference fixed view sees the target (severe level)"
    OUTSIDE_VIEW_SEES_TARGET = "a camera outside the opening sees the target (severe level)"
    NO_VIEW_SEES_TARGET = "no reachable collision-free view sees the target"
    NO_MONOTONIC_VIEW = "no good view is reached by a monotonic camera approach (moderate level)"
    NO_GRASP = "no reachable collision-free grasp"
    OBSTACLES_TOO_WEAK = "base obstacles remove too few good views or too few grasps"
    NO_PATH = "home -> view -> pre-grasp does not plan"
    LIFT_FAILED = "the grasp does not lift the target in physics"


@dataclass(frozen=True)
class CertifyConfig:
    """Sampling budget and thresholds of the certification. n_views camera poses (the uniform
    sample of the view statistics) out of n_view_poses (all searched for a good view), n_configs
    random configurations (uniform +-config_noise [rad] per joint about home), margin [m] of
    the sphere checker, plan_checks: edge checks of tree growth per planning query (the
    planner's deterministic budget, `PlannerConfig.max_checks`: the same scene on any machine
    and load; a 2 s wall-clock budget until 2026-11-24), max_grasp_candidates tried;
    view_stride: pixel stride of the coarse visibility of the sampled views, refined exactly
    where the coarse value is within view_refine_margin of min_view_visibility.
    reject_fv_solvable_severe: make step 3 a gate (on by default: the severe layout, a tall
    bottle behind a low wide box grasped by its neck, is hidden from the reference set in
    most candidates, so the gate rarely fires; docs/scenes.md). reject_outside_visible_severe:
    make step 3b a gate; n_severe_inside_views: poses inside or at the opening the severe
    levels' view search adds to its n_view_poses (`view_search.inside_view_poses`).
    severe_grasp_margin [m]: at the severe levels the grasp, its pre-grasp, lift and the
    straight segments between them (step 4) keep this clearance more than `margin` from
    everything but the target (the hand's and arm's spheres grown by it).
    check_home_clearance: make step 1b a gate (off only to measure what it rejects).
    per_kind_obstacle_levels: levels whose step 6 holds views and grasps to
    min_obstacle_removal each; the other obstacle levels count them together (both levels
    since branch l4k; level 4 counted together before). dense_grasp_levels: obstacle levels
    whose grasps are counted over the dense neck family too (`oracle.dense_neck_candidates`,
    after the max_grasp_candidates of `oracle.grasp_candidates`): the sparse family has 1-3
    valid neck grasps per severe layout, which makes a 30 % removal all or nothing; the
    dense one 2-31 (level 4's obstacles are aimed at them, `aimed_obstacles`)."""

    n_views: int = 40
    n_view_poses: int = 160
    n_configs: int = 150
    config_noise: float = 0.5
    min_view_visibility: float = 0.3
    max_start_visibility: float = 0.05
    min_obstacle_removal: float = 0.3
    max_attempts: int = 4000
    n_q7: int = 6
    n_q7_grasp: int = 12
    max_grasp_candidates: int = 24
    view_stride: int = 3
    view_refine_margin: float = 0.15
    margin: float = 0.0
    plan_checks: int = 100_000
    physics: bool = True
    reject_fv_solvable_severe: bool = True
    reject_outside_visible_severe: bool = True
    n_severe_inside_views: int = 60
    severe_grasp_margin: float = 0.01
    check_home_clearance: bool = True
    per_kind_obstacle_levels: tuple[int, ...] = (3, 4)
    dense_grasp_levels: tuple[int, ...] = (4,)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, config_noise=(0.0, 3.2, "rad"), margin=(0.0, 0.1, "m"),
                     min_view_visibility=(0.0, 2.0, ""), max_start_visibility=(0.0, 1.0, ""),  # (min view above 1:
                     min_obstacle_removal=(0.0, 1.0, ""), view_refine_margin=(0.0, 1.0, ""))  # no view passes)
        if isinstance(self.plan_checks, bool) or not isinstance(self.plan_checks, int) or not 1 <= self.plan_checks <= 10**8:
            raise CompassInputError(f"plan_checks {self.plan_checks!r} is not allowed; use a whole number 1..10**8")
        if not 0.0 <= self.severe_grasp_margin <= 0.05:
            raise CompassInputError(f"severe_grasp_margin {self.severe_grasp_margin!r} m is not allowed; use 0..0.05 m")


@dataclass(frozen=True)
class Certificate:
    """Result of certifying one scene. failure None = certified. Fractions in [0, 1].

    start_visibility: target fraction seen at home; best_fixed_view_visibility over the
    reference fixed-view set, fv_solvable when >= min_view_visibility; view_visibility_fraction:
    share of reachable sampled views that see enough; free_config_fraction: share of random
    configurations near home free for the sphere model; views/grasps_removed_by_obstacles:
    share of good views/grasps the base obstacles remove (0 without obstacles), out of
    n_good_views_without / n_grasps_without, the scene's good views (sampled and, at the
    severe levels, inside poses) and valid grasp candidates without them (-1: not counted);
    grasp_approach_deg: approach below the horizontal of the certified grasp (None if none),
    grasp_yaw_deg: its approach direction's angle about +z from the opening's inward normal +x
    (0 = straight in, +-52 = the steepest diagonal candidate; None if none);
    best_outside_view_visibility: severe levels, the best visible fraction over the dense
    outside sample (`outside_views`; None at the moderate levels, where it is not measured);
    view_camera_outside_m [m]: how far the certified view's camera stands in front of the
    opening plane (negative: inside; None if none);
    lift_height [m] in physics; plan_checks_max: the most edge checks one planning query of
    the certification used (its budget is `CertifyConfig.plan_checks`); path: waypoints (n,7) [rad] home -> view -> pre-grasp -> grasp
    -> lift with path_marks the indices of view, pre-grasp, grasp, lift; stage_times_s [s].
    """

    failure: CertFailure | None
    start_visibility: float = 0.0
    best_fixed_view_visibility: float = 0.0
    fv_solvable: bool = False
    view_visibility_fraction: float = 0.0
    n_valid_views: int = 0
    best_view_visibility: float = 0.0
    free_config_fraction: float = 0.0
    views_removed_by_obstacles: float = 0.0
    grasps_removed_by_obstacles: float = 0.0
    n_good_views_without: int = -1
    n_grasps_without: int = -1
    grasp_approach_deg: float | None = None
    grasp_yaw_deg: float | None = None
    best_outside_view_visibility: float | None = None
    view_camera_outside_m: float | None = None
    lift_height: float = 0.0
    plan_checks_max: int = 0
    n_objects: int = 0
    n_colour_distractors: int = 0
    n_shape_distractors: int = 0
    path: tuple[tuple[float, ...], ...] = ()
    path_marks: tuple[int, ...] = ()
    stage_times_s: tuple[tuple[str, float], ...] = ()
    time_s: float = 0.0

    @property
    def certified(self) -> bool:
        return self.failure is None


@dataclass(frozen=True)
class CertifiedScene:
    """An accepted scene, its certificate, the number of candidates drawn and why the
    rejected ones failed (failure names in order)."""

    scene: SceneSpec
    certificate: Certificate
    attempts: int
    rejections: tuple[str, ...] = ()


def _monotonic(kin, path: np.ndarray, target: np.ndarray, step: float = 0.02) -> bool:
    """True if the camera's distance to `target` never grows (by > 5 mm) along the path."""
    qs = [path[0]]
    for a, b in zip(path[:-1], path[1:]):
        k = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        qs.extend(a + (b - a) * (i / k) for i in range(1, k + 1))
    cams = kin.T_world_cam_batch(np.array(qs))[:, :3, 3]
    d = np.linalg.norm(cams - target, axis=1)
    return bool(np.all(np.diff(d) <= 0.005))


def certify(scene: SceneSpec, config: CertifyConfig | None = None, world: World | None = None) -> Certificate:
    """Check one scene with ground truth and measure its difficulty (deterministic per scene)."""
    config = config or CertifyConfig()
    t0 = time.perf_counter()
    own_world = world is None
    world = world or World(scene)
    try:
        return _certify(scene, config, world, t0)
    finally:
        if own_world:
            world.close()


def _certify(scene: SceneSpec, config: CertifyConfig, world: World, t0: float) -> Certificate:
    rng = np.random.default_rng(list(scene.seed) + [scene.level, scene.index, 7919])
    home = np.asarray(world.robot.q_home)
    severe, obstacles = scene.level in (2, 4), bool(scene.base_obstacles)
    stages: list[tuple[str, float]] = []
    clock = [time.perf_counter()]

    def lap(name: str) -> None:
        now = time.perf_counter()
        stages.append((name, round(now - clock[0], 4)))
        clock[0] = now

    rec = dict(n_objects=len(scene.objects),
               n_colour_distractors=sum(o.role == "colour_distractor" for o in scene.clutter),
               n_shape_distractors=sum(o.role == "shape_distractor" for o in scene.clutter))

    def done(failure, **kw):
        lap("rest")
        return Certificate(failure, **rec, **kw, stage_times_s=tuple(stages), time_s=time.perf_counter() - t0)

    full = oracle.ground_truth_checker(scene, margin=config.margin)
    no_target = oracle.ground_truth_checker(scene, exclude_target=True, margin=config.margin)
    if world.in_collision(home, include_self=True) or not full.is_valid(home):
        return done(CertFailure.HOME_IN_COLLISION)
    if config.check_home_clearance and not home_clearance(scene).ok:
        return done(CertFailure.HOME_CLEARANCE)
    rec["start_visibility"] = start = oracle.start_visibility(world)
    if start >= config.max_start_visibility:
        return done(CertFailure.TARGET_VISIBLE_AT_START)
    fv = max(oracle.fixed_view_visibilities(world))
    rec.update(best_fixed_view_visibility=fv, fv_solvable=bool(fv >= config.min_view_visibility))
    if severe and config.reject_fv_solvable_severe and rec["fv_solvable"]:
        return done(CertFailure.FIXED_VIEW_SEES_TARGET)
    lap("visibility")
    Q = np.clip(home + rng.uniform(-config.config_noise, config.config_noise, (config.n_configs, 7)), Q_MIN, Q_MAX)
    rec["free_config_fraction"] = float(np.mean(full.are_valid(Q)))
    ik = oracle.robot_ik(world.robot)
    g_margin = config.margin + (config.severe_grasp_margin if severe else 0.0)
    grasps, n_with, n_without = _grasps(world, config, ik, obstacles, g_margin)
    if obstacles:
        rec["grasps_removed_by_obstacles"] = 1.0 - n_with / n_without if n_without else 0.0
        rec["n_grasps_without"] = n_without
    lap("grasps")
    if not grasps:
        return done(CertFailure.NO_GRASP)
    per_kind = scene.level in config.per_kind_obstacle_levels
    if obstacles and per_kind and not _kind_removed(rec["grasps_removed_by_obstacles"], n_without,
                                                    config.min_obstacle_removal):
        return done(CertFailure.OBSTACLES_TOO_WEAK)  # the grasps' half of step 6, before the costly views
    if severe:
        rec["best_outside_view_visibility"] = outside_views.best_outside_visibility(
            world, config.min_view_visibility).best_visibility
        lap("outside")
        if config.reject_outside_visible_severe and rec["best_outside_view_visibility"] >= config.min_view_visibility:
            return done(CertFailure.OUTSIDE_VIEW_SEES_TARGET)
    without = oracle.ground_truth_checker(scene, base_obstacles=False, margin=config.margin) if obstacles else None
    views = search_views(world, config, rng, ik, full, without)
    reach = np.array([len(q) > 0 for q in views.q_full])
    good = reach & (views.vis >= config.min_view_visibility)
    r40, g40 = reach[:config.n_views], good[:config.n_views]  # the uniform sample
    rec.update(n_valid_views=int(r40.sum()),
               view_visibility_fraction=float(g40.sum() / r40.sum()) if r40.any() else 0.0,
               best_view_visibility=best_exact_visibility(world, views, reach))
    if obstacles:  # over all poses: the severe levels' inside poses are searched in full with obstacles
        rec["n_good_views_without"] = views.n_good_without
        rec["views_removed_by_obstacles"] = 1.0 - int(good.sum()) / views.n_good_without if views.n_good_without else 0.0
    lap("views")
    if not good.any():
        return done(CertFailure.NO_VIEW_SEES_TARGET)
    if severe:  # a good sampled view in the outside zone: the dense outside sample missed it
        out_m = np.array([outside_views.camera_outside_m(scene, T) for T in views.poses])
        seen_out = good & (out_m > outside_views.AT_OPENING)
        if seen_out.any():
            rec["best_outside_view_visibility"] = max(rec["best_outside_view_visibility"],
                                                      float(views.vis[seen_out].max()))
            if config.reject_outside_visible_severe:
                return done(CertFailure.OUTSIDE_VIEW_SEES_TARGET)
    goals = np.vstack([views.q_full[i] for i in np.nonzero(good)[0]])
    goals = goals[np.argsort(np.linalg.norm(goals - home, axis=1), kind="stable")][:24]
    if obstacles and per_kind and not _removes_enough(
            rec["views_removed_by_obstacles"], rec["grasps_removed_by_obstacles"], views.n_good_without, n_without,
            config.min_obstacle_removal):
        return done(CertFailure.OBSTACLES_TOO_WEAK)
    if obstacles and not per_kind:  # views and grasps counted together
        n_wo = views.n_good_without + n_without
        if n_wo == 0 or 1.0 - (int(good.sum()) + n_with) / n_wo < config.min_obstacle_removal:
            return done(CertFailure.OBSTACLES_TOO_WEAK)
    planner = PlannerConfig(max_checks=config.plan_checks)
    rec["plan_checks_max"] = 0

    def plan_q(q_start, goals):
        r = plan(q_start, goals, full, planner, rng)
        rec["plan_checks_max"] = max(rec["plan_checks_max"], int(r.n_checks))
        return r
    path1 = None
    if not severe:  # a monotonic approach: the straight joint segment, else a planned path
        for q in goals[:6]:
            if full.edge_valid(home, q) and _monotonic(ik.kin, np.stack([home, q]), scene.target.pos):
                path1 = np.stack([home, q])
                break
        if path1 is None:
            r = plan_q(home, goals)
            if r.success and _monotonic(ik.kin, r.path, scene.target.pos):
                path1 = r.path
        if path1 is None:
            lap("plan")
            return done(CertFailure.NO_MONOTONIC_VIEW)
    else:
        r = plan_q(home, goals)
        path1 = r.path if r.success else None
    if path1 is None:
        lap("plan")
        return done(CertFailure.NO_PATH)
    if world.visibility_from(ik.kin.T_world_cam(path1[-1]), with_robot=False) < config.min_view_visibility:
        lap("plan")  # the certified view, exactly (the search used coarse rays far from the threshold)
        return done(CertFailure.NO_VIEW_SEES_TARGET)
    r2 = plan_q(path1[-1], np.stack([g.q_pregrasp for g in grasps]))
    lap("plan")
    if not r2.success:
        return done(CertFailure.NO_PATH)
    order = [r2.goal_index] + [i for i in range(len(grasps)) if i != r2.goal_index][:1]
    for k, gi in enumerate(order):
        g = grasps[gi]
        if k > 0:  # the second choice needs its own path
            r2 = plan_q(path1[-1], g.q_pregrasp[None])
            if not r2.success:
                continue
        out = grasp_and_lift(world, g.q_pregrasp, _line(g.q_pregrasp, g.q_grasp), _line(g.q_grasp, g.q_lift)) \
            if config.physics else None
        if out is None or out.lifted:
            path = np.vstack([path1, r2.path[1:], g.q_grasp[None], g.q_lift[None]])
            marks = (len(path1) - 1, len(path1) + len(r2.path) - 2, len(path) - 2, len(path) - 1)
            lap("physics")
            world.set_q(home)
            T_cam = ik.kin.T_world_cam(path1[-1])
            return done(None, grasp_approach_deg=g.approach_deg, grasp_yaw_deg=_yaw_deg(g),
                        view_camera_outside_m=round(outside_views.camera_outside_m(scene, T_cam), 4),
                        lift_height=out.lift_height if out else 0.0,
                        path=tuple(tuple(float(v) for v in q) for q in path), path_marks=marks)
    lap("physics")
    world.set_q(home)
    return done(CertFailure.LIFT_FAILED, grasp_approach_deg=grasps[0].approach_deg)


def _kind_removed(removed: float, n_without: int, min_removal: float) -> bool:
    """Step 6 for one kind (good views or valid grasps): the scene has some without the base
    obstacles and the obstacles remove >= min_removal of them."""
    return n_without > 0 and removed >= min_removal


def _removes_enough(views_removed: float, grasps_removed: float, n_views_without: int, n_grasps_without: int,
                    min_removal: float) -> bool:
    """Step 6, per kind: `_kind_removed` for the good views and, on its own, for the grasps."""
    return (_kind_removed(views_removed, n_views_without, min_removal)
            and _kind_removed(grasps_removed, n_grasps_without, min_removal))


def _yaw_deg(g: GroundTruthGrasp) -> float:
    """Approach direction's angle [deg] about +z from +x (the opening's inward normal)."""
    a = g.T_world_tcp[:3, 2]
    return round(float(np.degrees(np.arctan2(a[1], a[0]))), 1)


def _line(a: np.ndarray, b: np.ndarray, duration: float = 1.2) -> Trajectory:
    return Trajectory(np.array([0.0, duration]), np.stack([a, b]))


def _grasps(world: World, config: CertifyConfig, ik, obstacles: bool, margin: float):
    """Valid ground-truth grasps (at most 4 kept unless counting), checked with the sphere
    model grown by margin [m], and, with base obstacles, the number of candidates valid with
    and without them (all candidates are then evaluated; at the dense_grasp_levels the dense
    neck family too). With base obstacles the layout's part of the work is shared among its
    obstacle draws (`layout_grasps`: the same answers as checking each draw in full)."""
    scene = world.scene
    home = np.asarray(world.robot.q_home)
    found: list[GroundTruthGrasp] = []
    n_with = n_without = 0
    candidates = oracle.grasp_candidates(scene)[:config.max_grasp_candidates]
    if not obstacles:
        full = oracle.ground_truth_checker(scene, margin=margin)
        no_target = oracle.ground_truth_checker(scene, exclude_target=True, margin=margin)
        for T, deg in candidates:
            sols = oracle.grasp_solutions(ik, T, home, config.n_q7_grasp)
            g = oracle.first_valid_grasp(ik, T, sols, full, no_target, world)
            if g is not None:
                found.append(GroundTruthGrasp(T, deg, *g))
                if len(found) >= 4:
                    break
        return found, n_with, n_without
    if scene.level in config.dense_grasp_levels:
        candidates += oracle.dense_neck_candidates(scene)
    shared = layout_grasps(scene, ik, home, config.n_q7_grasp, margin)
    obs = oracle.obstacle_checker(scene, margin)
    for T, deg in candidates:  # valid with obstacles (and in MuJoCo) only if valid without them
        if shared.first_valid_with(T, None) is None:
            continue
        n_without += 1
        if shared.first_valid_with(T, obs) is None:
            continue
        n_with += 1
        g = shared.first_valid_with(T, obs, world)
        if g is not None:
            found.append(GroundTruthGrasp(T, deg, *(np.array(a, copy=True) for a in g)))
    return found, n_with, n_without


#: Levels 3/4: base-obstacle draws tried on one layout (cabinet and objects) before the next.
OBSTACLE_DRAWS = 8
#: A rejection (in `CertifiedScene.rejections`) of an aimed level's sub-seed whose obstacle
#: draws were none predicted to pass (`aimed_obstacles.aim`): not certified.
NOT_AIMED = "OBSTACLES_NOT_AIMED"


def _other_obstacles_may_pass(scene: SceneSpec, cert: Certificate, per_kind_levels: tuple[int, ...]) -> bool:
    """Whether the same layout with other base obstacles could pass: False when the failure
    does not depend on the obstacles (the target seen from the start or from outside, the
    face frame in the start shell) or when no obstacles can satisfy the per-kind gate (at
    most one valid grasp or good view without them: removing >= 30 % would leave none)."""
    f = cert.failure
    if f in (CertFailure.TARGET_VISIBLE_AT_START, CertFailure.FIXED_VIEW_SEES_TARGET,
             CertFailure.OUTSIDE_VIEW_SEES_TARGET):
        return False
    if f is CertFailure.HOME_CLEARANCE:
        h = home_clearance(scene)
        return h.cabinet_m >= h.required_cabinet_m
    if scene.level in per_kind_levels and (0 <= cert.n_grasps_without <= 1 or 0 <= cert.n_good_views_without <= 1):
        return False
    return True


def certified_scene(level: int, index: int, seed: int = 0, config: CertifyConfig | None = None,
                    cache: bool = True, refresh: bool = False) -> CertifiedScene:
    """The first candidate of (seed, level, index) that passes certification.

    Sub-seed k uses `np.random.default_rng([seed, level, index, k])`; the accepted sub-seed
    is stored in `SceneSpec.seed`, so `regenerate(scene.seed)` gives the same scene. At
    levels 3/4 sub-seeds k come in groups of OBSTACLE_DRAWS that share one layout and differ
    in the base obstacles (`regenerate`); a group is left early when its layout fails for a
    reason no obstacle draw changes (`_other_obstacles_may_pass`). attempts: candidates
    certified (rejections + 1).
    cache: read and write the disk cache of certified scenes (`sim.scene_cache`); False
    certifies afresh without touching the cache; refresh certifies afresh (e.g. to measure
    certification time) and writes the entry (with cache).
    """
    level = check_level(level)
    config = instance_of(config, CertifyConfig, "config", CertifyConfig())
    for name, flag in (("cache", cache), ("refresh", refresh)):
        if not isinstance(flag, (bool, np.bool_)):
            raise CompassInputError(f"{name} = {flag!r:.40} is not allowed; use True or False")
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise CompassInputError(f"scene index {index!r} is not allowed; use an integer >= 0")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise CompassInputError(f"seed {seed!r} is not allowed; use an integer >= 0")
    path = scene_cache.entry_path(level, int(index), int(seed), config)
    if cache and not refresh and (hit := scene_cache.load(path, Certificate, CertFailure)) is not None:
        return CertifiedScene(*hit)
    rejections = []
    attempt = 0
    while attempt < config.max_attempts:
        scene = regenerate((int(seed), level, int(index), attempt))
        cert = None if scene.extra.get("aim_draws") == 0 else certify(scene, config)
        if cert is not None and cert.certified:
            if cache:
                scene_cache.store(path, scene, cert, len(rejections) + 1, rejections)
            return CertifiedScene(scene, cert, len(rejections) + 1, tuple(rejections))
        rejections.append(cert.failure.name if cert is not None else NOT_AIMED)
        attempt += 1
        if cert is None:  # no obstacle draw predicted to pass: the layout's other draws, then the next layout
            if not _aim_possible(scene):
                attempt += (OBSTACLE_DRAWS - attempt % OBSTACLE_DRAWS) % OBSTACLE_DRAWS
            continue
        if level >= 3 and attempt % OBSTACLE_DRAWS and not _other_obstacles_may_pass(scene, cert, config.per_kind_obstacle_levels):
            attempt += OBSTACLE_DRAWS - attempt % OBSTACLE_DRAWS  # the next layout
    counts = sorted({r: rejections.count(r) for r in rejections}.items(), key=lambda kv: -kv[1])
    raise NoCertifiedScene(
        f"no certified scene for level {level}, index {index}, seed {seed} within {config.max_attempts} "
        f"attempts ({len(rejections)} candidates rejected: "
        + ", ".join(f"{r} {n}" for r, n in counts[:4])
        + "); use another seed or scene index"
    )


def _aim_possible(scene: SceneSpec) -> bool:
    """Whether the layout has >= 2 sampled good views and >= 2 valid grasps (`aimed_obstacles`)."""
    seed, level, index, attempt = scene.seed
    s = layout_samples(seed, level, index, attempt // OBSTACLE_DRAWS)
    return len(s.views) >= 2 and len(s.grasps) >= 2


def regenerate(sub_seed: tuple[int, int, int, int]) -> SceneSpec:
    """The candidate scene of a sub-seed (seed, level, index, attempt). Levels 3/4: the layout
    from (seed, level, index, attempt // OBSTACLE_DRAWS), the base obstacles from (seed,
    level, index, attempt, 1); at the `aimed_obstacles.AIMED_LEVELS` (4) they are aimed
    instead: the first of AIM_DRAWS draws from (seed, level, index, attempt, 2) predicted to
    pass the per-kind gate (`extra["aim_draws"]`: draws used, 0 when none was: the blind draw
    is kept and `certified_scene` does not certify it)."""
    seed, level, index, attempt = (int(s) for s in sub_seed)
    if level >= 3:
        scene = generate_scene(level, index, np.random.default_rng([seed, level, index, attempt // OBSTACLE_DRAWS]),
                               np.random.default_rng([seed, level, index, attempt, 1]))
        if level in AIMED_LEVELS:
            aimed = aim(scene, layout_samples(seed, level, index, attempt // OBSTACLE_DRAWS),
                        np.random.default_rng([seed, level, index, attempt, 2]))
            scene = aimed if aimed is not None else replace(scene, extra={**scene.extra, "aim_draws": 0})
    else:
        scene = generate_scene(level, index, np.random.default_rng([seed, level, index, attempt]))
    return replace(scene, seed=(seed, level, index, attempt))
