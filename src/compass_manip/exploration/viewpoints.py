"""Camera viewpoints aimed at points, solved to joint configurations by camera IK.

Pure sampling: no validity here (the tree validates what it grows). Views look at a point
from `distance` [m] along a direction; the camera roll is drawn from the generator.
"""
from __future__ import annotations

import numpy as np

from ..geometry import look_at, make_T, rot_z
from ..robot.ik import PandaIK


def unit(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, float)
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else np.array([1.0, 0.0, 0.0])


def sample_direction_in_cone(axis: np.ndarray, half_angle: float, rng: np.random.Generator) -> np.ndarray:
    """A unit vector uniformly distributed in the cone of `half_angle` [rad] around axis."""
    a = unit(axis)
    z = rng.uniform(np.cos(half_angle), 1.0)
    phi = rng.uniform(0.0, 2 * np.pi)
    s = np.sqrt(max(0.0, 1 - z * z))
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = unit(np.cross(a, helper))
    e2 = np.cross(a, e1)
    return z * a + s * (np.cos(phi) * e1 + np.sin(phi) * e2)


def view_pose(point: np.ndarray, view_dir: np.ndarray, distance: float, roll: float) -> np.ndarray:
    """T_world_cam looking along unit view_dir at `point` [m] from `distance` [m], rolled by
    `roll` [rad] about the optical axis."""
    eye = np.asarray(point, float) - distance * unit(view_dir)
    return look_at(eye, point) @ make_T(rot_z(roll))


def view_configurations(ik: PandaIK, T_world_cam: np.ndarray, q_ref: np.ndarray, n_q7: int,
                        max_solutions: int) -> np.ndarray:
    """Up to max_solutions IK solutions (k, 7) [rad] of the camera pose, nearest q_ref first."""
    r = ik.solve(T_world_cam, "cam", q_ref, n_q7, retry=False)
    return r.solutions[:max_solutions]
