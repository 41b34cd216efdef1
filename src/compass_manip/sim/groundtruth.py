"""Ground-truth occupancy of a scene's geometry on a voxel grid (for benchmarks and tests).

Planning never sees this: it is the reference the map built from depth is compared with,
and the "map from ground truth" of the motion benchmark.
"""
from __future__ import annotations

import numpy as np

from .scenes import Primitive, SceneSpec


def voxel_centres(origin: np.ndarray, shape: tuple[int, int, int], resolution: float) -> np.ndarray:
    """(X, Y, Z, 3) world coordinates [m] of voxel centres; voxel (0,0,0) spans origin..origin+res."""
    axes = [origin[i] + (np.arange(shape[i]) + 0.5) * resolution for i in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def inside_primitive(p: Primitive, pts: np.ndarray, pad: float = 0.0) -> np.ndarray:
    """Bool mask of points (..., 3) [m] inside primitive p grown by `pad` [m]."""
    d = pts - np.asarray(p.pos)
    c, s = np.cos(p.yaw), np.sin(p.yaw)
    local = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]], axis=-1)
    if p.shape == "box":
        return np.all(np.abs(local) <= np.asarray(p.size) + pad, axis=-1)
    if p.shape == "cylinder":
        r, hh = p.size
        return (local[..., 0] ** 2 + local[..., 1] ** 2 <= (r + pad) ** 2) & (np.abs(local[..., 2]) <= hh + pad)
    return np.sum(local**2, axis=-1) <= (p.size[0] + pad) ** 2


def occupancy_grid(scene: SceneSpec, origin, shape, resolution: float, floor: bool = True,
                   pad: float = 0.0) -> np.ndarray:
    """Bool grid (X, Y, Z): voxel centre inside any scene primitive (or below the floor)."""
    origin = np.asarray(origin, dtype=float)
    pts = voxel_centres(origin, tuple(shape), resolution)
    occ = np.zeros(tuple(shape), dtype=bool)
    for p in scene.all_primitives():
        lo, hi = p.aabb()
        i0 = np.clip(np.floor((lo - pad - origin) / resolution).astype(int), 0, shape)
        i1 = np.clip(np.ceil((hi + pad - origin) / resolution).astype(int) + 1, 0, shape)
        if np.any(i1 <= i0):
            continue
        sl = tuple(slice(a, b) for a, b in zip(i0, i1))
        occ[sl] |= inside_primitive(p, pts[sl], pad)
    if floor:
        occ |= pts[..., 2] <= scene.floor_z + pad
    return occ
