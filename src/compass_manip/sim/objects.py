"""Household objects built from primitives: cereal boxes, books, boxes, cans, bottles, mugs,
bowls and balls, with realistic sizes [m] and masses [kg].

`draw_dims(category, rng)` draws the dimensions of one object; `build_object(...)` places it
standing on a support surface at height z [m] with a yaw [rad]; `footprint_radius(...)` is
the radius [m] of a circle about its centre that covers its footprint (for placement).
"""
from __future__ import annotations

import math

import numpy as np

from ..task import COLOURS
from .scenes import Primitive, SceneObject

#: category -> (dimension ranges, mass range [kg]). Box-like: (depth x, width y, height z)
#: full extents; cylinder-like: (radius, height); bottle: (radius, body height, neck radius,
#: neck height); mug / bowl: (outer radius, height); sphere: (radius,).
CATALOGUE = {
    "cereal_box": (((0.05, 0.07), (0.14, 0.19), (0.17, 0.24)), (0.3, 0.5)),
    "book": (((0.022, 0.04), (0.13, 0.17), (0.17, 0.23)), (0.25, 0.6)),
    "box": (((0.04, 0.06), (0.04, 0.065), (0.05, 0.12)), (0.08, 0.25)),
    "can": (((0.028, 0.034), (0.09, 0.125)), (0.12, 0.35)),
    "bottle": (((0.028, 0.034), (0.10, 0.15), (0.011, 0.015), (0.035, 0.055)), (0.15, 0.4)),
    "mug": (((0.038, 0.045), (0.08, 0.10)), (0.2, 0.35)),
    "bowl": (((0.06, 0.075), (0.045, 0.06)), (0.15, 0.3)),
    "sphere": (((0.028, 0.04),), (0.05, 0.2)),
}
#: Categories a target may have: graspable across by the Panda hand (< 0.07 m wide).
TARGET_CATEGORIES = ("can", "bottle", "box")
#: Categories big enough to hide a target.
LARGE_CATEGORIES = ("cereal_box", "book")
WALL = 0.008  # wall thickness of mugs and bowls [m]


def rgba_of(colour: str) -> tuple[float, float, float, float]:
    r, g, b = COLOURS[colour]
    return (float(r), float(g), float(b), 1.0)


def draw_dims(category: str, rng: np.random.Generator) -> tuple[float, ...]:
    ranges, _ = CATALOGUE[category]
    return tuple(float(rng.uniform(lo, hi)) for lo, hi in ranges)


def draw_mass(category: str, rng: np.random.Generator) -> float:
    lo, hi = CATALOGUE[category][1]
    return float(rng.uniform(lo, hi))


def height_of(category: str, dims: tuple[float, ...]) -> float:
    """Standing height [m]."""
    if category in ("cereal_box", "book", "box"):
        return dims[2]
    if category == "bottle":
        return dims[1] + dims[3]
    if category == "sphere":
        return 2 * dims[0]
    return dims[1]


def footprint_radius(category: str, dims: tuple[float, ...]) -> float:
    if category in ("cereal_box", "book", "box"):
        return 0.5 * math.hypot(dims[0], dims[1])
    return dims[0] + (0.02 if category == "mug" else 0.0)  # a mug's handle sticks out


def _ring(name: str, r_out: float, h: float, z0: float, x: float, y: float, rgba, n: int = 8) -> list[Primitive]:
    """n boxes around a circle: the wall of a mug or bowl."""
    out = []
    r_mid = r_out - WALL / 2
    half_t = r_out * math.tan(math.pi / n) + 1e-4
    for k in range(n):
        a = 2 * math.pi * k / n
        out.append(Primitive(f"{name}/wall{k}", "box", (WALL / 2, half_t, h / 2),
                             (x + r_mid * math.cos(a), y + r_mid * math.sin(a), z0 + h / 2), a, rgba))
    return out


def build_object(name: str, category: str, colour: str, dims: tuple[float, ...], mass: float,
                 x: float, y: float, z: float, yaw: float, role: str = "clutter") -> SceneObject:
    """The object standing with its bottom at height z [m], centred at (x, y) [m]."""
    rgba = rgba_of(colour)
    x, y, z, yaw = float(x), float(y), float(z), float(yaw)
    if category in ("cereal_box", "book", "box"):
        parts = [Primitive(f"{name}/body", "box", (dims[0] / 2, dims[1] / 2, dims[2] / 2), (x, y, z + dims[2] / 2), yaw, rgba)]
    elif category == "can":
        parts = [Primitive(f"{name}/body", "cylinder", (dims[0], dims[1] / 2), (x, y, z + dims[1] / 2), 0.0, rgba)]
    elif category == "bottle":
        r, hb, rn, hn = dims
        parts = [Primitive(f"{name}/body", "cylinder", (r, hb / 2), (x, y, z + hb / 2), 0.0, rgba),
                 Primitive(f"{name}/neck", "cylinder", (rn, hn / 2), (x, y, z + hb + hn / 2), 0.0, rgba)]
    elif category in ("mug", "bowl"):
        r, h = dims
        bottom = 0.006
        parts = [Primitive(f"{name}/bottom", "cylinder", (r - WALL / 2, bottom / 2), (x, y, z + bottom / 2), 0.0, rgba)]
        parts += _ring(name, r, h - bottom, z + bottom, x, y, rgba, 8 if category == "mug" else 10)
        if category == "mug":
            c, s = math.cos(yaw), math.sin(yaw)
            parts.append(Primitive(f"{name}/handle", "box", (0.011, 0.006, 0.3 * h),
                                   (x + (r + 0.009) * c, y + (r + 0.009) * s, z + 0.5 * h), yaw, rgba))
    elif category == "sphere":
        parts = [Primitive(f"{name}/body", "sphere", (dims[0],), (x, y, z + dims[0]), 0.0, rgba)]
    else:
        raise ValueError(f"unknown category {category!r}")
    return SceneObject(name, category, colour, tuple(parts), float(mass), role)


def lying_book(name: str, colour: str, dims: tuple[float, ...], mass: float, x: float, y: float, z: float,
               yaw: float, role: str = "clutter") -> SceneObject:
    """A book lying flat (its thickness vertical): a support for a stacked object."""
    t, w, h = dims
    part = Primitive(f"{name}/body", "box", (h / 2, w / 2, t / 2), (float(x), float(y), float(z) + t / 2), float(yaw),
                     rgba_of(colour))
    return SceneObject(name, "book", colour, (part,), float(mass), role)
