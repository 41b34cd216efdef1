"""What a method may know: the `Task` and its `TargetQuery`.

This is the boundary between a method (exploration, detection, grasping) and the world it
acts in. A method is told what a robot would be told before a trial: where its base is,
where the floor is, the outer geometry of the confined space and its opening, and a
description of the target. It is never told where the target is, what else is inside the
confined space (shelves, partitions, clutter) or what stands near its base: those it has to
sense. `sim.scenes.SceneSpec.task()` builds the Task of a simulated scene; on a real robot it
is written by hand.

World frame: +z up, lengths in [m], angles in [rad].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import CompassInputError

#: Shape classes a `TargetQuery` may name.
SHAPE_CLASSES = ("box", "cylinder", "sphere", "can", "bottle", "mug", "bowl", "book", "cereal_box")
#: Colour names a `TargetQuery` may name, with their reference RGB in [0, 1].
COLOURS: dict[str, tuple[float, float, float]] = {
    "red": (0.9, 0.05, 0.05),
    "orange": (0.95, 0.5, 0.05),
    "yellow": (0.85, 0.75, 0.2),
    "green": (0.25, 0.65, 0.3),
    "cyan": (0.3, 0.7, 0.7),
    "blue": (0.2, 0.45, 0.8),
    "purple": (0.55, 0.35, 0.7),
    "white": (0.9, 0.9, 0.85),
    "grey": (0.6, 0.6, 0.6),
    "brown": (0.35, 0.3, 0.25),
}


def colour_name(rgb) -> str:
    """The name in `COLOURS` nearest to an RGB(A) colour with components in [0, 1]."""
    c = np.asarray(rgb, dtype=float)[:3]
    return min(COLOURS, key=lambda k: float(np.sum((np.asarray(COLOURS[k]) - c) ** 2)))


@dataclass(frozen=True)
class TargetQuery:
    """A description of the target, the analogue of the paper's text prompt to its detector.

    shape: one of `SHAPE_CLASSES`; colour: one of `COLOURS`; size: approximate full extents
    (x, y, z) [m] of the object's bounding box in its own upright frame (x >= y, z up).
    """

    shape: str
    colour: str
    size: tuple[float, float, float]

    def __post_init__(self) -> None:
        if self.shape not in SHAPE_CLASSES:
            raise CompassInputError(f"target shape {self.shape!r} is not one of {SHAPE_CLASSES}")
        if self.colour not in COLOURS:
            raise CompassInputError(f"target colour {self.colour!r} is not one of {tuple(COLOURS)}")
        s = np.asarray(self.size, dtype=float)
        if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s <= 0) or np.any(s > 1.0):
            raise CompassInputError(f"target size {self.size!r} must be 3 finite extents in (0, 1] m")

    @property
    def text(self) -> str:
        """The query as a prompt, e.g. 'a red can about 6 x 6 x 12 cm'."""
        cm = " x ".join(f"{100 * v:.0f}" for v in self.size)
        return f"a {self.colour} {self.shape.replace('_', ' ')} about {cm} cm"


@dataclass(frozen=True)
class ConfinedSpace:
    """The outer geometry of the confined space, as a robot would be told it.

    interior_min / interior_max [m]: the world axis-aligned box inside the outer walls
    (whatever shelves or partitions it holds are not described). opening_min / opening_max
    [m]: the world axis-aligned box of the open face (zero thickness along `outward`).
    outward: unit vector out of the space through the opening (towards the robot).
    wall_thickness [m] of the outer boards.
    """

    interior_min: tuple[float, float, float]
    interior_max: tuple[float, float, float]
    opening_min: tuple[float, float, float]
    opening_max: tuple[float, float, float]
    outward: tuple[float, float, float] = (-1.0, 0.0, 0.0)
    wall_thickness: float = 0.02

    @property
    def centre(self) -> np.ndarray:
        return (np.asarray(self.interior_min) + np.asarray(self.interior_max)) / 2

    @property
    def opening_centre(self) -> np.ndarray:
        return (np.asarray(self.opening_min) + np.asarray(self.opening_max)) / 2

    def contains(self, p: np.ndarray) -> np.ndarray:
        """Whether points (..., 3) [m] lie inside the interior box."""
        p = np.asarray(p, dtype=float)
        return np.all((p >= np.asarray(self.interior_min)) & (p <= np.asarray(self.interior_max)), axis=-1)


@dataclass(frozen=True)
class Task:
    """Everything a method is told before a trial starts.

    robot_base_pos [m] / robot_base_yaw [rad]: the arm's base in the world; floor_z [m];
    space: the confined space's outer geometry and opening; target: what to find;
    time_limit_s: the trial's limit in simulated (or wall) time [s].
    """

    robot_base_pos: tuple[float, float, float]
    robot_base_yaw: float
    floor_z: float
    space: ConfinedSpace
    target: TargetQuery
    time_limit_s: float = 200.0
