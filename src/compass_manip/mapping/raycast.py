"""Numba ray kernels on a dense voxel grid: pixel back-projection and the 3-D DDA set-up.

Grid convention (shared by every kernel in `mapping`): voxel `(i, j, k)` with integer key
`key = floor(x / res)` along each axis covers `[key * res, (key + 1) * res)` [m], exactly
OctoMap's key layout, and index `i = key - k0` where `k0` is the grid's lowest key. Arrays
have shape `(nx, ny, nz)` in C order, so the linear index is `(i * ny + j) * nz + k`.

Ray traversal is Amanatides & Woo's 3-D DDA ("A Fast Voxel Traversal Algorithm", 1987)
with OctoMap's conventions: a ray from `origin` to `end` visits the voxel of `origin` and
every voxel it crosses before the voxel of `end`, which is *not* visited (it is the hit
voxel of a measured point). The walk takes exactly as many steps as the Manhattan distance
between the two voxels. A ray whose origin lies outside the grid starts where it enters
the grid; voxels outside the grid are never touched.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Voxel states stored in the uint8 state grid (see `occupancy.VoxelState`).
UNKNOWN = np.uint8(0)
FREE = np.uint8(1)
OCCUPIED = np.uint8(2)

#: Kinds of back-projected pixels.
KIND_INVALID = np.uint8(0)  # NaN, <= 0 or dropped by a filter: no update at all
KIND_POINT = np.uint8(1)  # finite depth: a hit if within range, a cleared ray otherwise
KIND_NO_RETURN = np.uint8(2)  # +inf depth: clear free space up to the range, no hit

_BIG = 1.0e30


@njit(cache=True, inline="always")
def ray_setup(gx, gy, gz, ex, ey, ez, kex, key, kez, nx, ny, nz):
    """Start state of a DDA along the segment from g to e, both in grid units
    (x / res - k0, so voxel (i, j, k) spans [i, i + 1) x [j, j + 1) x [k, k + 1)).

    kex, key, kez: index of the end voxel (computed by the caller as floor(x / res) - k0,
    OctoMap's key). If g lies outside the grid the ray starts where it enters the grid.
    Returns (ok, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps): the first
    voxel, step signs, segment parameters in [0, 1] at which the ray leaves the current
    voxel along each axis and their per-voxel increments, and the number of DDA steps from
    the first voxel to the end voxel. Visiting the first voxel and the next n_steps - 1
    voxels visits every voxel before the end voxel. ok is False if the segment misses the
    grid or starts in its end voxel.
    """
    dx = ex - gx
    dy = ey - gy
    dz = ez - gz
    fx = math.floor(gx)
    fy = math.floor(gy)
    fz = math.floor(gz)
    if 0.0 <= fx < nx and 0.0 <= fy < ny and 0.0 <= fz < nz:
        ix = int(fx)
        iy = int(fy)
        iz = int(fz)
    else:  # slab clipping against the grid box [0, n] in grid units
        t_in = 0.0
        t_out = 1.0
        if dx != 0.0:
            a = -gx / dx
            b = (nx - gx) / dx
            t_in = max(t_in, min(a, b))
            t_out = min(t_out, max(a, b))
        elif gx < 0.0 or gx >= nx:
            t_out = -1.0
        if dy != 0.0:
            a = -gy / dy
            b = (ny - gy) / dy
            t_in = max(t_in, min(a, b))
            t_out = min(t_out, max(a, b))
        elif gy < 0.0 or gy >= ny:
            t_out = -1.0
        if dz != 0.0:
            a = -gz / dz
            b = (nz - gz) / dz
            t_in = max(t_in, min(a, b))
            t_out = min(t_out, max(a, b))
        elif gz < 0.0 or gz >= nz:
            t_out = -1.0
        if t_in >= t_out:
            return False, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0
        ix = min(max(int(math.floor(gx + dx * t_in)), 0), nx - 1)
        iy = min(max(int(math.floor(gy + dy * t_in)), 0), ny - 1)
        iz = min(max(int(math.floor(gz + dz * t_in)), 0), nz - 1)
    n_steps = abs(kex - ix) + abs(key - iy) + abs(kez - iz)
    if n_steps == 0:
        return False, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0
    sx = 0
    sy = 0
    sz = 0
    tmx = _BIG
    tmy = _BIG
    tmz = _BIG
    tdx = _BIG
    tdy = _BIG
    tdz = _BIG
    if dx > 0.0:
        sx = 1
        tdx = 1.0 / dx
        tmx = (ix + 1.0 - gx) * tdx
    elif dx < 0.0:
        sx = -1
        tdx = -1.0 / dx
        tmx = (gx - ix) * tdx
    if dy > 0.0:
        sy = 1
        tdy = 1.0 / dy
        tmy = (iy + 1.0 - gy) * tdy
    elif dy < 0.0:
        sy = -1
        tdy = -1.0 / dy
        tmy = (gy - iy) * tdy
    if dz > 0.0:
        sz = 1
        tdz = 1.0 / dz
        tmz = (iz + 1.0 - gz) * tdz
    elif dz < 0.0:
        sz = -1
        tdz = -1.0 / dz
        tmz = (gz - iz) * tdz
    return True, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps


@njit(cache=True)
def backproject(depth, fx, fy, cx, cy, R_world_cam, t_world_cam, stride):
    """World points of the pixels of a depth image (z-depth [m], OpenCV camera frame).

    Pixel (u, v) is the ray through image point (u, v) (OpenCV: pixel centres at integer
    coordinates, principal point (cx, cy)); with `stride` s only the pixel at
    offset s // 2 of every s x s block is used. Returns `points` (N, 3) [m] and `kind`
    (N,) uint8: KIND_POINT for a finite depth > 0 (the measured point), KIND_NO_RETURN for
    +inf (the point 1 m along the unit ray, only its direction matters), KIND_INVALID for
    NaN, 0, negative or -inf depth.
    """
    H, W = depth.shape
    off = stride // 2
    nu = (W - off + stride - 1) // stride
    nv = (H - off + stride - 1) // stride
    points = np.empty((nu * nv, 3))
    kind = np.empty(nu * nv, np.uint8)
    for jv in range(nv):
        v = jv * stride + off
        yc = (v - cy) / fy
        for ju in range(nu):
            u = ju * stride + off
            n = jv * nu + ju
            d = depth[v, u]
            xc = (u - cx) / fx
            if math.isnan(d) or d <= 0.0:
                kind[n] = KIND_INVALID
                points[n, 0] = t_world_cam[0]
                points[n, 1] = t_world_cam[1]
                points[n, 2] = t_world_cam[2]
                continue
            if math.isinf(d):
                kind[n] = KIND_NO_RETURN
                s = 1.0 / math.sqrt(xc * xc + yc * yc + 1.0)
            else:
                kind[n] = KIND_POINT
                s = d
            for a in range(3):
                points[n, a] = t_world_cam[a] + s * (
                    R_world_cam[a, 0] * xc + R_world_cam[a, 1] * yc + R_world_cam[a, 2]
                )
    return points, kind


@njit(cache=True, inline="always")
def ray_end(origin, points, kind, i, max_range):
    """End point [m] of ray i and whether it is a hit (OctoMap's maxrange rule)."""
    px = points[i, 0]
    py = points[i, 1]
    pz = points[i, 2]
    dx = px - origin[0]
    dy = py - origin[1]
    dz = pz - origin[2]
    L2 = dx * dx + dy * dy + dz * dz
    if kind[i] == KIND_POINT and L2 <= max_range * max_range:
        return px, py, pz, True
    if L2 == 0.0:
        return px, py, pz, False
    s = max_range / math.sqrt(L2)
    return origin[0] + dx * s, origin[1] + dy * s, origin[2] + dz * s, False


@njit(cache=True, inline="always")
def grid_cell_point(gx, gy, gz, ex, ey, ez, nx, ny, nz):
    """The end point e of the segment g -> e (grid units) if it lies in the grid, else the
    point where the segment leaves the grid (clamped inside); (x, y, z, ok, inside). ok is
    False if the segment misses the grid, inside is True for the end point itself."""
    if 0.0 <= ex < nx and 0.0 <= ey < ny and 0.0 <= ez < nz:
        return ex, ey, ez, True, True
    dx = ex - gx
    dy = ey - gy
    dz = ez - gz
    t_in = 0.0
    t_out = 1.0
    for g, d, n in ((gx, dx, nx), (gy, dy, ny), (gz, dz, nz)):
        if d != 0.0:
            a = -g / d
            b = (n - g) / d
            t_in = max(t_in, min(a, b))
            t_out = min(t_out, max(a, b))
        elif g < 0.0 or g >= n:
            t_out = -1.0
    if t_in >= t_out:
        return 0.0, 0.0, 0.0, False, False
    t = t_out * (1.0 - 1e-9)
    top = 1.0 - 1e-9
    return (min(max(gx + dx * t, 0.0), nx - top), min(max(gy + dy * t, 0.0), ny - top),
            min(max(gz + dz * t, 0.0), nz - top), True, False)
