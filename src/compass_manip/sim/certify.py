"""Ground-truth certification and measured difficulty of generated scenes.

A scene is accepted only when, with the simulator's ground truth:
(a) the target is hidden from the start camera (visible fraction < `max_start_visibility`);
(b) at least one collision-free, reachable camera pose sees >= `min_view_visibility` of the
    target's unoccluded image area;
(c) at least one collision-free, reachable grasp of the target exists;
and the home configuration is collision-free. Otherwise the next sub-seed is drawn.

Difficulty figures recorded per scene: the start visibility, the fraction of sampled
reachable collision-free camera poses aimed near the target that see it, and the fraction
of random joint configurations near home that are free of contact with the scene.
"""
from __future__ import annotations

import enum
import time
from dataclasses import dataclass, replace

import frankik
import numpy as np

from ..errors import CompassInputError
from ..geometry import inv_T, look_at, make_T, rot_z
from ..robot.model import GRIPPER_MAX_WIDTH, Q_MAX, Q_MIN, T_HAND_TCP, T_world_base, RobotConfig
from .levels import check_level, generate_scene
from .scenes import SceneSpec
from .world import World

#: The hand is mounted on the flange (panda_link8) rotated -45 deg about z.
T_FLANGE_HAND = make_T(rot_z(-np.pi / 4))


class CertFailure(enum.Enum):
    NONE = "none"
    HOME_IN_COLLISION = "home configuration in collision"
    TARGET_VISIBLE_AT_START = "target visible from the start camera"
    NO_VIEW_SEES_TARGET = "no reachable collision-free view sees the target"
    NO_GRASP = "no reachable collision-free grasp"


@dataclass(frozen=True)
class CertifyConfig:
    """Sampling budget and thresholds of the certification."""

    n_views: int = 48
    n_configs: int = 150
    config_noise: float = 0.5  # [rad], uniform per joint around home
    min_view_visibility: float = 0.3
    max_start_visibility: float = 0.05
    max_attempts: int = 60
    q7_samples: int = 9


@dataclass(frozen=True)
class Certificate:
    """Result of certifying one scene (all fractions in [0, 1])."""

    certified: bool
    failure: CertFailure
    start_visibility: float
    view_visibility_fraction: float
    n_valid_views: int
    best_view_visibility: float
    free_config_fraction: float
    grasp_found: bool
    time_s: float


@dataclass(frozen=True)
class CertifiedScene:
    scene: SceneSpec
    certificate: Certificate
    attempts: int


def ik_world(world: World, T_world_hand: np.ndarray, q_ref: np.ndarray, n_q7: int) -> list[np.ndarray]:
    """All analytic IK solutions (frankik, q7 sweep) for a hand pose, nearest to q_ref first."""
    T_base_flange = inv_T(T_world_base(world.robot)) @ T_world_hand @ inv_T(T_FLANGE_HAND)
    sols = []
    for q7 in np.linspace(Q_MIN[6] + 0.05, Q_MAX[6] - 0.05, n_q7):
        cand = np.asarray(frankik.ik_full(T_base_flange, q_ref, float(q7)))
        for q in cand:
            if np.all(np.isfinite(q)) and np.all(q >= Q_MIN) and np.all(q <= Q_MAX):
                sols.append(q)
    sols.sort(key=lambda q: float(np.sum((q - q_ref) ** 2)))
    return sols


def _free_solution(world: World, T_world_hand, q_ref, n_q7, finger_width=None, check_pos=None):
    for q in ik_world(world, T_world_hand, q_ref, n_q7):
        if world.in_collision(q, finger_width, include_self=True):
            continue
        if check_pos is not None and np.linalg.norm(check_pos(world) - T_world_hand[:3, 3]) > 0.01:
            continue  # analytic model and MJCF disagree here
        return q
    return None


def _sample_views(world: World, cfg: CertifyConfig, rng: np.random.Generator) -> list[float]:
    """Visible fractions of the target from sampled reachable, collision-free camera poses."""
    scene = world.scene
    lo, hi = np.array(scene.cabinet.interior_min), np.array(scene.cabinet.interior_max)
    target = np.array(scene.target.pos)
    T_hand_cam = world.camera.T_hand_cam
    q_home = np.asarray(world.robot.q_home)
    out = []
    for _ in range(cfg.n_views):
        eye = np.array([
            rng.uniform(lo[0] - 0.25, lo[0] + 0.5 * (hi[0] - lo[0])),
            rng.uniform(lo[1] + 0.06, hi[1] - 0.06),
            rng.uniform(lo[2] + 0.06, hi[2] + 0.1),
        ])
        if eye[0] > lo[0] - 0.03:
            eye[2] = min(eye[2], hi[2] - 0.05)
        aim = target + rng.normal(0.0, 0.02, 3)
        if np.linalg.norm(aim - eye) < world.camera.depth_min + 0.08:
            continue
        T_world_cam = look_at(eye, aim) @ make_T(rot_z(rng.uniform(-np.pi / 2, np.pi / 2)))
        T_world_hand = T_world_cam @ inv_T(T_hand_cam)
        q = _free_solution(world, T_world_hand, q_home, cfg.q7_samples)
        if q is None:
            continue
        world.set_q(q)
        if np.linalg.norm(world.T_world_cam()[:3, 3] - eye) > 0.01:
            continue
        out.append(world.target_visibility())
    return out


@dataclass(frozen=True, eq=False)
class GroundTruthGrasp:
    """A grasp found with ground truth: TCP pose, grasp and pre-grasp (8 cm back) configurations."""

    T_world_tcp: np.ndarray
    q_grasp: np.ndarray
    q_pregrasp: np.ndarray


def find_grasp(world: World, cfg: CertifyConfig | None = None) -> GroundTruthGrasp | None:
    """The first collision-free, reachable grasp of the target with the fingers open, or None.

    Candidates: TCP on the target's axis 3 cm below its top; approach from straight above
    down to 0.6 rad pitch, yaw within +-0.8 rad of +x, eight rolls of the closing axis; the
    pre-grasp 8 cm back along the approach must be collision-free too.
    """
    cfg = cfg or CertifyConfig()
    tgt = world.scene.target
    h = tgt.half_extents
    q_home = np.asarray(world.robot.q_home)
    R_obj = rot_z(tgt.yaw)
    top = tgt.pos[2] + h[2]
    p = np.array([tgt.pos[0], tgt.pos[1], max(tgt.pos[2], top - 0.03)])  # TCP 3 cm below the top
    for pitch in (np.pi / 2, 1.3, 1.1, 0.9, 0.6):
        for yaw in ((0.0,) if pitch == np.pi / 2 else (0.0, 0.4, -0.4, 0.8, -0.8)):
            a = np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), -np.sin(pitch)])
            y0 = np.cross([1.0, 0.0, 0.0] if pitch == np.pi / 2 else [0.0, 0.0, 1.0], a)
            y0 /= np.linalg.norm(y0)
            for roll in np.arange(8) * np.pi / 4:
                y = np.cos(roll) * y0 + np.sin(roll) * np.cross(a, y0)  # closing axis
                if tgt.shape == "cylinder":
                    width = 2 * h[0] / max(np.linalg.norm(y[:2]), 1e-6) if abs(y[2]) > 1e-6 else 2 * h[0]
                else:
                    width = 2 * np.sum(np.abs(R_obj.T @ y) * h)
                if width > GRIPPER_MAX_WIDTH - 0.01:
                    continue
                T_world_tcp = make_T(np.column_stack([np.cross(y, a), y, a]), p)
                T_world_hand = T_world_tcp @ inv_T(T_HAND_TCP)
                q = _free_solution(world, T_world_hand, q_home, cfg.q7_samples, GRIPPER_MAX_WIDTH)
                if q is None:
                    continue
                T_pre = make_T(T_world_hand[:3, :3], T_world_hand[:3, 3] - 0.08 * a)
                q_pre = _free_solution(world, T_pre, q, cfg.q7_samples, GRIPPER_MAX_WIDTH)
                if q_pre is not None:
                    return GroundTruthGrasp(T_world_tcp, q, q_pre)
    return None


def _free_config_fraction(world: World, cfg: CertifyConfig, rng: np.random.Generator) -> float:
    q_home = np.asarray(world.robot.q_home)
    free = 0
    for _ in range(cfg.n_configs):
        q = np.clip(q_home + rng.uniform(-cfg.config_noise, cfg.config_noise, 7), Q_MIN, Q_MAX)
        free += not world.contacts(q, include_self=False)
    return free / cfg.n_configs


def certify(scene: SceneSpec, cfg: CertifyConfig | None = None, world: World | None = None) -> Certificate:
    """Check one scene with ground truth and measure its difficulty (deterministic per scene)."""
    cfg = cfg or CertifyConfig()
    t0 = time.perf_counter()
    world = world or World(scene)
    rng = np.random.default_rng(list(scene.seed) + [scene.level, scene.index, 7919])
    q_home = np.asarray(world.robot.q_home)

    def done(failure, start=0.0, views=(), free=0.0, grasp=False):
        views = list(views)
        seeing = sum(v >= cfg.min_view_visibility for v in views)
        return Certificate(
            certified=failure is CertFailure.NONE,
            failure=failure,
            start_visibility=float(start),
            view_visibility_fraction=seeing / len(views) if views else 0.0,
            n_valid_views=len(views),
            best_view_visibility=float(max(views, default=0.0)),
            free_config_fraction=float(free),
            grasp_found=grasp,
            time_s=time.perf_counter() - t0,
        )

    if world.in_collision(q_home, include_self=True):
        return done(CertFailure.HOME_IN_COLLISION)
    start = world.target_visibility(q_home)
    if start >= cfg.max_start_visibility:
        return done(CertFailure.TARGET_VISIBLE_AT_START, start)
    views = _sample_views(world, cfg, rng)
    if not any(v >= cfg.min_view_visibility for v in views):
        return done(CertFailure.NO_VIEW_SEES_TARGET, start, views)
    free = _free_config_fraction(world, cfg, rng)
    if find_grasp(world, cfg) is None:
        return done(CertFailure.NO_GRASP, start, views, free)
    world.set_q(q_home)
    return done(CertFailure.NONE, start, views, free, True)


def certified_scene(level: int, index: int, seed: int = 0, cfg: CertifyConfig | None = None) -> CertifiedScene:
    """The first candidate of (seed, level, index) that passes certification.

    Sub-seed k uses `np.random.default_rng([seed, level, index, k])`; the accepted sub-seed
    is stored in `SceneSpec.seed`, so `regenerate(scene.seed)` gives the same scene.
    """
    level = check_level(level)
    cfg = cfg or CertifyConfig()
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise CompassInputError(f"scene index {index!r} is not allowed; use an integer >= 0")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise CompassInputError(f"seed {seed!r} is not allowed; use an integer >= 0")
    for attempt in range(cfg.max_attempts):
        scene = regenerate((int(seed), level, int(index), attempt))
        world = World(scene)
        try:
            cert = certify(scene, cfg, world)
        finally:
            world.close()
        if cert.certified:
            return CertifiedScene(scene, cert, attempt + 1)
    raise RuntimeError(
        f"no certified scene for level {level}, index {index}, seed {seed} in {cfg.max_attempts} attempts"
    )


def regenerate(sub_seed: tuple[int, int, int, int]) -> SceneSpec:
    """The candidate scene of a sub-seed (seed, level, index, attempt)."""
    seed, level, index, attempt = (int(s) for s in sub_seed)
    scene = generate_scene(level, index, np.random.default_rng([seed, level, index, attempt]))
    return replace(scene, seed=(seed, level, index, attempt))
