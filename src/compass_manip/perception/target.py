"""Geometry of image regions: back-projection to world points, surface normals, extents.

Pure functions on arrays. Images are (H, W); depth is z-depth [m] (0 or inf = no
measurement); K is the 3x3 pinhole matrix [px]; T_world_cam the OpenCV optical frame.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np


@lru_cache(maxsize=4)
def _pixel_grid(H: int, W: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel column and row coordinates (H, W) float64 (read-only, shared between calls)."""
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    u.flags.writeable = False
    v.flags.writeable = False
    return u, v


def backproject_image(depth: np.ndarray, K: np.ndarray, T_world_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World points (H, W, 3) [m] of every pixel (NaN where depth is missing) and the
    validity mask (H, W)."""
    H, W = depth.shape
    z = np.asarray(depth, dtype=np.float64)
    valid = np.isfinite(z) & (z > 0)
    u, v = _pixel_grid(H, W)
    zz = np.where(valid, z, np.nan)
    pc = np.stack([(u - K[0, 2]) / K[0, 0] * zz, (v - K[1, 2]) / K[1, 1] * zz, zz], axis=-1)
    pw = pc @ T_world_cam[:3, :3].T
    for i in range(3):  # = pw + T_world_cam[:3, 3]: a length-3 broadcast over (H, W, 3) is 6x slower
        pw[..., i] += T_world_cam[i, 3]
    return pw, valid


def surface_normals(points: np.ndarray, step: int = 2, max_jump: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (H, W, 3) from an organised point image (H, W, 3) [m] by the cross
    product of central differences `step` px apart, and a mask (H, W) of pixels whose
    neighbours lie within `max_jump` [m] (no depth discontinuity, no missing depth).
    Normals are oriented towards the camera is not guaranteed; callers use |n| terms."""
    H, W, _ = points.shape
    n = np.full_like(points, np.nan)
    ok = np.zeros((H, W), bool)
    s = int(step)
    if H <= 2 * s or W <= 2 * s:
        return n, ok
    c = points[s:-s, s:-s]
    du = points[s:-s, 2 * s:] - points[s:-s, :-2 * s]
    dv = points[2 * s:, s:-s] - points[:-2 * s, s:-s]
    cr = np.cross(du, dv)
    norm = _norm3(cr)
    with np.errstate(invalid="ignore"):
        jump = np.maximum(_norm3(du), _norm3(dv))
        good = (np.isfinite(norm) & (norm > 1e-12) & (jump < 2 * max_jump) & np.isfinite(c[..., 0])
                & np.isfinite(c[..., 1]) & np.isfinite(c[..., 2]))
    inner = n[s:-s, s:-s]
    normal = norm[good]
    for i in range(3):  # = cr[good] / norm[good, None], one component at a time
        inner[..., i][good] = cr[..., i][good] / normal
    ok[s:-s, s:-s] = good
    return n, ok


def _norm3(x: np.ndarray) -> np.ndarray:
    """`np.linalg.norm(x, axis=-1)` of (..., 3) vectors, the same numbers (numpy sums the
    three squares in order), without its slow reduction over a length-3 axis."""
    s = x * x
    return np.sqrt((s[..., 0] + s[..., 1]) + s[..., 2])


def region_normals(points: np.ndarray, sl: tuple[slice, slice], step: int = 2,
                   max_jump: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """`surface_normals(points)[0][sl]` and `[1][sl]` without the whole image: the normals
    are computed on the window `sl` grown by `step` px (clipped to the image), which holds
    every neighbour a pixel of `sl` needs, so the values are the same."""
    H, W, _ = points.shape
    s = int(step)
    r0, r1 = max(0, sl[0].start - s), min(H, sl[0].stop + s)
    c0, c1 = max(0, sl[1].start - s), min(W, sl[1].stop + s)
    n, ok = surface_normals(points[r0:r1, c0:c1], step, max_jump)
    inner = (slice(sl[0].start - r0, sl[0].stop - r0), slice(sl[1].start - c0, sl[1].stop - c0))
    return n[inner], ok[inner]


def upright_extents(points_world: np.ndarray) -> tuple[float, float, float]:
    """Extents [m] of world points (N, 3) in an upright frame: (major horizontal, minor
    horizontal, vertical), the horizontal axes from the principal axes of their x-y spread.
    Robust to a few outliers: 2nd-98th percentile ranges."""
    p = np.asarray(points_world, dtype=np.float64)
    if len(p) < 3:
        return 0.0, 0.0, 0.0
    xy = p[:, :2] - p[:, :2].mean(0)
    cov = xy.T @ xy / len(p)
    _, vec = np.linalg.eigh(cov)
    proj = xy @ vec[:, ::-1]
    lo, hi = np.percentile(proj, [2, 98], axis=0)
    zlo, zhi = np.percentile(p[:, 2], [2, 98])
    return float(hi[0] - lo[0]), float(hi[1] - lo[1]), float(zhi - zlo)
