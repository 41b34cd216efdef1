"""Reading a `SceneSpec` from its JSON dictionary, checking every field.

Bad input raises `CompassInputError` naming the field, e.g. ``scene field 'target.parts[0].size':
NaN is not a finite number``. Numbers must be JSON numbers (a string "12" is refused), integer
fields must be whole numbers (1.9 is refused) and the level must be 1..4.
"""
from __future__ import annotations

import math

from ..errors import CompassInputError
from .scenes import CabinetSpec, Primitive, SceneObject, SceneSpec

LEVELS = (1, 2, 3, 4)


def _fail(where: str, what: str) -> CompassInputError:
    return CompassInputError(f"scene field {where!r}: {what}")


def _get(d: dict, key: str, where: str, default=...):
    if not isinstance(d, dict):
        raise _fail(where, f"expected an object (dictionary), got {type(d).__name__}")
    if key not in d:
        if default is not ...:
            return default
        raise _fail(f"{where}.{key}" if where else key, "missing")
    return d[key]


def _num(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _fail(where, f"expected a number, got {type(v).__name__} {v!r}")
    if not math.isfinite(float(v)):
        raise _fail(where, f"{v!r} is not a finite number")
    return float(v)


def _int(v, where: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (isinstance(v, float) and not v.is_integer()):
        raise _fail(where, f"expected a whole number, got {type(v).__name__} {v!r}")
    return int(v)


def _vec(v, n: int | None, where: str) -> tuple[float, ...]:
    if not isinstance(v, (list, tuple)):
        raise _fail(where, f"expected a list of numbers, got {type(v).__name__}")
    if n is not None and len(v) != n:
        raise _fail(where, f"expected {n} numbers, got {len(v)}")
    return tuple(_num(x, f"{where}[{i}]") for i, x in enumerate(v))


def _list(v, where: str) -> list:
    if not isinstance(v, (list, tuple)):
        raise _fail(where, f"expected a list, got {type(v).__name__}")
    return list(v)


def _str(v, where: str) -> str:
    if not isinstance(v, str):
        raise _fail(where, f"expected a string, got {type(v).__name__}")
    return v


def _wrap(build, where: str):
    try:
        return build()
    except CompassInputError as exc:
        if str(exc).startswith("scene field"):
            raise
        raise _fail(where, str(exc)) from exc


def primitive_from_dict(d, where: str) -> Primitive:
    name = _str(_get(d, "name", where), f"{where}.name")
    shape = _str(_get(d, "shape", where), f"{where}.shape")
    size = _vec(_get(d, "size", where), None, f"{where}.size")
    pos = _vec(_get(d, "pos", where), 3, f"{where}.pos")
    yaw = _num(_get(d, "yaw", where, 0.0), f"{where}.yaw")
    rgba = _vec(_get(d, "rgba", where, (0.6, 0.6, 0.6, 1.0)), 4, f"{where}.rgba")
    movable = bool(_get(d, "movable", where, False))
    mass = _num(_get(d, "mass", where, 0.1), f"{where}.mass")
    return _wrap(lambda: Primitive(name, shape, size, pos, yaw, rgba, movable, mass), where)


def object_from_dict(d, where: str) -> SceneObject:
    name = _str(_get(d, "name", where), f"{where}.name")
    parts = tuple(primitive_from_dict(p, f"{where}.parts[{i}]")
                  for i, p in enumerate(_list(_get(d, "parts", where), f"{where}.parts")))
    category = _str(_get(d, "category", where), f"{where}.category")
    colour = _str(_get(d, "colour", where), f"{where}.colour")
    mass = _num(_get(d, "mass", where), f"{where}.mass")
    role = _str(_get(d, "role", where, "clutter"), f"{where}.role")
    return _wrap(lambda: SceneObject(name, category, colour, parts, mass, role), where)


def cabinet_from_dict(d, where: str = "cabinet") -> CabinetSpec:
    lo = _vec(_get(d, "interior_min", where), 3, f"{where}.interior_min")
    hi = _vec(_get(d, "interior_max", where), 3, f"{where}.interior_max")
    frame = _vec(_get(d, "frame", where, (0.0, 0.0, 0.0, 0.0)), 4, f"{where}.frame")
    shelves = _vec(_get(d, "shelves", where, ()), None, f"{where}.shelves")
    inner = tuple(primitive_from_dict(p, f"{where}.inner[{i}]")
                  for i, p in enumerate(_list(_get(d, "inner", where, ()), f"{where}.inner")))
    rgba = _vec(_get(d, "rgba", where, (0.55, 0.42, 0.3, 1.0)), 4, f"{where}.rgba")
    rail = _num(_get(d, "rail", where, 0.0), f"{where}.rail")
    return _wrap(lambda: CabinetSpec(lo, hi, frame, shelves, inner, rgba, rail), where)


def scene_from_dict(d) -> SceneSpec:
    """A SceneSpec from `SceneSpec.to_dict()` output; every field checked."""
    if not isinstance(d, dict):
        raise CompassInputError(f"a scene must be a JSON object (dictionary), got {type(d).__name__}")
    level = _int(_get(d, "level", ""), "level")
    if level not in LEVELS:
        raise _fail("level", f"{level} is not allowed; use one of 1, 2, 3, 4")
    index = _int(_get(d, "index", ""), "index")
    if index < 0:
        raise _fail("index", f"{index} is not allowed; use an integer >= 0")
    seed = tuple(_int(s, f"seed[{i}]") for i, s in enumerate(_list(_get(d, "seed", ""), "seed")))
    if any(s < 0 for s in seed):
        raise _fail("seed", f"{seed} must hold integers >= 0")
    cabinet = cabinet_from_dict(_get(d, "cabinet", ""))
    target = object_from_dict(_get(d, "target", ""), "target")
    clutter = tuple(object_from_dict(o, f"clutter[{i}]") for i, o in enumerate(_list(_get(d, "clutter", ""), "clutter")))
    obstacles = tuple(primitive_from_dict(p, f"base_obstacles[{i}]")
                      for i, p in enumerate(_list(_get(d, "base_obstacles", "", ()), "base_obstacles")))
    base_pos = _vec(_get(d, "robot_base_pos", "", (0.0, 0.0, 0.0)), 3, "robot_base_pos")
    base_yaw = _num(_get(d, "robot_base_yaw", "", 0.0), "robot_base_yaw")
    floor_z = _num(_get(d, "floor_z", "", 0.0), "floor_z")
    extra = _get(d, "extra", "", {})
    if not isinstance(extra, dict):
        raise _fail("extra", f"expected an object (dictionary), got {type(extra).__name__}")
    names = [p.name for o in clutter + (target,) for p in o.parts] + [o.name for o in clutter + (target,)]
    if len(set(names)) != len(names):
        raise _fail("clutter", "object and part names must be unique")
    return SceneSpec(level, index, seed, cabinet, target, clutter, obstacles, base_pos, base_yaw, floor_z, dict(extra))
