"""The reference fixed-view set: camera poses outside a confined space's opening that need no
knowledge of the target (pure geometry of the Task's `ConfinedSpace`; no simulator imports).

A 3 x 3 grid over the opening: eyes STANDOFF [m] outside the opening plane at 15 %, 50 % and
85 % of its width and 20 %, 50 % and 80 % of its height; every camera looks at the point on
the interior's mid-depth plane at the opening's centre line (y) and 5 cm below its own height,
so the side eyes look diagonally across the interior. Optical frames are OpenCV (+z forward),
with the image's "up" towards world +z. The set also holds every pose of the FV baseline
(`exploration.fixed_views.fixed_view_poses` with its default config), so a scene the baseline's
own views solve is never called hidden. Used to define the levels: a scene is FV-solvable
when one of these poses sees >= 30 % of the target (with nothing but the scene in the way).
"""
from __future__ import annotations

import numpy as np

from ..exploration.fixed_views import FixedViewsConfig, fixed_view_poses
from ..geometry import look_at
from ..task import ConfinedSpace, Task

STANDOFF = 0.15
Y_FRACTIONS = (0.15, 0.5, 0.85)
Z_FRACTIONS = (0.2, 0.5, 0.8)
LOOK_DOWN = 0.05


def reference_fixed_views(task: Task) -> list[np.ndarray]:
    """The optical-frame poses T_world_cam (4x4) of the reference fixed-view set: the 3 x 3
    grid, then the FV baseline's poses."""
    return grid_views(task.space) + list(fixed_view_poses(task, FixedViewsConfig()))


def grid_views(space: ConfinedSpace) -> list[np.ndarray]:
    """The 3 x 3 grid of eyes STANDOFF [m] outside the opening (see the module doc)."""
    o_lo, o_hi = np.asarray(space.opening_min, float), np.asarray(space.opening_max, float)
    out_dir = np.asarray(space.outward, float)
    out_dir = out_dir / np.linalg.norm(out_dir)
    centre = space.centre
    # in-plane axes of the opening: horizontal (perpendicular to outward) and vertical
    side = np.cross([0.0, 0.0, 1.0], out_dir)
    side = side / np.linalg.norm(side)
    views = []
    c_open = (o_lo + o_hi) / 2
    half_w = abs(float(np.dot(o_hi - o_lo, side))) / 2
    h_lo, h_hi = float(o_lo[2]), float(o_hi[2])
    for fz in Z_FRACTIONS:
        for fy in Y_FRACTIONS:
            z = h_lo + fz * (h_hi - h_lo)
            eye = c_open + (2 * fy - 1) * half_w * side + STANDOFF * out_dir
            eye[2] = z
            aim = c_open - float(np.dot(centre - c_open, -out_dir)) * out_dir  # mid-depth, centre line
            aim[2] = z - LOOK_DOWN
            views.append(look_at(eye, aim))
    return views
