"""Procedural confined scenes in four difficulty levels (the COMPASS benchmark), v2.

Every scene: a cabinet or shelving unit (1-3 shelves, face frame, optional partition and
back-corner compartment, `layout`), 8-15 household objects (`objects`), a target described by
a `TargetQuery`, colour distractors (same colour, clearly another shape and size), shape
distractors (same shape, another colour), decoys (large objects hiding nothing, away from the
target), sometimes a stack (a lying book with something on it).

The shelves leave room only for near-horizontal grasps, and the Panda hand is ~0.2 m wide
along its closing axis: every target keeps an approach corridor to the opening free of
objects (`_keep_hand_room`); occluders stand beside that corridor, placed by what they hide.
L1 moderate: the target stands on a storey below the start camera's field of view, in the
   back part of a compartment, with one large object beside its corridor hiding it from
   views on that side.
L2 severe (`severe`): a tall bottle at the back of the bottom storey, a cereal box lying on
   its side just in front of it with its top 6-7 cm below the bottle's top, a face-frame
   rail under the shelf above: from outside only the neck shows (no camera more than 10 cm
   in front of the opening sees >= 30 % of the target, certified); the wrist camera looks
   down behind the box from inside the storey, and the only grasp is on the neck, over it.
L3 = L1 + obstacles near the base and arm; L4 = L2 + those obstacles and a short low bar
   across the forearm's way in front of the opening (`forearm_bar`; the certification aims
   level 4's draws, `aimed_obstacles`). The obstacle variant (overhead plate / lateral walls /
   bar, wall and post) is chosen by scene index, so rejection never drops a variant.

`generate_scene` draws one candidate; `certify.certified_scene` checks it and moves to the
next sub-seed when it fails.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import CompassInputError
from ..task import COLOURS
from .layout import Compartment, Placer, box_discs, draw_cabinet
from .objects import (LARGE_CATEGORIES, TARGET_CATEGORIES, build_object, draw_dims, draw_mass, footprint_radius,
                      height_of, lying_book)
from .scenes import Primitive, SceneObject, SceneSpec
from .severe import severe_target

LEVELS = (1, 2, 3, 4)
#: The start camera (robot.model.Q_HOME) sits here [m], looking along +x.
START_CAMERA_POS = np.array([0.291, 0.0, 0.696])
START_HALF_FOV = math.radians(29.0)
#: Colours objects may have (the boards are brown).
OBJECT_COLOURS = tuple(c for c in COLOURS if c != "brown")
OBSTACLE_RGBA = (0.4, 0.4, 0.45, 1.0)
CLUTTER_CATEGORIES = ("cereal_box", "book", "box", "can", "bottle", "mug", "bowl", "sphere")
N_OBJECTS = (8, 15)
#: Categories of colour distractors: clearly another shape and size than any target.
COLOUR_DISTRACTOR_CATEGORIES = ("cereal_box", "book", "bowl")
#: Base-obstacle variants, chosen by scene index (stratified).
OBSTACLE_VARIANTS = ("overhead_plate", "lateral_walls", "bar_wall_post")  # the plate comes with one wall
#: Level 4's variants: walls on both sides leave the severe layout's neck grasp no elbow room
#: (under the shelf above, the elbow swings out to |y| ~ 0.35 m; docs/scenes.md).
SEVERE_OBSTACLE_VARIANTS = ("overhead_plate", "bar_wall_post")


def check_level(level: object) -> int:
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or int(level) not in LEVELS:
        raise CompassInputError(f"level {level!r} is not allowed; use one of 1, 2, 3, 4")
    return int(level)


def _u(rng, lo, hi) -> float:
    return float(rng.uniform(lo, hi))


def _reachable(c: Compartment) -> bool:
    return 0.26 <= c.z_floor <= 0.85 and c.clearance >= 0.19


class _Builder:
    def __init__(self, rng: np.random.Generator, cabinet, comps: list[Compartment]):
        self.rng, self.cabinet, self.comps = rng, cabinet, comps
        self.placer = Placer()
        self.objects: list[SceneObject] = []
        self.n = 0

    def name(self, category: str) -> str:
        self.n += 1
        return f"{category}{self.n}"

    def place(self, category: str, colour: str, role: str, comps=None, x_range=None, dims=None,
              tries: int = 40) -> SceneObject | None:
        rng = self.rng
        dims = dims or draw_dims(category, rng)
        r, h = footprint_radius(category, dims), height_of(category, dims)
        for _ in range(tries):
            pool = comps or self.comps
            c = pool[int(rng.integers(len(pool)))]
            xa, xb = x_range(c) if x_range else (c.x_lo, c.x_hi)
            x, y = _u(rng, xa, xb), _u(rng, c.y_lo, c.y_hi)
            if self.placer.fits(c, x, y, r, h):
                obj = build_object(self.name(category), category, colour, dims, draw_mass(category, rng), x, y,
                                   c.z_floor, _u(rng, -math.pi, math.pi), role)
                self.placer.add(obj, r)
                self.objects.append(obj)
                return obj
        return None


#: Farthest target centre [m] from the base along x: deeper, the low storeys are out of reach.
MAX_TARGET_X = 0.72
#: Room the hand needs beside a target [m]: the Panda hand is ~0.2 m wide along its closing axis.
HAND_HALF_WIDTH = 0.115


def _target(b: _Builder) -> tuple[SceneObject, Compartment]:
    """The target and its compartment (moderate levels): in the back part of a compartment
    out of the start camera's view, at least HAND_HALF_WIDTH from the side walls so a grasp
    can exist."""
    rng = b.rng
    ok = [c for c in b.comps if _reachable(c) and (c.x_hi - c.x_lo) >= 0.12
          and (c.y_hi - c.y_lo) >= 2 * HAND_HALF_WIDTH + 0.01]
    normal = [c for c in ok if not c.corner]
    if not normal:
        raise _Retry("no compartment for the target")
    category = TARGET_CATEGORIES[int(rng.integers(len(TARGET_CATEGORIES)))]
    colour = OBJECT_COLOURS[int(rng.integers(len(OBJECT_COLOURS)))]
    for _ in range(60):
        dims = _target_dims(category, rng)
        r, h = footprint_radius(category, dims), height_of(category, dims)
        c = normal[int(rng.integers(len(normal)))]
        if c.clearance < h + 0.10:
            continue
        if _in_start_view(c, 0.5 * (c.x_lo + c.x_hi)):
            continue
        y = _u(rng, c.y_lo + HAND_HALF_WIDTH, c.y_hi - HAND_HALF_WIDTH)
        x = min(_u(rng, c.x_lo + 0.45 * (c.x_hi - c.x_lo), c.x_hi - r - 0.005), MAX_TARGET_X)
        if not b.placer.fits(c, x, y, r, h + 0.06):  # room above for the fingers
            continue
        yaw = _u(rng, -0.5, 0.5) if category == "box" else 0.0
        t = build_object("target", category, colour, dims, _u(rng, 0.08, 0.2), x, y, c.z_floor, yaw, "target")
        b.placer.add(t, r)
        return t, c
    raise _Retry("no room for the target")


def _in_start_view(c: Compartment, x: float) -> bool:
    """Whether a storey's middle lies within the start camera's vertical field of view (the
    target is placed elsewhere: with the approach corridor open, nothing would hide it)."""
    cam = START_CAMERA_POS
    elev = math.atan2(0.5 * (c.z_floor + c.z_ceiling) - cam[2], x - cam[0])
    return abs(elev) < START_HALF_FOV + math.radians(4.0)


def _target_dims(category: str, rng: np.random.Generator) -> tuple[float, ...]:
    """Dimensions of a target: tall enough that the hand, grasping 2.5 cm below the top,
    keeps its lower edge and the forearm clear of the shelf (tall cans, upright boxes)."""
    dims = list(draw_dims(category, rng))
    if category == "can":
        dims[1] = _u(rng, 0.115, 0.15)
    elif category == "box":
        dims[2] = _u(rng, 0.10, 0.15)
    return tuple(dims)


def _keep_hand_room(b: _Builder, t: SceneObject, c: Compartment, psi: float) -> None:
    """Keep a corridor from the opening to the target (hand approach yaw psi [rad]) free: the
    shelves above leave room only for near-horizontal approaches, and the hand (~0.2 m wide
    along its closing axis) and the forearm below or above it need that corridor."""
    lo, hi = t.aabb()
    back = -np.array([math.cos(psi), math.sin(psi)])
    p = np.array(t.pos[:2], dtype=float)
    while p[0] > c.x_lo - 0.05:
        b.placer.keep_out(p[0], p[1], HAND_HALF_WIDTH - 0.02, c.z_floor, c.z_ceiling)
        p = p + 0.04 * back


class _Retry(Exception):
    pass


def _side_occluder(b: _Builder, t: SceneObject, c: Compartment, side: int, angle: tuple[float, float],
                   extra_h: tuple[float, float], role: str = "occluder") -> SceneObject | None:
    """A large object in front of the target on one side of its approach corridor (side +1:
    +y), at `angle` [rad] from the -x direction, facing the target, taller than it by extra_h [m]."""
    rng = b.rng
    lo, hi = t.aabb()
    r_t = 0.5 * float(hi[0] - lo[0])
    for _ in range(25):
        category = LARGE_CATEGORIES[int(rng.integers(2))]
        dims = list(draw_dims(category, rng))
        phi = _u(rng, *angle)
        u = np.array([-math.cos(phi), side * math.sin(phi)])
        p = t.pos[:2] + (r_t + _u(rng, 0.03, 0.07) + dims[0] / 2 + 0.06) * u
        dims[2] = float(min(hi[2] - c.z_floor + _u(rng, *extra_h), c.clearance - 0.035))
        yaw = math.atan2(u[1], u[0]) + _u(rng, -0.15, 0.15)
        obj = build_object(b.name(category), category, _other_colour(rng, t.colour), tuple(dims),
                           draw_mass(category, rng), p[0], p[1], c.z_floor, yaw, role)
        if _inside(obj, c) and _free(b, obj):
            b.placer.add_box(obj)
            b.objects.append(obj)
            return obj
    return None


def _occluders(b: _Builder, t: SceneObject, c: Compartment) -> list[SceneObject]:
    """One large object on one side of the approach corridor: it hides the target from views
    on that side (moderate levels)."""
    side = 1 if b.rng.random() < 0.5 else -1
    o = _side_occluder(b, t, c, side, (0.7, 1.2), (0.0, 0.04))
    return [o] if o is not None else []


def _inside(obj: SceneObject, c: Compartment) -> bool:
    lo, hi = obj.aabb()
    return (lo[0] >= c.x_lo + 0.003 and hi[0] <= c.x_hi - 0.003 and lo[1] >= c.y_lo + 0.003
            and hi[1] <= c.y_hi - 0.003 and hi[2] <= c.z_ceiling - 0.02)


def _free(b: _Builder, obj: SceneObject) -> bool:
    for (x, y, rad, zl, zh) in box_discs(obj):
        for (ox, oy, orad, ozl, ozh) in b.placer.discs:
            if zl < ozh and ozl < zh and math.hypot(x - ox, y - oy) < rad + orad + b.placer.gap:
                return False
    return True


def _other_colour(rng, colour: str) -> str:
    pool = [c for c in OBJECT_COLOURS if c != colour]
    return pool[int(rng.integers(len(pool)))]


def _stack(b: _Builder, colour_ban: str) -> None:
    """A book lying flat with a small object on top of it."""
    rng = b.rng
    dims = draw_dims("book", rng)
    for _ in range(20):
        c = b.comps[int(rng.integers(len(b.comps)))]
        x, y = _u(rng, c.x_lo, c.x_hi), _u(rng, c.y_lo, c.y_hi)
        r = 0.5 * math.hypot(dims[1], dims[2])
        top_cat = ("can", "box", "mug", "bowl")[int(rng.integers(4))]
        top_dims = draw_dims(top_cat, rng)
        if not b.placer.fits(c, x, y, r, dims[0] + height_of(top_cat, top_dims)):
            continue
        book = lying_book(b.name("book"), _other_colour(rng, colour_ban), dims, draw_mass("book", rng), x, y,
                          c.z_floor, _u(rng, -0.3, 0.3))
        top = build_object(b.name(top_cat), top_cat, _other_colour(rng, colour_ban), top_dims, draw_mass(top_cat, rng),
                           x, y, c.z_floor + dims[0], _u(rng, -math.pi, math.pi))
        b.placer.add(book, r)
        b.objects += [book, top]
        return


def _base_obstacles(rng: np.random.Generator, variant: str, z_cabinet: float,
                    post_beside_wall: bool = False) -> list[Primitive]:
    """Obstacles close to the robot's base and arm (levels 3 and 4); always at least one
    overhead or lateral constraint. post_beside_wall (level 4): the bar variant's post stands
    on its wall's side (on the other side, wall and post leave the severe neck grasp's elbow
    no room on either side: `certify` found no level-4 scene 7 of seed 0 in 800 candidates)."""
    def box(name, half, pos):
        return Primitive(name, "box", tuple(float(h) for h in half), tuple(float(p) for p in pos), 0.0, OBSTACLE_RGBA)

    out = []
    if variant == "overhead_plate":
        z = _u(rng, 0.98, 1.06)
        x0, x1 = _u(rng, -0.40, -0.25), _u(rng, 0.0, 0.12)
        out.append(box("base_plate", ((x1 - x0) / 2, _u(rng, 0.3, 0.45), 0.015), ((x0 + x1) / 2, _u(rng, -0.05, 0.05), z)))
    if variant in ("lateral_walls", "bar_wall_post", "overhead_plate"):
        sides = (1.0, -1.0) if variant == "lateral_walls" else ((1.0,) if rng.random() < 0.5 else (-1.0,))
        for k, s in enumerate(sides):
            y = s * _u(rng, 0.27, 0.33)
            x0, x1 = _u(rng, -0.35, -0.2), _u(rng, 0.30, 0.42)
            h = _u(rng, 0.45, 0.65) if variant == "lateral_walls" else _u(rng, 0.7, 1.1)
            out.append(box(f"base_wall{k}", ((x1 - x0) / 2, 0.015, h / 2), ((x0 + x1) / 2, y, h / 2)))
    if variant == "bar_wall_post":
        out.append(box("base_bar", (_u(rng, 0.02, 0.035), 0.45, 0.02), (_u(rng, 0.0, 0.2), 0.0, _u(rng, 0.88, 0.96))))
        s = 1.0 if rng.random() < 0.5 else -1.0
        if post_beside_wall:
            s = float(np.sign(out[0].pos[1]))
        ph = _u(rng, 0.8, 1.1)
        out.append(Primitive("base_post", "cylinder", (_u(rng, 0.025, 0.04), ph / 2),
                             (_u(rng, 0.30, 0.38), s * _u(rng, 0.27, 0.33), ph / 2), 0.0, OBSTACLE_RGBA))
    return out


#: Level 4's low bar (`forearm_bar`): half length along y [m], centre x [m] from the base (at
#: most this far before the opening plane), height [m] and offset [m] of its centre from the
#: target's y. Where the arm's good views and neck grasps differ: near the base they keep to
#: the same space (an overhead plate >= 11.7 cm above home removes none), while the forearm
#: dips towards the storey's floor under the opening for some views and grasps and not others
#: (docs/scenes.md, "Level 4's obstacles").
LOW_BAR_HALF_LENGTH = (0.03, 0.15)
LOW_BAR_X = (0.30, 0.06)
LOW_BAR_Z = (0.34, 0.50)
LOW_BAR_DY = 0.2


def forearm_bar(rng: np.random.Generator, target_y: float, x_opening: float) -> Primitive:
    """A short horizontal bar (2 x 4 cm section) across the forearm's way in front of the
    opening, below its bottom storey's top: level 4's obstacle aimed at the arm between base
    and opening (with one lateral wall, the lateral constraint, and the variant's others)."""
    half = _u(rng, *LOW_BAR_HALF_LENGTH)
    pos = (_u(rng, LOW_BAR_X[0], x_opening - LOW_BAR_X[1]), target_y + _u(rng, -LOW_BAR_DY, LOW_BAR_DY),
           _u(rng, *LOW_BAR_Z))
    return Primitive("base_low_bar", "box", (0.02, float(half), 0.02), tuple(float(v) for v in pos), 0.0,
                     OBSTACLE_RGBA)


def draw_base_obstacles(scene: SceneSpec, rng: np.random.Generator) -> tuple[Primitive, ...]:
    """A fresh draw of a level-3/4 scene's base obstacles (its variant, `scene.extra`) from rng:
    what `generate_scene` draws from its obstacle generator; level 4 adds `forearm_bar`."""
    variant = scene.extra.get("obstacle_variant", "")
    if scene.level < 3 or not variant:
        return ()
    severe = scene.level == 4
    out = _base_obstacles(rng, variant, scene.cabinet.interior_min[2], severe)
    if severe:
        out.append(forearm_bar(rng, float(scene.target.pos[1]), float(scene.cabinet.opening()[0][0])))
    return tuple(out)


def generate_scene(level: int, index: int, rng: np.random.Generator,
                   obstacle_rng: np.random.Generator | None = None) -> SceneSpec:
    """Draw one candidate scene of `level` (1..4). Pure function of the generators' states.

    obstacle_rng: levels 3/4 draw their base obstacles from it (None: from rng, after the
    rest), so one layout can be tried with several obstacle draws (`certify.certified_scene`).
    The result is not yet certified: see `certify.certified_scene`.
    """
    level = check_level(level)
    for g in (rng, obstacle_rng):
        if g is not None and not isinstance(g, np.random.Generator):
            raise CompassInputError(f"rng must be a numpy.random.Generator, got {type(g).__name__}")
    if rng is None:
        raise CompassInputError("rng must be a numpy.random.Generator, got NoneType")
    severe = level in (2, 4)
    for _ in range(50):
        try:
            return _draw(level, int(index), rng, severe, obstacle_rng)
        except _Retry:
            continue
    raise RuntimeError(f"could not lay out a level-{level} scene in 50 draws")


def _draw(level: int, index: int, rng: np.random.Generator, severe: bool,
          obstacle_rng: np.random.Generator | None = None) -> SceneSpec:
    cab, comps = draw_cabinet(rng, severe)
    b = _Builder(rng, cab, comps)
    if severe:  # a tall bottle behind a low wide box, grasped by the neck over it (`severe`)
        colour = OBJECT_COLOURS[int(rng.integers(len(OBJECT_COLOURS)))]
        found = severe_target(rng, b.placer, comps, colour, _other_colour(rng, colour), b.name("cereal_box"))
        if found is None:
            raise _Retry("no room for the severe layout")
        target, occluder, comp = found
        b.objects.append(occluder)
    else:
        target, comp = _target(b)
        _keep_hand_room(b, target, comp, 0.0)
        if not _occluders(b, target, comp) and not comp.corner:
            raise _Retry("no occluder fits")
    n_total = int(rng.integers(N_OBJECTS[0], N_OBJECTS[1] + 1))
    others = [c for c in COLOUR_DISTRACTOR_CATEGORIES if c != target.category]
    colour_cat = others[int(rng.integers(len(others)))]
    if b.place(colour_cat, target.colour, "colour_distractor") is None:
        raise _Retry("no room for the colour distractor")
    if b.place(target.category, _other_colour(rng, target.colour), "shape_distractor") is None:
        raise _Retry("no room for the shape distractor")
    n_decoys = int(rng.integers(1, 3))
    # decoys: large objects away from the space in front of the target
    away = [c for c in comps if c is not comp] or comps
    for _ in range(n_decoys):
        cat = LARGE_CATEGORIES[int(rng.integers(2))]
        b.place(cat, _other_colour(rng, target.colour), "decoy", away)
    if rng.random() < 0.5:
        _stack(b, target.colour)
    attempts = 0
    while len(b.objects) + 1 < n_total and attempts < 60:
        attempts += 1
        cat = CLUTTER_CATEGORIES[int(rng.integers(len(CLUTTER_CATEGORIES)))]
        b.place(cat, _other_colour(rng, target.colour), "clutter", tries=8)
    if not any(o.role == "decoy" for o in b.objects) or len(b.objects) + 1 < N_OBJECTS[0]:
        raise _Retry("too few objects")
    variants = SEVERE_OBSTACLE_VARIANTS if severe else OBSTACLE_VARIANTS
    variant = variants[index % len(variants)] if level >= 3 else ""
    extra = {"obstacle_variant": variant,
             "target_row": comp.row, "target_in_corner_compartment": bool(comp.corner)}
    scene = SceneSpec(level=level, index=index, seed=(), cabinet=cab, target=target, clutter=tuple(b.objects),
                      extra=extra)
    return replace(scene, base_obstacles=draw_base_obstacles(scene, obstacle_rng or rng))
