"""Scene description as pure data: `Primitive`, `SceneObject`, `CabinetSpec`, `SceneSpec`.

Nothing here imports MuJoCo. World frame: the robot base stands at the origin (by default),
+x points into the confined space, +z up. Lengths in [m], angles in [rad], masses in [kg].
The JSON reader with its input checks lives in `scene_io`.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import CompassInputError
from ..task import COLOURS, SHAPE_CLASSES, ConfinedSpace, TargetQuery, Task, colour_name

SHAPES = ("box", "cylinder", "sphere")
#: Thickness of the cabinet boards [m].
BOARD_THICKNESS = 0.02
#: What an object is in a scene (recorded for analysis; a method never sees it).
ROLES = ("target", "occluder", "decoy", "colour_distractor", "shape_distractor", "clutter")
BOARD_RGBA = (0.55, 0.42, 0.3, 1.0)


def _finite(values, what: str) -> None:
    if not all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
               and math.isfinite(float(v)) for v in values):
        raise CompassInputError(f"{what} must be finite numbers, got {tuple(values)!r}")


@dataclass(frozen=True)
class Primitive:
    """A rigid primitive: a cabinet board, a base obstacle or one part of an object.

    shape: "box" (size = half extents x, y, z), "cylinder" (size = radius, half height) or
    "sphere" (size = radius). pos [m] is the centre in the world, yaw [rad] a rotation about
    world z. movable / mass [kg] are kept for old scene files; objects carry their own.
    """

    name: str
    shape: str
    size: tuple[float, ...]
    pos: tuple[float, float, float]
    yaw: float = 0.0
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)
    movable: bool = False
    mass: float = 0.1

    def __post_init__(self) -> None:
        n = {"box": 3, "cylinder": 2, "sphere": 1}.get(self.shape)
        if n is None:
            raise CompassInputError(f"primitive {self.name!r}: shape {self.shape!r} is not one of {SHAPES}")
        _finite(self.size, f"primitive {self.name!r} size")
        _finite(self.pos, f"primitive {self.name!r} pos")
        _finite((self.yaw, self.mass), f"primitive {self.name!r} yaw and mass")
        if len(self.size) != n or min(self.size) <= 0:
            raise CompassInputError(
                f"primitive {self.name!r}: {self.shape} needs {n} positive size values, got {self.size}"
            )
        if len(self.pos) != 3 or len(self.rgba) != 4:
            raise CompassInputError(f"primitive {self.name!r}: pos needs 3 values and rgba 4")

    @property
    def half_extents(self) -> np.ndarray:
        """Half extents [m] of the primitive's own (yaw-rotated) bounding box."""
        s = self.size
        if self.shape == "box":
            return np.array(s, dtype=float)
        if self.shape == "cylinder":
            return np.array([s[0], s[0], s[1]], dtype=float)
        return np.array([s[0]] * 3, dtype=float)

    @property
    def volume(self) -> float:
        """Volume [m^3]."""
        s = self.size
        if self.shape == "box":
            return 8.0 * s[0] * s[1] * s[2]
        if self.shape == "cylinder":
            return 2.0 * math.pi * s[0] ** 2 * s[1]
        return 4.0 / 3.0 * math.pi * s[0] ** 3

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounding box (min, max) [m]."""
        h = self.half_extents
        c, s = abs(np.cos(self.yaw)), abs(np.sin(self.yaw))
        if self.shape == "box":
            hw = np.array([c * h[0] + s * h[1], s * h[0] + c * h[1], h[2]])
        else:
            hw = h
        p = np.array(self.pos)
        return p - hw, p + hw


@dataclass(frozen=True)
class SceneObject:
    """A movable household object built from primitives, one rigid body in physics.

    category: its shape class (one of `task.SHAPE_CLASSES`); colour: its colour name (one of
    `task.COLOURS`); parts: primitives in world coordinates (part names are unique in the
    scene); mass [kg] of the whole object, shared among the parts by volume; role: one of
    `ROLES`. The body's origin is the centre of the parts' bounding box.
    """

    name: str
    category: str
    colour: str
    parts: tuple[Primitive, ...]
    mass: float
    role: str = "clutter"

    def __post_init__(self) -> None:
        if self.category not in SHAPE_CLASSES:
            raise CompassInputError(f"object {self.name!r}: category {self.category!r} is not one of {SHAPE_CLASSES}")
        if self.colour not in COLOURS:
            raise CompassInputError(f"object {self.name!r}: colour {self.colour!r} is not one of {tuple(COLOURS)}")
        if self.role not in ROLES:
            raise CompassInputError(f"object {self.name!r}: role {self.role!r} is not one of {ROLES}")
        if not self.parts:
            raise CompassInputError(f"object {self.name!r} needs at least one part")
        _finite((self.mass,), f"object {self.name!r} mass")
        if not 0.0 < self.mass <= 20.0:
            raise CompassInputError(f"object {self.name!r}: mass {self.mass} kg must be in (0, 20]")

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounding box (min, max) [m] of all parts."""
        boxes = [p.aabb() for p in self.parts]
        return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)

    @classmethod
    def single(cls, part: Primitive, role: str = "clutter") -> "SceneObject":
        """A one-part object from a primitive: its shape is its class, its colour the name
        nearest its rgba, its mass the primitive's (for hand-built test and demo scenes)."""
        return cls(part.name, part.shape, colour_name(part.rgba), (part,), part.mass, role)

    @property
    def pos(self) -> np.ndarray:
        """Body origin [m]: the centre of the bounding box."""
        lo, hi = self.aabb()
        return (lo + hi) / 2

    @property
    def size(self) -> tuple[float, float, float]:
        """Full extents (a, b, height) [m], horizontal ones sorted a >= b (yaw-independent
        for a single part; the bounding box of the parts otherwise)."""
        if len(self.parts) == 1 and self.parts[0].shape == "box":
            h = 2 * self.parts[0].half_extents
        else:
            lo, hi = self.aabb()
            h = hi - lo
        a, b = sorted((float(h[0]), float(h[1])), reverse=True)
        return a, b, float(h[2])

    @property
    def rgba(self) -> tuple[float, float, float, float]:
        return self.parts[0].rgba


@dataclass(frozen=True)
class CabinetSpec:
    """A cabinet or shelving unit with an open front facing -x (towards the robot).

    interior_min / interior_max [m]: the free interior box. Boards of BOARD_THICKNESS
    surround it on every side but the front. frame: widths [m] of the face frame (left = +y
    side, right = -y side, top, bottom) standing just in front of the interior, which narrows
    the opening. shelves: top-surface heights [m] of full-width, full-depth shelf boards.
    inner: further static boards (partitions, compartment walls) as primitives. rail [m]: the
    face frame's rail in front of each shelf reaches this far below the shelf (and half as
    far above it).
    """

    interior_min: tuple[float, float, float]
    interior_max: tuple[float, float, float]
    frame: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    shelves: tuple[float, ...] = ()
    inner: tuple[Primitive, ...] = ()
    rgba: tuple[float, float, float, float] = BOARD_RGBA
    rail: float = 0.0

    def __post_init__(self) -> None:
        _finite(tuple(self.interior_min) + tuple(self.interior_max), "cabinet interior_min/max")
        _finite(tuple(self.frame) + tuple(self.shelves) + (self.rail,), "cabinet frame, shelves and rail")
        lo, hi = np.array(self.interior_min), np.array(self.interior_max)
        if lo.shape != (3,) or hi.shape != (3,) or np.any(hi - lo < 0.05):
            raise CompassInputError(f"cabinet interior {self.interior_min}..{self.interior_max} is not a box")
        if not 0.0 <= self.rail <= 0.1:
            raise CompassInputError(f"cabinet rail {self.rail} m must be in 0..0.1 m")
        if len(self.frame) != 4 or min(self.frame) < 0:
            raise CompassInputError(f"cabinet frame {self.frame} needs 4 widths >= 0 [m]")
        for z in self.shelves:
            if not lo[2] + 0.05 < z < hi[2] - 0.05:
                raise CompassInputError(f"cabinet shelf at z = {z} m is outside the interior")

    def opening(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(min, max) [m] of the open face left by the face frame (zero thickness in x)."""
        lo, hi = self.interior_min, self.interior_max
        left, right, top, bottom = self.frame
        return ((float(lo[0]), float(lo[1] + right), float(lo[2] + bottom)),
                (float(lo[0]), float(hi[1] - left), float(hi[2] - top)))

    def rows(self) -> list[tuple[float, float]]:
        """(floor z, ceiling z) [m] of each storey between the shelves, bottom first."""
        lo, hi = self.interior_min[2], self.interior_max[2]
        floors = [lo] + list(self.shelves)
        ceilings = [z - BOARD_THICKNESS for z in self.shelves] + [hi]
        return list(zip(floors, ceilings))

    def boards(self) -> list[Primitive]:
        """All static boards: outer box, stand, face frame, shelves, inner boards."""
        lo, hi = np.array(self.interior_min), np.array(self.interior_max)
        t = BOARD_THICKNESS
        c, half = (lo + hi) / 2, (hi - lo) / 2
        xc, hx = c[0] - t / 2, half[0] + t / 2  # side, top and bottom boards also span the face frame
        out = [
            Primitive("cab_bottom", "box", (hx, half[1] + t, t / 2), (xc, c[1], lo[2] - t / 2)),
            Primitive("cab_top", "box", (hx, half[1] + t, t / 2), (xc, c[1], hi[2] + t / 2)),
            Primitive("cab_back", "box", (t / 2, half[1] + t, half[2] + t), (hi[0] + t / 2, c[1], c[2])),
            Primitive("cab_left", "box", (hx, t / 2, half[2]), (xc, hi[1] + t / 2, c[2])),
            Primitive("cab_right", "box", (hx, t / 2, half[2]), (xc, lo[1] - t / 2, c[2])),
        ]
        stand_h = (lo[2] - t) / 2
        if stand_h > 1e-3:
            out.append(Primitive("cab_stand", "box", (hx, half[1] + t, stand_h), (xc, c[1], stand_h)))
        left, right, top, bottom = self.frame
        xf = lo[0] - t / 2
        if left > 0:
            out.append(Primitive("frame_left", "box", (t / 2, left / 2, half[2]), (xf, hi[1] - left / 2, c[2])))
        if right > 0:
            out.append(Primitive("frame_right", "box", (t / 2, right / 2, half[2]), (xf, lo[1] + right / 2, c[2])))
        if top > 0:
            out.append(Primitive("frame_top", "box", (t / 2, half[1], top / 2), (xf, c[1], hi[2] - top / 2)))
        if bottom > 0:
            out.append(Primitive("frame_bottom", "box", (t / 2, half[1], bottom / 2), (xf, c[1], lo[2] + bottom / 2)))
        for i, z in enumerate(self.shelves):
            out.append(Primitive(f"cab_shelf{i}", "box", (half[0], half[1], t / 2), (c[0], c[1], z - t / 2)))
            if self.rail > 0:  # a face-frame rail across the front of the shelf
                lo_r, hi_r = z - t - self.rail, z + 0.5 * self.rail
                out.append(Primitive(f"frame_rail{i}", "box", (t / 2, half[1], (hi_r - lo_r) / 2),
                                     (xf, c[1], (lo_r + hi_r) / 2)))
        out.extend(self.inner)
        return [Primitive(p.name, p.shape, p.size, p.pos, p.yaw, self.rgba) for p in out]


@dataclass(frozen=True)
class SceneSpec:
    """A confined scene: cabinet, objects (one of them the target), obstacles near the base.

    level 1..4, index within the level, seed: the sub-seed that generated it (so the scene
    can be regenerated). Pure data; `to_json` / `from_json` round-trip it exactly.
    """

    level: int
    index: int
    seed: tuple[int, ...]
    cabinet: CabinetSpec
    target: SceneObject
    clutter: tuple[SceneObject, ...] = ()
    base_obstacles: tuple[Primitive, ...] = ()
    robot_base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    robot_base_yaw: float = 0.0
    floor_z: float = 0.0
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        # a bare Primitive given as the target or clutter becomes a one-part object
        if isinstance(self.target, Primitive):
            object.__setattr__(self, "target", SceneObject.single(self.target, "target"))
        if any(isinstance(o, Primitive) for o in self.clutter):
            object.__setattr__(self, "clutter", tuple(SceneObject.single(o) if isinstance(o, Primitive) else o
                                                      for o in self.clutter))

    def task(self, time_limit_s: float = 200.0) -> Task:
        """What a method may know of this scene: base, floor, the cabinet's outer interior box
        and its opening (narrowed by the face frame), and a description of the target; never
        the target's pose, the shelves, partitions, contents or base obstacles."""
        lo, hi = self.cabinet.interior_min, self.cabinet.interior_max
        o_lo, o_hi = self.cabinet.opening()
        space = ConfinedSpace(
            interior_min=tuple(float(v) for v in lo), interior_max=tuple(float(v) for v in hi),
            opening_min=o_lo, opening_max=o_hi, outward=(-1.0, 0.0, 0.0), wall_thickness=BOARD_THICKNESS,
        )
        return Task(
            robot_base_pos=tuple(float(v) for v in self.robot_base_pos),
            robot_base_yaw=float(self.robot_base_yaw), floor_z=float(self.floor_z),
            space=space, target=target_query(self.target), time_limit_s=float(time_limit_s),
        )

    @property
    def objects(self) -> tuple[SceneObject, ...]:
        """All movable objects, the target last."""
        return tuple(self.clutter) + (self.target,)

    def static_primitives(self) -> list[Primitive]:
        """Everything that does not move: cabinet boards and the obstacles near the base."""
        return self.cabinet.boards() + list(self.base_obstacles)

    def object_primitives(self) -> list[Primitive]:
        """The parts of all objects, the target's last."""
        return [p for o in self.objects for p in o.parts]

    def all_primitives(self) -> list[Primitive]:
        """Static primitives, then the objects' parts (the target's last)."""
        return self.static_primitives() + self.object_primitives()

    def to_dict(self) -> dict:
        return asdict(self)

    def to_json(self, indent: int | None = 1) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, d: dict) -> "SceneSpec":
        from .scene_io import scene_from_dict

        return scene_from_dict(d)

    @classmethod
    def from_json(cls, text: str) -> "SceneSpec":
        try:
            d = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CompassInputError(f"scene JSON does not parse: {exc}") from exc
        return cls.from_dict(d)


def target_query(obj: SceneObject | Primitive) -> TargetQuery:
    """The description a method gets of a target object (or a one-part object given as a
    primitive): shape class, colour name and full extents [m], horizontal ones sorted."""
    if isinstance(obj, Primitive):
        obj = SceneObject.single(obj, "target")
    return TargetQuery(shape=obj.category, colour=obj.colour, size=obj.size)
