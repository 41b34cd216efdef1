"""The one door to ground truth, for certification and metrics (never for methods).

Sections: (1) target visibility, (2) collision checking of the ground-truth geometry with the
planner's own sphere model, (3) ground-truth grasps. Later sections (detection truth) follow
at the end of the file. Code outside `sim/` reaches ground truth only through this module.
World frame, lengths [m], angles [rad].
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..geometry import make_T
from ..motion.primitives import PrimitiveSet
from ..perception.detector import Detection, Verdict
from ..perception.target import backproject_image, upright_extents
from ..motion.validity import ValidityChecker, ValidityConfig
from ..robot.ik import PandaIK
from ..robot.kinematics import PandaKinematics
from ..robot.model import GRIPPER_MAX_WIDTH, RobotConfig
from ..robot.spheres import panda_sphere_model
from .fixed_views import reference_fixed_views
from .scenes import SceneSpec
from .world import World

# ---------------------------------------------------------------- (1) target visibility


def target_visibility(world: World, q: np.ndarray | None = None) -> float:
    """Visible fraction of the target from the wrist camera at q (current q if None)."""
    return world.target_visibility(q)


def start_visibility(world: World) -> float:
    """Visible fraction of the target from the wrist camera at the home configuration."""
    return world.target_visibility(np.asarray(world.robot.q_home))


def fixed_view_visibilities(world: World) -> list[float]:
    """Visible fraction of the target from each pose of the reference fixed-view set
    (`fixed_views.reference_fixed_views` of the scene's Task), with only the scene in the way."""
    return [world.visibility_from(T, with_robot=False) for T in reference_fixed_views(world.scene.task())]


# ------------------------------------------------- (2) ground-truth collision checking


def scene_obstacles(scene: SceneSpec, exclude_target: bool = False, base_obstacles: bool = True) -> PrimitiveSet:
    """The scene's ground-truth geometry (floor, boards, objects, base obstacles) as a PrimitiveSet."""
    items = scene.cabinet.boards() + (list(scene.base_obstacles) if base_obstacles else [])
    items += [p for o in scene.clutter for p in o.parts]
    if not exclude_target:
        items += list(scene.target.parts)
    return PrimitiveSet.from_shapes(items, floor_z=scene.floor_z)


def ground_truth_checker(scene: SceneSpec, finger_width: float = GRIPPER_MAX_WIDTH, exclude_target: bool = False,
                         base_obstacles: bool = True, margin: float = 0.0) -> ValidityChecker:
    """The planner's `ValidityChecker` (conservative sphere model of the arm, hand and camera
    with the fingers at finger_width [m]) on the scene's ground-truth geometry."""
    robot = RobotConfig(base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw)
    spheres = panda_sphere_model(robot, finger_width)
    return ValidityChecker(spheres, None, scene_obstacles(scene, exclude_target, base_obstacles),
                           ValidityConfig(margin=margin))


def obstacle_checker(scene: SceneSpec, margin: float = 0.0, finger_width: float = GRIPPER_MAX_WIDTH) -> ValidityChecker:
    """The sphere-model checker of `ground_truth_checker` on the scene's base obstacles alone
    (no floor, no self-collision test): a configuration or straight segment is valid for
    `ground_truth_checker(scene, margin=m)` iff it is valid for
    `ground_truth_checker(scene, base_obstacles=False, margin=m)` and for this one (the
    verdict is an AND over the primitives; `layout_grasps` shares the first part among the
    obstacle draws of a layout)."""
    robot = RobotConfig(base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw)
    spheres = panda_sphere_model(robot, finger_width)
    return ValidityChecker(spheres, None, PrimitiveSet.from_shapes(list(scene.base_obstacles)),
                           ValidityConfig(margin=margin, check_self=False))


@lru_cache(maxsize=4)
def robot_ik(robot: RobotConfig) -> PandaIK:
    """A cached IK solver of the robot (base pose, camera)."""
    return PandaIK(PandaKinematics(robot))


# ------------------------------------------------------------ (3) ground-truth grasps


@dataclass(frozen=True, eq=False)
class GroundTruthGrasp:
    """A grasp found with ground truth. T_world_tcp: TCP pose at the grasp (z = approach
    direction, y = closing axis); approach_deg: angle of the approach below the horizontal
    (0 = from the side, 90 = from above); q_grasp, q_pregrasp (TCP `PREGRASP_BACK` m back
    along the approach) and q_lift (TCP `LIFT_HEIGHT` m higher) [rad]."""

    T_world_tcp: np.ndarray
    approach_deg: float
    q_grasp: np.ndarray
    q_pregrasp: np.ndarray
    q_lift: np.ndarray


PREGRASP_BACK = 0.10
LIFT_HEIGHT = 0.04
MAX_GRASP_WIDTH = GRIPPER_MAX_WIDTH - 0.012
#: approach angles below the horizontal [deg] and yaws about +x [rad] of the candidates
APPROACH_PITCH_DEG = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0)
APPROACH_YAW = (0.0, 0.3, -0.3, 0.6, -0.6, 0.9, -0.9)
#: A bottle's neck is a grasp candidate too when it is at least this long [m]: the TCP sits
#: NECK_TCP_DEPTH below its top and the palm reaches ~3.7 cm below the TCP (the sphere model),
#: so a shorter neck puts the palm on the shoulder. Near-horizontal approaches only.
NECK_MIN_HEIGHT = 0.055
NECK_TCP_DEPTH = 0.018
NECK_PITCH_DEG = (0.0, 15.0)


def grasp_candidates(scene: SceneSpec) -> list[tuple[np.ndarray, float]]:
    """Antipodal candidate TCP poses (T_world_tcp, approach_deg) on the target, ordered by the
    angle between the approach and the opening's inward normal (+x): side approaches first.

    The closing axis is horizontal; for boxes it is a face normal (the fingers close on two
    parallel faces). The TCP sits on the grasped part's axis 2.5 cm below its top (lower, the
    forearm's conservative spheres reach the shelf the target stands on).
    Both rolls of the hand are candidates (the one with the wrist camera above first). A
    bottle with a neck of at least NECK_MIN_HEIGHT adds near-horizontal candidates on the
    neck (TCP NECK_TCP_DEPTH below its top), each right after the body candidate of the same
    approach direction.
    """
    tgt = scene.target
    out = _part_candidates(tgt.parts[0], tgt.parts[0].pos[2] + tgt.parts[0].half_extents[2] - 0.025,
                           APPROACH_PITCH_DEG, 0.0)
    if tgt.category == "bottle" and len(tgt.parts) > 1 and 2 * tgt.parts[1].half_extents[2] >= NECK_MIN_HEIGHT - 1e-9:
        neck = tgt.parts[1]
        out += _part_candidates(neck, neck.pos[2] + neck.half_extents[2] - NECK_TCP_DEPTH, NECK_PITCH_DEG, 5e-4)
    out.sort(key=lambda c: c[0])
    return [(T, deg) for _, T, deg in out]


#: The denser neck family the severe obstacle level counts its grasps over (`dense_neck_candidates`):
#: approach yaws [rad] every 0.05 rad within +-0.45 (the neck grasps that pass the 1 cm margin
#: approach within ~0.35 rad of +x) and TCP depths [m] below the neck's top around NECK_TCP_DEPTH.
DENSE_NECK_YAW = tuple(float(v) for v in np.round(np.linspace(-0.45, 0.45, 19), 4))
DENSE_NECK_TCP_DEPTH = (0.014, 0.018, 0.022)


def dense_neck_candidates(scene: SceneSpec) -> list[tuple[np.ndarray, float]]:
    """The neck candidates of `grasp_candidates` sampled densely (DENSE_NECK_YAW x
    DENSE_NECK_TCP_DEPTH x NECK_PITCH_DEG x both rolls, 228 poses), (T_world_tcp, approach_deg)
    in the same order rule; [] for a target without a long neck. The severe candidates have 1-3
    valid neck grasps in the sparse family (7 yaws, one depth), which makes "the obstacles
    remove >= 30 % of the grasps" all or nothing; over this family a layout has 2-31
    (docs/scenes.md)."""
    tgt = scene.target
    if not (tgt.category == "bottle" and len(tgt.parts) > 1
            and 2 * tgt.parts[1].half_extents[2] >= NECK_MIN_HEIGHT - 1e-9):
        return []
    neck = tgt.parts[1]
    out = []
    for depth in DENSE_NECK_TCP_DEPTH:
        out += _part_candidates(neck, neck.pos[2] + neck.half_extents[2] - depth, NECK_PITCH_DEG, 0.0,
                                DENSE_NECK_YAW)
    out.sort(key=lambda c: c[0])
    return [(T, deg) for _, T, deg in out]


def _part_candidates(body, z_tcp: float, pitches, key_offset: float, round_yaws=APPROACH_YAW) -> list:
    """(sort key, T_world_tcp, approach_deg) of the antipodal candidates on one part, the
    TCP on its axis at height z_tcp [m]."""
    h = body.half_extents
    if body.shape == "box":  # approach along a face normal: the fingers close on the other two faces
        yaws = []
        for k in range(4):
            yaw = float((body.yaw + k * np.pi / 2 + np.pi) % (2 * np.pi) - np.pi)
            if abs(yaw) <= 0.95:
                yaws.append((yaw, 2 * float(h[1] if k % 2 == 0 else h[0])))
    else:
        yaws = [(yaw, 2 * float(h[0])) for yaw in round_yaws]
    out = []
    for pitch_deg in pitches:
        pitch = np.radians(pitch_deg)
        for yaw, width in (yaws if pitch_deg < 90 else yaws[:1]):
            if width > MAX_GRASP_WIDTH:
                continue
            a = np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), -np.sin(pitch)])
            p = np.array([body.pos[0], body.pos[1], z_tcp])
            for sign in (-1.0, 1.0):  # closing axis horizontal, normal to a; camera above the hand first
                y = sign * np.array([-np.sin(yaw), np.cos(yaw), 0.0])
                T = make_T(np.column_stack([np.cross(y, a), y, a]), p)
                key = float(np.arccos(np.clip(a[0], -1.0, 1.0))) + (0.0 if T[2, 0] >= -1e-9 else 1e-3) + key_offset
                out.append((key, T, float(pitch_deg)))
    return out


def grasp_solutions(ik: PandaIK, T_world_tcp: np.ndarray, q_ref: np.ndarray, n_q7: int = 12) -> np.ndarray:
    """IK solutions (k,7) [rad] of a grasp pose, nearest to q_ref first."""
    return ik.solve(T_world_tcp, "tcp", q_ref, n_q7, retry=False).solutions


def _near(ik: PandaIK, T: np.ndarray, q: np.ndarray) -> np.ndarray | None:
    r = ik.solve(T, "tcp", q, 2, retry=False)
    return r.best if r.success and np.max(np.abs(r.best - q)) < 0.6 else None


def first_valid_grasp(ik: PandaIK, T_world_tcp: np.ndarray, sols: np.ndarray, full: ValidityChecker,
                      no_target: ValidityChecker, world: World | None = None):
    """(q_grasp, q_pregrasp, q_lift) for the first IK solution whose grasp, pre-grasp (TCP
    PREGRASP_BACK back along the approach), lift (TCP LIFT_HEIGHT up) and the straight joint
    segments pre-grasp -> grasp -> lift are collision-free (the target excluded except at the
    pre-grasp: the fingers close around it), or None. With a world, the grasp must also be
    free of ground-truth (MuJoCo) contacts with the fingers open."""
    if len(sols) == 0:
        return None
    for q in sols[no_target.are_valid(sols)]:
        if world is not None and world.in_collision(q, GRIPPER_MAX_WIDTH, include_self=True):
            continue
        found = grasp_chain(ik, T_world_tcp, q, full, no_target)
        if found is not None:
            return found
    return None


def grasp_chain(ik: PandaIK, T_world_tcp: np.ndarray, q: np.ndarray, full: ValidityChecker,
                no_target: ValidityChecker):
    """`first_valid_grasp`'s test of one IK solution q (already valid for no_target):
    (q, q_pregrasp, q_lift) when its pre-grasp, lift and the straight segments are valid, or None."""
    a = T_world_tcp[:3, 2]
    T_pre, T_lift = T_world_tcp.copy(), T_world_tcp.copy()
    T_pre[:3, 3] -= PREGRASP_BACK * a
    T_lift[2, 3] += LIFT_HEIGHT
    pre = _near(ik, T_pre, q)
    if pre is None or not full.is_valid(pre) or not no_target.edge_valid(pre, q):
        return None
    lift = _near(ik, T_lift, q)
    if lift is None or not no_target.is_valid(lift) or not no_target.edge_valid(q, lift):
        return None
    return q, pre, lift


def find_grasp(world: World, q_ref: np.ndarray | None = None, max_candidates: int | None = None) -> GroundTruthGrasp | None:
    """The first ground-truth grasp (side approaches first) that is reachable and collision-free
    with its pre-grasp and lift, or None."""
    scene = world.scene
    ik = robot_ik(world.robot)
    q_ref = np.asarray(world.robot.q_home) if q_ref is None else q_ref
    full = ground_truth_checker(scene)
    no_target = ground_truth_checker(scene, exclude_target=True)
    for T, deg in grasp_candidates(scene)[:max_candidates]:
        found = first_valid_grasp(ik, T, grasp_solutions(ik, T, q_ref), full, no_target, world)
        if found is not None:
            return GroundTruthGrasp(T, deg, *found)
    return None


# ------------------------------------------ (4) perception and trial oracles
# Segmentation-label detector (an explicitly named oracle for ablations), the truth check
# of an accepted detection, the target's surroundings box for the explored-fraction metric
# and the best view of the target (for grasp-only runs). Only trial/, bench/ and tests use
# these; methods never do.



class OracleSegmentationDetector:
    """Detects the target from the simulator's segmentation labels (an oracle: the frames
    must carry `seg`, so the trial pushes whole frames into the buffer for it). At least
    `min_pixels` target pixels are one ACCEPTED detection."""

    def __init__(self, target_label: int, min_pixels: int = 40) -> None:
        self.target_label, self.min_pixels = int(target_label), int(min_pixels)

    def __call__(self, frame, query=None) -> tuple[Detection, ...]:
        if frame.seg is None:
            raise ValueError("the oracle detector needs frames rendered with segmentation")
        mask = (frame.seg == self.target_label) & np.isfinite(frame.depth) & (frame.depth > 0)
        if mask.sum() < self.min_pixels:
            return ()
        pts, _ = backproject_image(frame.depth, frame.K, frame.T_world_cam)
        rows, cols = np.nonzero(mask)
        P = pts[rows, cols]
        u0, u1, v0, v1 = int(cols.min()), int(cols.max()), int(rows.min()), int(rows.max())
        return (Detection(t=float(frame.t), T_world_cam=np.asarray(frame.T_world_cam), bbox=(u0, v0, u1, v1),
                          centre_px=((u0 + u1) / 2, (v0 + v1) / 2), n_pixels=int(len(rows)), points_world=P,
                          centroid_world=P.mean(axis=0), extents=upright_extents(P), shape="oracle", score=1.0,
                          verdict=Verdict.ACCEPTED),)


def detection_is_target(scene, detection: Detection, margin: float = 0.015, min_fraction: float = 0.5) -> bool:
    """Whether at least `min_fraction` of the detection's 3D points lie in the target's
    bounding box grown by `margin` [m] (ground truth)."""
    lo, hi = scene.target.aabb()
    P = np.asarray(detection.points_world, float).reshape(-1, 3)
    if len(P) == 0:
        return False
    inside = np.all((P >= lo - margin) & (P <= hi + margin), axis=1)
    return bool(inside.mean() >= min_fraction)


def target_surroundings(scene, margin: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """World box (min, max) [m]: the target's bounding box grown by `margin` [m], clipped to
    the cabinet's interior: the region whose explored fraction a trial records."""
    lo, hi = scene.target.aabb()
    ilo, ihi = np.asarray(scene.cabinet.interior_min), np.asarray(scene.cabinet.interior_max)
    return np.maximum(lo - margin, ilo), np.minimum(hi + margin, ihi)


def best_target_view(world, rng: np.random.Generator, n_samples: int = 24, distance: float = 0.35):
    """The collision-free configuration (7,) [rad] among camera IK solutions looking at the
    target from `distance` [m] that sees most of it, and that visible fraction; (None, 0.0)
    when no sampled view sees it (for grasp-only runs)."""
    from ..robot.ik import ik_look_at

    q_home = np.asarray(world.robot.q_home)
    sols = ik_look_at(np.asarray(world.scene.target.pos, float), distance, q_home, rng=rng,
                      n_samples=n_samples).solutions
    best, best_vis = None, 0.0
    for q in sols:
        if world.in_collision(q):
            continue
        vis = world.target_visibility(q, stride=2)
        if vis > best_vis:
            best, best_vis = q.copy(), vis
    world.set_q(q_home)
    return best, best_vis
