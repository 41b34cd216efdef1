"""Scene description as pure data: `SceneSpec` and its JSON round trip.

Nothing here imports MuJoCo. World frame: the robot base stands at the origin (by default),
+x points into the confined space, +z up. Lengths in [m], angles in [rad].
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from ..errors import CompassInputError
from ..task import ConfinedSpace, TargetQuery, Task, colour_name

SHAPES = ("box", "cylinder", "sphere")
#: Wall thickness of the cabinet boards [m].
BOARD_THICKNESS = 0.02


@dataclass(frozen=True)
class Primitive:
    """A rigid primitive.

    shape: "box" (size = half extents x, y, z), "cylinder" (size = radius, half height) or
    "sphere" (size = radius). pos [m] is the centre, yaw [rad] a rotation about world z.
    movable objects are free bodies in physics; the others are welded to the world.
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
        if len(self.size) != n or min(self.size) <= 0:
            raise CompassInputError(
                f"primitive {self.name!r}: {self.shape} needs {n} positive size values, got {self.size}"
            )

    @property
    def half_extents(self) -> np.ndarray:
        """Half extents [m] of the primitive's own (yaw-rotated) bounding box."""
        s = self.size
        if self.shape == "box":
            return np.array(s, dtype=float)
        if self.shape == "cylinder":
            return np.array([s[0], s[0], s[1]], dtype=float)
        return np.array([s[0]] * 3, dtype=float)

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounding box (min, max) [m]."""
        h = self.half_extents
        c, s = abs(np.cos(self.yaw)), abs(np.sin(self.yaw))
        hw = np.array([c * h[0] + s * h[1], s * h[0] + c * h[1], h[2]])
        p = np.array(self.pos)
        return p - hw, p + hw


@dataclass(frozen=True)
class CabinetSpec:
    """A cabinet with an open front facing -x (towards the robot).

    interior_min / interior_max [m]: the free interior box. Boards of BOARD_THICKNESS
    surround it on every side but the front. shelves: heights [m] of extra horizontal
    boards (top surface) spanning the interior's back `shelf_depth` fraction. partitions:
    (y [m], depth fraction) vertical boards from the back wall towards the front.
    stand: a box under the cabinet down to the floor.
    """

    interior_min: tuple[float, float, float]
    interior_max: tuple[float, float, float]
    shelves: tuple[float, ...] = ()
    shelf_depth: float = 1.0
    partitions: tuple[tuple[float, float], ...] = ()
    rgba: tuple[float, float, float, float] = (0.55, 0.42, 0.3, 1.0)

    def boards(self) -> list[Primitive]:
        """The cabinet's boards and stand as static boxes."""
        lo, hi = np.array(self.interior_min), np.array(self.interior_max)
        t = BOARD_THICKNESS
        c = (lo + hi) / 2
        half = (hi - lo) / 2
        out = [
            Primitive("cab_bottom", "box", (half[0] + t / 2, half[1] + t, t / 2), (c[0] + t / 2, c[1], lo[2] - t / 2)),
            Primitive("cab_top", "box", (half[0] + t / 2, half[1] + t, t / 2), (c[0] + t / 2, c[1], hi[2] + t / 2)),
            Primitive("cab_back", "box", (t / 2, half[1] + t, half[2]), (hi[0] + t / 2, c[1], c[2])),
            Primitive("cab_left", "box", (half[0] + t / 2, t / 2, half[2]), (c[0] + t / 2, hi[1] + t / 2, c[2])),
            Primitive("cab_right", "box", (half[0] + t / 2, t / 2, half[2]), (c[0] + t / 2, lo[1] - t / 2, c[2])),
        ]
        stand_h = (lo[2] - t) / 2
        if stand_h > 1e-3:
            out.append(
                Primitive("cab_stand", "box", (half[0] + t / 2, half[1] + t, stand_h), (c[0] + t / 2, c[1], stand_h))
            )
        for i, z in enumerate(self.shelves):
            d = (hi[0] - lo[0]) * self.shelf_depth
            out.append(Primitive(f"cab_shelf{i}", "box", (d / 2, half[1], t / 2), (hi[0] - d / 2, c[1], z - t / 2)))
        for i, (y, frac) in enumerate(self.partitions):
            d = (hi[0] - lo[0]) * frac
            out.append(Primitive(f"cab_partition{i}", "box", (d / 2, t / 2, half[2]), (hi[0] - d / 2, y, c[2])))
        return [Primitive(p.name, p.shape, p.size, p.pos, p.yaw, self.rgba) for p in out]


@dataclass(frozen=True)
class SceneSpec:
    """A confined scene: cabinet, clutter, target, obstacles near the robot base.

    level 1..4, index within the level, seed: the sub-seed that generated it (so the scene
    can be regenerated). Pure data; `to_json` / `from_json` round-trip it exactly.
    """

    level: int
    index: int
    seed: tuple[int, ...]
    cabinet: CabinetSpec
    target: Primitive
    clutter: tuple[Primitive, ...] = ()
    base_obstacles: tuple[Primitive, ...] = ()
    robot_base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    robot_base_yaw: float = 0.0
    floor_z: float = 0.0
    extra: dict = field(default_factory=dict)

    def task(self, time_limit_s: float = 200.0) -> Task:
        """What a method may know of this scene: base, floor, the cabinet's outer geometry
        and opening, and a description of the target (never its pose, nor the contents)."""
        lo, hi = self.cabinet.interior_min, self.cabinet.interior_max
        space = ConfinedSpace(
            interior_min=tuple(float(v) for v in lo), interior_max=tuple(float(v) for v in hi),
            opening_min=(float(lo[0]), float(lo[1]), float(lo[2])),
            opening_max=(float(lo[0]), float(hi[1]), float(hi[2])),
            outward=(-1.0, 0.0, 0.0), wall_thickness=BOARD_THICKNESS,
        )
        return Task(
            robot_base_pos=tuple(float(v) for v in self.robot_base_pos),
            robot_base_yaw=float(self.robot_base_yaw), floor_z=float(self.floor_z),
            space=space, target=target_query(self.target), time_limit_s=float(time_limit_s),
        )

    def static_primitives(self) -> list[Primitive]:
        """Everything that does not move: cabinet boards and the obstacles near the base."""
        return self.cabinet.boards() + list(self.base_obstacles)

    def all_primitives(self) -> list[Primitive]:
        """Static primitives, then clutter, then the target (last)."""
        return self.static_primitives() + list(self.clutter) + [self.target]

    def to_dict(self) -> dict:
        return asdict(self)

    def to_json(self, indent: int | None = 1) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, d: dict) -> "SceneSpec":
        try:
            cab = d["cabinet"]
            cabinet = CabinetSpec(
                interior_min=tuple(cab["interior_min"]),
                interior_max=tuple(cab["interior_max"]),
                shelves=tuple(cab["shelves"]),
                shelf_depth=cab["shelf_depth"],
                partitions=tuple(tuple(p) for p in cab["partitions"]),
                rgba=tuple(cab["rgba"]),
            )
            return cls(
                level=int(d["level"]),
                index=int(d["index"]),
                seed=tuple(int(s) for s in d["seed"]),
                cabinet=cabinet,
                target=_primitive(d["target"]),
                clutter=tuple(_primitive(p) for p in d["clutter"]),
                base_obstacles=tuple(_primitive(p) for p in d["base_obstacles"]),
                robot_base_pos=tuple(d["robot_base_pos"]),
                robot_base_yaw=float(d["robot_base_yaw"]),
                floor_z=float(d["floor_z"]),
                extra=dict(d.get("extra", {})),
            )
        except (KeyError, TypeError) as exc:
            raise CompassInputError(f"not a valid SceneSpec dictionary: missing or bad field {exc}") from exc

    @classmethod
    def from_json(cls, text: str) -> "SceneSpec":
        try:
            d = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CompassInputError(f"scene JSON does not parse: {exc}") from exc
        return cls.from_dict(d)


def target_query(p: Primitive) -> TargetQuery:
    """The description a method gets of a target primitive: shape class, colour name and
    full extents [m] with the two horizontal ones sorted (x >= y)."""
    h = p.half_extents
    a, b = sorted((2 * float(h[0]), 2 * float(h[1])), reverse=True)
    return TargetQuery(shape=p.shape, colour=colour_name(p.rgba), size=(a, b, 2 * float(h[2])))


def _primitive(d: dict) -> Primitive:
    names = {f.name for f in fields(Primitive)}
    kw = {k: v for k, v in d.items() if k in names}
    for k in ("size", "pos", "rgba"):
        kw[k] = tuple(kw[k])
    return Primitive(**kw)
