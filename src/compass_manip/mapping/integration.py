"""Scan integration kernels: one depth scan into the log-odds grid with OctoMap's rule.

Three steps per scan: `_prepare` (serial) marks the hit voxels and picks the rays whose
free space is traced; `_trace_*` walks those rays with the 3-D DDA of `raycast.ray_setup`
and marks the voxels they cross (in parallel when there is enough work, serially
otherwise: on a machine shared with other jobs a parallel region costs a scheduling round
for every thread); `_apply` updates each marked voxel once and clears the scratch grids.

Marks: a voxel hit in the scan is marked HIT and never re-marked FREE, so hits win and
every voxel is updated at most once per scan, as in OctoMap's `insertPointCloud`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .raycast import FREE, KIND_INVALID, KIND_POINT, OCCUPIED, ray_setup

_MARK_NONE = np.uint8(0)
_MARK_FREE = np.uint8(1)
_MARK_HIT = np.uint8(2)

#: Trace in parallel only from this many rays on.
PARALLEL_MIN_RAYS = 4096


def integrate_scan(
    logodds, state, mark, row_dirty, claim, origin, points, kind, max_range, k0, res,
    logs, grouping, n_workers,
):
    """Integrate one scan into the log-odds grid with OctoMap's update rule.

    logodds (nx, ny, nz) float32 and state (nx, ny, nz) uint8 are updated in place; mark,
    claim (same shape, uint8) and row_dirty (nx * ny,) uint8 are all-zero scratch grids
    and are all-zero again on return. origin (3,) [m]; points (N, 3) [m] and kind (N,) from
    `raycast.backproject`. A ray of kind KIND_POINT whose length is <= max_range [m] hits
    the voxel of its point and clears the voxels before it; longer rays and KIND_NO_RETURN
    rays clear up to max_range with no hit. logs = float32 log-odds (hit, miss, clamp_min,
    clamp_max, occupancy threshold).

    grouping = 0 traces every ray (exactly OctoMap's insertPointCloud). grouping = g in
    {1, 2} traces, among the rays whose end points fall in the same cell of edge res / g
    (for rays ending outside the grid: whose grid exit points fall in the same cell of
    edge res / 2), only the first one's free space; hits still come from every ray.
    Returns (voxels updated as free, voxels updated as occupied, rays traced).
    """
    cast, claimed, n_cast = _prepare(mark, row_dirty, claim, origin, points, kind, max_range, k0, res, grouping)
    if n_workers > 1 and n_cast >= PARALLEL_MIN_RAYS:
        _trace_parallel(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res, n_workers)
    else:
        _trace_serial(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res)
    n_free, n_hit = _apply(logodds, state, mark, row_dirty, claim, claimed, n_cast, *logs)
    return int(n_free), int(n_hit), int(n_cast)


@njit(cache=True, inline="always")
def _ray_end(origin, points, kind, i, max_range):
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
def _grid_cell_point(gx, gy, gz, ex, ey, ez, nx, ny, nz):
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


@njit(cache=True)
def _prepare(mark, row_dirty, claim, origin, points, kind, max_range, k0, res, grouping):
    """Mark hit voxels; return the rays to trace, the cell each claimed (-1: none), count."""
    nx, ny, nz = mark.shape
    mk = mark.reshape(-1)
    cl = claim.reshape(-1)
    inv_res = 1.0 / res
    n = points.shape[0]
    cast = np.empty(n, np.int64)
    claimed = np.empty(n, np.int64)
    n_cast = 0
    gx = origin[0] * inv_res - k0[0]
    gy = origin[1] * inv_res - k0[1]
    gz = origin[2] * inv_res - k0[2]
    for i in range(n):
        if kind[i] == KIND_INVALID:
            continue
        ex, ey, ez, hit = _ray_end(origin, points, kind, i, max_range)
        if hit:
            ix = int(math.floor(ex * inv_res)) - k0[0]
            iy = int(math.floor(ey * inv_res)) - k0[1]
            iz = int(math.floor(ez * inv_res)) - k0[2]
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                row = ix * ny + iy
                mk[row * nz + iz] = _MARK_HIT
                row_dirty[row] = 1
        lin = -1
        if grouping > 0:
            cx, cy, cz, ok, inside = _grid_cell_point(
                gx, gy, gz, ex * inv_res - k0[0], ey * inv_res - k0[1], ez * inv_res - k0[2], nx, ny, nz
            )
            if ok:
                g = grouping if inside else 2  # rays leaving the grid diverge more: finer cells
                fx = int(math.floor(cx * g))
                fy = int(math.floor(cy * g))
                fz = int(math.floor(cz * g))
                ix = fx // g
                iy = fy // g
                iz = fz // g
                bit = np.uint8(1) << np.uint8((fx - g * ix) + g * ((fy - g * iy) + g * (fz - g * iz)))
                lin = (ix * ny + iy) * nz + iz
                if cl[lin] & bit:
                    continue
                cl[lin] |= bit
        cast[n_cast] = i
        claimed[n_cast] = lin
        n_cast += 1
    return cast, claimed, n_cast


@njit(cache=True, inline="always")
def _trace_block(mark, row_dirty, origin, points, kind, cast, c0, c1, max_range, k0, res):
    """Mark FREE every unmarked voxel crossed by rays cast[c0:c1] before their end voxel."""
    nx, ny, nz = mark.shape
    mk = mark.reshape(-1)
    inv_res = 1.0 / res
    gx = origin[0] * inv_res - k0[0]
    gy = origin[1] * inv_res - k0[1]
    gz = origin[2] * inv_res - k0[2]
    sx_lin = ny * nz
    for c in range(c0, c1):
        ex, ey, ez, hit = _ray_end(origin, points, kind, cast[c], max_range)
        ok, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps = ray_setup(
            gx, gy, gz, ex * inv_res - k0[0], ey * inv_res - k0[1], ez * inv_res - k0[2],
            int(math.floor(ex * inv_res)) - k0[0], int(math.floor(ey * inv_res)) - k0[1],
            int(math.floor(ez * inv_res)) - k0[2], nx, ny, nz,
        )
        if not ok:
            continue
        row = ix * ny + iy
        lin = row * nz + iz
        for _ in range(n_steps):
            m = mk[lin]
            mk[lin] = m | np.uint8(m == _MARK_NONE)  # branch-free: NONE -> FREE, others stay
            row_dirty[row] = 1
            if tmx < tmy:
                if tmx < tmz:
                    ix += sx
                    if ix < 0 or ix >= nx:
                        break
                    lin += sx * sx_lin
                    row += sx * ny
                    tmx += tdx
                else:
                    iz += sz
                    if iz < 0 or iz >= nz:
                        break
                    lin += sz
                    tmz += tdz
            else:
                if tmy < tmz:
                    iy += sy
                    if iy < 0 or iy >= ny:
                        break
                    lin += sy * nz
                    row += sy
                    tmy += tdy
                else:
                    iz += sz
                    if iz < 0 or iz >= nz:
                        break
                    lin += sz
                    tmz += tdz


@njit(cache=True)
def _trace_serial(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res):
    _trace_block(mark, row_dirty, origin, points, kind, cast, 0, n_cast, max_range, k0, res)


@njit(cache=True, parallel=True)
def _trace_parallel(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res, n_workers):
    # interleaved blocks of rays so the workers share near and far parts of the image; the
    # only shared writes are idempotent (NONE -> FREE, dirty flags -> 1)
    block = 256
    n_blocks = (n_cast + block - 1) // block
    for w in prange(n_workers):
        for b in range(w, n_blocks, n_workers):
            _trace_block(mark, row_dirty, origin, points, kind, cast, b * block,
                         min(n_cast, (b + 1) * block), max_range, k0, res)


@njit(cache=True)
def _apply(logodds, state, mark, row_dirty, claim, claimed, n_cast,
           hit_log, miss_log, clamp_min_log, clamp_max_log, occ_log):
    """Update each marked voxel once (float32 log-odds, clamped) and clear the scratch."""
    nx, ny, nz = logodds.shape
    lo_flat = logodds.reshape(-1)
    st_flat = state.reshape(-1)
    mk = mark.reshape(-1)
    cl = claim.reshape(-1)
    for c in range(n_cast):
        if claimed[c] >= 0:
            cl[claimed[c]] = 0
    n_free = 0
    n_hit = 0
    for row in range(nx * ny):
        if row_dirty[row] == 0:
            continue
        row_dirty[row] = 0
        base = row * nz
        for k in range(nz):
            m = mk[base + k]
            if m == _MARK_NONE:
                continue
            mk[base + k] = _MARK_NONE
            v = lo_flat[base + k]
            if m == _MARK_HIT:
                v = v + hit_log
                if v > clamp_max_log:
                    v = clamp_max_log
                n_hit += 1
            else:
                v = v + miss_log
                if v < clamp_min_log:
                    v = clamp_min_log
                n_free += 1
            lo_flat[base + k] = v
            st_flat[base + k] = OCCUPIED if v >= occ_log else FREE
    return n_free, n_hit
