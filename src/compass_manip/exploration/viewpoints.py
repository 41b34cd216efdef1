"""Camera viewpoints aimed at points, solved to joint configurations by camera IK.

Pure sampling: no validity here (the tree validates what it grows). Views look at a point
from `distance` [m] along a direction; the camera roll is drawn from the generator.
"""
from __future__ import annotations

import numpy as np

from ..robot.ik import PandaIK


def unit(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, float)
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else np.array([1.0, 0.0, 0.0])


def _cross(a, b) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def sample_direction_in_cone(axis: np.ndarray, half_angle: float, rng: np.random.Generator) -> np.ndarray:
    """A unit vector uniformly distributed in the cone of `half_angle` [rad] around axis."""
    a = unit(axis)
    z = rng.uniform(np.cos(half_angle), 1.0)
    phi = rng.uniform(0.0, 2 * np.pi)
    s = np.sqrt(max(0.0, 1 - z * z))
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = unit(_cross(a, helper))
    e2 = _cross(a, e1)
    return z * a + s * (np.cos(phi) * e1 + np.sin(phi) * e2)


def view_pose(point: np.ndarray, view_dir: np.ndarray, distance: float, roll: float) -> np.ndarray:
    """T_world_cam looking along unit view_dir at `point` [m] from `distance` [m], rolled by
    `roll` [rad] about the optical axis (OpenCV axes: +z forward, +x right, +y down; roll 0
    keeps +x horizontal as `geometry.look_at` does)."""
    z = unit(view_dir)
    x = _cross(z, np.array([0.0, 0.0, 1.0]))
    if np.linalg.norm(x) < 1e-6:
        x = _cross(z, np.array([1.0, 0.0, 0.0]))
    x = x / np.linalg.norm(x)
    y = _cross(z, x)
    c, s = np.cos(roll), np.sin(roll)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = c * x + s * y, -s * x + c * y, z
    T[:3, 3] = np.asarray(point, float) - distance * z
    return T


def view_configurations(ik: PandaIK, T_world_cam: np.ndarray, q_ref: np.ndarray, n_q7: int,
                        max_solutions: int) -> np.ndarray:
    """Up to max_solutions IK solutions (k, 7) [rad] of the camera pose, nearest q_ref first."""
    r = ik.solve(T_world_cam, "cam", q_ref, n_q7, retry=False)
    return r.solutions[:max_solutions]
