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
def _cam_point(depth, u, v, fx, fy, cx, cy):
    d = depth[v, u]
    return (u - cx) / fx * d, (v - cy) / fy * d, d


@njit(cache=True)
def depth_cues(depth, fx, fy, cx, cy, R_world_cam, stride, max_jump, half_diag):
    """What the depth image says about the surface at each pixel `backproject` returns (same
    order and stride): (N, 6) columns n_x, n_y, n_z (unit normal in the world frame, sign
    arbitrary), spacing [m] of the neighbouring samples on the surface (the longer of the two
    tangents used), and the shadow interval [start, end) of ranges [m] along this pixel's ray
    where it frees nothing (start +inf: none).

    The normal comes from the measured points of the neighbouring sampled pixels: along u and
    along v the neighbour with the smaller depth step (a surface does not continue across a
    depth edge); NaN where the pixel or both neighbours on an axis are not finite depths, or
    where the smaller step exceeds max_jump [m] plus the step of a surface at 88 deg to the
    ray (30 pixel footprints). Shadows: a pixel with a neighbour farther by more than a depth
    jump (max_jump plus 10 pixel footprints, or a no-return) is an occluding edge at depth
    d_e; the object goes on, unseen, behind it. A farther pixel's ray frees nothing from
    depth d_e - half_diag [m] as long as it passes within half_diag of the edge's shadow
    (a voxel cube centred on it may reach into the shadow; `_shadow`)."""
    H, W = depth.shape
    off = stride // 2
    nu = (W - off + stride - 1) // stride
    nv = (H - off + stride - 1) // stride
    out = np.full((nu * nv, 6), np.nan)
    out[:, 4] = np.inf
    out[:, 5] = 0.0
    t = np.zeros((2, 3))  # the two tangents of the current pixel (set when its neighbour qualifies)
    for jv in range(nv):
        v = jv * stride + off
        for ju in range(nu):
            u = ju * stride + off
            d = depth[v, u]
            if not (d > 0.0 and d < np.inf):
                continue
            n = jv * nu + ju
            px, py, pz = _cam_point(depth, u, v, fx, fy, cx, cy)
            foot = d * stride / fx
            jump = max_jump + 10.0 * foot
            tol = max_jump + 30.0 * foot
            ok = True
            edge = False
            for a in range(2):
                best = np.inf
                for sgn in (-1, 1):
                    uu = u + sgn * stride * (1 - a)
                    vv = v + sgn * stride * a
                    if uu < 0 or uu >= W or vv < 0 or vv >= H:
                        continue
                    dd = depth[vv, uu]
                    if dd > d + jump:  # also +inf (no return)
                        edge = True
                    if not (dd > 0.0 and dd < np.inf) or abs(dd - d) >= best:
                        continue
                    best = abs(dd - d)
                    qx, qy, qz = _cam_point(depth, uu, vv, fx, fy, cx, cy)
                    t[a, 0] = (qx - px) * sgn
                    t[a, 1] = (qy - py) * sgn
                    t[a, 2] = (qz - pz) * sgn
                if best > tol:
                    ok = False
            if edge:
                _shadow(depth, out, u, v, d, jump, half_diag, fx, fy, cx, cy, stride, off, nu, nv)
            if not ok:
                continue
            n0 = t[0, 1] * t[1, 2] - t[0, 2] * t[1, 1]
            n1 = t[0, 2] * t[1, 0] - t[0, 0] * t[1, 2]
            n2 = t[0, 0] * t[1, 1] - t[0, 1] * t[1, 0]
            s = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            if s == 0.0:
                continue
            for a in range(3):
                out[n, a] = (R_world_cam[a, 0] * n0 + R_world_cam[a, 1] * n1 + R_world_cam[a, 2] * n2) / s
            out[n, 3] = math.sqrt(max(t[0, 0] ** 2 + t[0, 1] ** 2 + t[0, 2] ** 2, t[1, 0] ** 2 + t[1, 1] ** 2
                                      + t[1, 2] ** 2))
    return out


@njit(cache=True, inline="always")
def _shadow(depth, out, u, v, d, jump, half_diag, fx, fy, cx, cy, stride, off, nu, nv):
    """Limit the known free space of the rays beside the occluding edge pixel (u, v) at depth
    d: a ray k sampled pixels away passes k * stride * z / fx [m] beside the edge's shadow at
    depth z, so from depth d - half_diag until that distance reaches half_diag the voxels it
    crosses may reach into the shadow."""
    k = int(math.ceil(half_diag * fx / (d * stride)))  # pixels within half_diag of the edge at depth d
    z_stop = max(d - half_diag, 0.0)
    ju0, jv0 = (u - off) // stride, (v - off) // stride
    for jv in range(max(0, jv0 - k), min(nv, jv0 + k + 1)):
        vv = jv * stride + off
        for ju in range(max(0, ju0 - k), min(nu, ju0 + k + 1)):
            uu = ju * stride + off
            dd = depth[vv, uu]
            if not dd > d + jump:
                continue
            z_resume = half_diag * fx / (stride * math.sqrt((ju - ju0) ** 2 + (jv - jv0) ** 2))
            if z_resume <= z_stop:
                continue
            xc = (uu - cx) / fx
            yc = (vv - cy) / fy
            ray = math.sqrt(xc * xc + yc * yc + 1.0)  # range [m] per metre of z-depth
            m = jv * nu + ju
            out[m, 4] = min(out[m, 4], z_stop * ray)
            out[m, 5] = max(out[m, 5], z_resume * ray)
