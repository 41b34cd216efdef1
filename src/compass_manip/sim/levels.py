"""Procedural confined scenes in four difficulty levels (the COMPASS benchmark).

L1 moderate occlusion, low kinematic constraint: one occluder hides the target from the
   start camera; moving the camera sideways or up (a monotonic path) reveals it.
L2 severe occlusion: the target sits in a pocket at the back, behind a wide, tall front
   occluder with a side wall; the camera has to enter the cabinet, look behind the
   occluder from the open side and back out.
L3 = L1 occlusion + obstacles close to the robot's base and arm.
L4 = L2 occlusion + L3 obstacles.

`generate_scene` draws one *candidate*; `certify.certified_scene` checks it with ground
truth and moves to the next sub-seed when it fails.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError
from .scenes import CabinetSpec, Primitive, SceneSpec

LEVELS = (1, 2, 3, 4)
TARGET_RGBA = (0.9, 0.05, 0.05, 1.0)
#: Clutter colours: no saturated red, so the target's appearance stays distinctive.
CLUTTER_PALETTE = (
    (0.2, 0.45, 0.8, 1.0), (0.25, 0.65, 0.3, 1.0), (0.85, 0.75, 0.2, 1.0), (0.55, 0.35, 0.7, 1.0),
    (0.3, 0.7, 0.7, 1.0), (0.6, 0.6, 0.6, 1.0), (0.9, 0.9, 0.85, 1.0), (0.35, 0.3, 0.25, 1.0),
)
OBSTACLE_RGBA = (0.4, 0.4, 0.45, 1.0)
#: The start camera (robot.model.Q_HOME) sits near here [m]; occluders are placed on the
#: line from it to the target.
START_CAMERA_POS = np.array([0.291, 0.0, 0.696])


@dataclass(frozen=True)
class LevelParams:
    severe_occlusion: bool
    base_obstacles: bool
    n_clutter: tuple[int, int]


LEVEL_PARAMS = {
    1: LevelParams(severe_occlusion=False, base_obstacles=False, n_clutter=(2, 4)),
    2: LevelParams(severe_occlusion=True, base_obstacles=False, n_clutter=(3, 5)),
    3: LevelParams(severe_occlusion=False, base_obstacles=True, n_clutter=(2, 4)),
    4: LevelParams(severe_occlusion=True, base_obstacles=True, n_clutter=(3, 5)),
}


def check_level(level: object) -> int:
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or int(level) not in LEVELS:
        raise CompassInputError(f"level {level!r} is not allowed; use one of 1, 2, 3, 4")
    return int(level)


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _box(name: str, half, pos, yaw=0.0, rgba=OBSTACLE_RGBA, movable=False, mass=0.2) -> Primitive:
    return Primitive(name, "box", tuple(float(h) for h in half), tuple(float(p) for p in pos), float(yaw),
                     tuple(rgba), movable, mass)


def _overlaps(a: Primitive, others: list[Primitive], gap: float) -> bool:
    lo, hi = a.aabb()
    for o in others:
        olo, ohi = o.aabb()
        if np.all(lo[:2] < ohi[:2] + gap) and np.all(olo[:2] < hi[:2] + gap):
            return True
    return False


def _fit_inside(p: Primitive, cab: CabinetSpec, margin: float = 0.003) -> Primitive:
    """Shift p horizontally so its bounding box lies inside the cabinet's interior."""
    lo, hi = p.aabb()
    ilo = np.array(cab.interior_min[:2]) + margin
    ihi = np.array(cab.interior_max[:2]) - margin
    shift = np.maximum(ilo - lo[:2], 0.0) - np.maximum(hi[:2] - ihi, 0.0)
    if not np.any(shift):
        return p
    pos = (float(p.pos[0] + shift[0]), float(p.pos[1] + shift[1]), p.pos[2])
    return Primitive(p.name, p.shape, p.size, pos, p.yaw, p.rgba, p.movable, p.mass)


def _cabinet(rng: np.random.Generator) -> CabinetSpec:
    x_front = _u(rng, 0.46, 0.52)
    depth = _u(rng, 0.30, 0.36)
    width = _u(rng, 0.56, 0.70)
    height = _u(rng, 0.55, 0.62)
    z_bottom = _u(rng, 0.42, 0.48)
    yc = _u(rng, -0.04, 0.04)
    return CabinetSpec(
        interior_min=(x_front, yc - width / 2, z_bottom),
        interior_max=(x_front + depth, yc + width / 2, z_bottom + height),
    )


def _target(rng: np.random.Generator, cab: CabinetSpec, x: float, y: float) -> Primitive:
    height = _u(rng, 0.10, 0.15)
    z = cab.interior_min[2] + height / 2
    if rng.random() < 0.5:
        r = _u(rng, 0.02, 0.027)
        return Primitive("target", "cylinder", (r, height / 2), (x, y, z), 0.0, TARGET_RGBA, True, 0.08)
    hx, hy = _u(rng, 0.018, 0.026), _u(rng, 0.018, 0.026)
    return Primitive("target", "box", (hx, hy, height / 2), (x, y, z), _u(rng, -0.4, 0.4), TARGET_RGBA, True, 0.08)


def _colour(rng: np.random.Generator) -> tuple[float, ...]:
    return CLUTTER_PALETTE[int(rng.integers(len(CLUTTER_PALETTE)))]


def _occluder_height(cab: CabinetSpec, target: Primitive, x_occ_front: float, margin: float) -> float:
    """Height [m] an occluder at x_occ_front needs to hide the target top from the start camera."""
    top = cab.interior_min[2] + 2 * target.half_extents[2]
    x_back = target.pos[0] + target.half_extents[0]
    cx, cz = START_CAMERA_POS[0], START_CAMERA_POS[2]
    z_line = cz + (top - cz) * (x_occ_front - cx) / (x_back - cx)
    return z_line - cab.interior_min[2] + margin


def _line_of_sight(tx: float, ty: float) -> tuple[np.ndarray, float]:
    """Unit (x, y) direction from the start camera to (tx, ty) and its length [m]."""
    los = np.array([tx - START_CAMERA_POS[0], ty - START_CAMERA_POS[1]])
    n = float(np.linalg.norm(los))
    return los / n, n


def _board(name, rng, cab, target, d_occ: float, extra_half_w: float, h: float) -> Primitive:
    """A board across the line of sight, d_occ [m] in front of the target's axis."""
    los, dist_t = _line_of_sight(target.pos[0], target.pos[1])
    r = float(max(target.half_extents[:2])) * np.sqrt(2.0)
    oc = np.array(target.pos[:2]) - d_occ * los
    half_w = (r + 0.015) * (dist_t - d_occ) / dist_t + extra_half_w
    half_t = _u(rng, 0.01, 0.02)
    lo = cab.interior_min
    board = _box(name, (half_t, half_w, h / 2), (oc[0], oc[1], lo[2] + h / 2), float(np.arctan2(los[1], los[0])),
                 _colour(rng), True, 0.3)
    return _fit_inside(board, cab)


def _place_target(rng, cab: CabinetSpec) -> Primitive:
    lo, hi = np.array(cab.interior_min), np.array(cab.interior_max)
    tx = _u(rng, max(lo[0] + 0.1, 0.57), min(hi[0] - 0.06, 0.68))
    ty = _u(rng, max(lo[1] + 0.1, -0.2), min(hi[1] - 0.1, 0.2))
    return _target(rng, cab, tx, ty)


def _occlusion_l1(rng, cab: CabinetSpec) -> tuple[Primitive, list[Primitive]]:
    """One board on the line of sight, just tall enough to hide the target from the start."""
    lo, hi = np.array(cab.interior_min), np.array(cab.interior_max)
    target = _place_target(rng, cab)
    d_occ = _u(rng, 0.07, 0.1)
    los, _ = _line_of_sight(target.pos[0], target.pos[1])
    x_front = target.pos[0] - (d_occ + 0.02) * los[0]
    h = _occluder_height(cab, target, x_front, 0.01) + _u(rng, 0.0, 0.02)
    h = min(h, (hi[2] - lo[2]) - 0.1)
    return target, [_board("occluder0", rng, cab, target, d_occ, _u(rng, 0.01, 0.025), h)]


def _occlusion_l2(rng, cab: CabinetSpec) -> tuple[Primitive, list[Primitive]]:
    """A wide board twice the target's height and a side wall: the camera has to rise above
    it and look down behind it from inside the cabinet, then back out."""
    lo, hi = np.array(cab.interior_min), np.array(cab.interior_max)
    target = _place_target(rng, cab)
    height_in = hi[2] - lo[2]
    d_occ = _u(rng, 0.08, 0.11)
    los, _ = _line_of_sight(target.pos[0], target.pos[1])
    h = height_in * _u(rng, 0.36, 0.44)
    board = _board("occluder0", rng, cab, target, d_occ, _u(rng, 0.05, 0.08), h)
    # a side wall along the line of sight closes one side of the space behind the board
    normal = np.array([-los[1], los[0]])
    side = 1.0 if rng.random() < 0.5 else -1.0
    r = float(max(target.half_extents[:2]))
    length = d_occ - 0.03
    centre = np.array(target.pos[:2]) - (0.5 * length + 0.02) * los + side * (r + _u(rng, 0.1, 0.12)) * normal
    h_side = h * _u(rng, 0.75, 0.9)
    wall = _box("occluder1", (length / 2, 0.012, h_side / 2), (centre[0], centre[1], lo[2] + h_side / 2),
                float(np.arctan2(los[1], los[0])), _colour(rng), True, 0.2)
    wall = _fit_inside(wall, cab)
    return target, [board, wall]


def _clutter(rng, cab: CabinetSpec, n: int, placed: list[Primitive]) -> list[Primitive]:
    lo, hi = np.array(cab.interior_min), np.array(cab.interior_max)
    out: list[Primitive] = []
    for i in range(200):
        if len(out) == n:
            break
        colour = _colour(rng)
        h = _u(rng, 0.05, 0.16)
        kind = int(rng.integers(3))
        x, y = _u(rng, lo[0] + 0.04, hi[0] - 0.04), _u(rng, lo[1] + 0.04, hi[1] - 0.04)
        name = f"clutter{len(out)}"
        if kind == 0:
            p = _box(name, (_u(rng, 0.02, 0.045), _u(rng, 0.02, 0.045), h / 2), (x, y, lo[2] + h / 2),
                     _u(rng, -np.pi, np.pi), colour, True, 0.15)
        elif kind == 1:
            p = Primitive(name, "cylinder", (_u(rng, 0.02, 0.04), h / 2), (x, y, lo[2] + h / 2), 0.0, colour, True, 0.15)
        else:
            rad = _u(rng, 0.025, 0.045)
            p = Primitive(name, "sphere", (rad,), (x, y, lo[2] + rad), 0.0, colour, True, 0.1)
        a_lo, a_hi = p.aabb()
        if np.any(a_lo[:2] < lo[:2] + 0.005) or np.any(a_hi[:2] > hi[:2] - 0.005):
            continue
        if not _overlaps(p, placed + out, 0.015):
            out.append(p)
    return out


def _base_obstacles(rng) -> list[Primitive]:
    """Obstacles close to the robot's base and arm (levels 3 and 4)."""
    out = []
    # side walls left and right of the base that limit joint 1 and the elbow
    for k, s in enumerate((1.0, -1.0)):
        if k == 1 and rng.random() < 0.3:
            continue
        y = s * _u(rng, 0.27, 0.34)
        x0, x1 = _u(rng, -0.25, -0.1), _u(rng, 0.35, 0.5)
        h = _u(rng, 0.55, 0.9)
        out.append(_box(f"base_wall{k}", ((x1 - x0) / 2, 0.02, h / 2), ((x0 + x1) / 2, y, h / 2)))
    # a low block between the robot and the cabinet, under the arm's path
    h = _u(rng, 0.22, 0.32)
    out.append(_box("base_block", (_u(rng, 0.06, 0.1), _u(rng, 0.1, 0.18), h / 2), (_u(rng, 0.3, 0.42), _u(rng, -0.1, 0.1), h / 2)))
    # a post next to the cabinet's front edge
    s = 1.0 if rng.random() < 0.5 else -1.0
    ph = _u(rng, 0.7, 1.0)
    out.append(Primitive("base_post", "cylinder", (_u(rng, 0.025, 0.04), ph / 2),
                         (_u(rng, 0.3, 0.4), s * _u(rng, 0.22, 0.3), ph / 2), 0.0, OBSTACLE_RGBA))
    # an overhead bar across the workspace, above the home pose
    if rng.random() < 0.6:
        z = _u(rng, 0.98, 1.08)
        out.append(_box("base_bar", (0.025, 0.45, 0.025), (_u(rng, 0.25, 0.4), 0.0, z)))
    return out


def generate_scene(level: int, index: int, rng: np.random.Generator) -> SceneSpec:
    """Draw one candidate scene of `level` (1..4). Pure function of the generator's state.

    The result is not yet certified: see `certify.certified_scene`.
    """
    level = check_level(level)
    if not isinstance(rng, np.random.Generator):
        raise CompassInputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    params = LEVEL_PARAMS[level]
    cab = _cabinet(rng)
    target, occluders = (_occlusion_l2 if params.severe_occlusion else _occlusion_l1)(rng, cab)
    n = int(rng.integers(params.n_clutter[0], params.n_clutter[1] + 1))
    clutter = occluders + _clutter(rng, cab, n, occluders + [target])
    obstacles = _base_obstacles(rng) if params.base_obstacles else []
    return SceneSpec(
        level=level,
        index=int(index),
        seed=(),
        cabinet=cab,
        target=target,
        clutter=tuple(clutter),
        base_obstacles=tuple(obstacles),
    )
