"""Scan integration kernels: one depth scan into the log-odds grid with OctoMap's rule.

Three steps per scan: `_prepare` (serial) marks the hit voxels and picks the rays whose
free space is traced; `_trace_*` walks those rays with the 3-D DDA of `raycast.ray_setup`
and marks the voxels they cross (in parallel when there is enough work, serially
otherwise: on a machine shared with other jobs a parallel region costs a scheduling round
for every thread); `_apply` updates each marked voxel once and clears the scratch grids.

Marks: a voxel hit in the scan is marked HIT (HIT_PATCHED once the surface guard's patch
around it is marked) and never re-marked FREE, so hits win and every voxel is updated at
most once per scan, as in OctoMap's `insertPointCloud`.

Two departures from OctoMap's rule (both optional, `MapConfig`) keep voxels a surface fills
in part from being freed by rays through their empty part: the surface guard (no voxel
meeting a hit's tangent plane is freed, along that ray or around its hit voxel; rays beside
an occluding edge free nothing in its shadow; `depth_cues`) and sticky hits (a voxel hit in
`sticky` scans stays occupied, misses no longer lower it).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .depth_cues import GUARD_RADIUS_MAX, guard_patch
from .depth_cues import MARK_GUARD as _MARK_GUARD
from .depth_cues import MARK_NONE as _MARK_NONE
from .raycast import FREE, KIND_INVALID, OCCUPIED, grid_cell_point, ray_end, ray_setup

_MARK_FREE = np.uint8(1)
_MARK_HIT = np.uint8(2)
_MARK_HIT_PATCHED = np.uint8(4)  # hit, and the surface guard's patch around it is marked

#: Trace in parallel only from this many rays on.
PARALLEL_MIN_RAYS = 4096


def integrate_scan(
    logodds, state, mark, row_dirty, claim, origin, points, kind, max_range, k0, res,
    logs, grouping, n_workers, normals, hits, sticky,
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
    normals (N, 6): per ray `depth_cues.depth_cues` (the unit surface normal at its end point
    or NaN, the spacing [m] of the samples there, the interval of ranges [m] where it frees
    nothing), or an empty (0, 6) array: no surface guard. hits (nx, ny, nz) uint8: the
    number of scans that hit each voxel (saturating), updated in place; sticky >= 1: a voxel
    hit in that many scans is occupied for good (0: OctoMap's rule).
    Returns (voxels updated as free, voxels updated as occupied, rays traced).
    """
    cast, claimed, n_cast = _prepare(mark, row_dirty, claim, origin, points, kind, max_range, k0, res, grouping,
                                     normals)
    if n_workers > 1 and n_cast >= PARALLEL_MIN_RAYS:
        _trace_parallel(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res, normals, n_workers)
    else:
        _trace_serial(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res, normals)
    n_free, n_hit = _apply(logodds, state, mark, row_dirty, claim, claimed, n_cast, hits, sticky, *logs)
    return int(n_free), int(n_hit), int(n_cast)


@njit(cache=True)
def _prepare(mark, row_dirty, claim, origin, points, kind, max_range, k0, res, grouping, normals):
    """Mark hit voxels (and the surface guard's patches); return the rays to trace, the cell
    each claimed (-1: none), count."""
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
        ex, ey, ez, hit = ray_end(origin, points, kind, i, max_range)
        if hit:
            ix = int(math.floor(ex * inv_res)) - k0[0]
            iy = int(math.floor(ey * inv_res)) - k0[1]
            iz = int(math.floor(ez * inv_res)) - k0[2]
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                row = ix * ny + iy
                lin_hit = row * nz + iz
                row_dirty[row] = 1
                if mk[lin_hit] == _MARK_HIT_PATCHED:  # one patch per hit voxel and scan
                    pass
                elif normals.shape[0] == 0 or math.isnan(normals[i, 0]):
                    mk[lin_hit] = _MARK_HIT
                else:
                    mk[lin_hit] = _MARK_HIT_PATCHED
                    R = min(GUARD_RADIUS_MAX, 2 + int(0.75 * normals[i, 3] * inv_res))
                    guard_patch(mk, row_dirty, ix, iy, iz, ex * inv_res - k0[0], ey * inv_res - k0[1],
                                 ez * inv_res - k0[2], normals[i, 0], normals[i, 1], normals[i, 2], R, nx, ny, nz)
        lin = -1
        if grouping > 0:
            cx, cy, cz, ok, inside = grid_cell_point(
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
def _trace_block(mark, row_dirty, origin, points, kind, cast, c0, c1, max_range, k0, res, normals):
    """Mark FREE every unmarked voxel crossed by rays cast[c0:c1] before their end voxel,
    except (surface guard, when normals has a row per ray) the voxels whose cube meets the
    plane through a hit end point with that ray's normal."""
    nx, ny, nz = mark.shape
    mk = mark.reshape(-1)
    inv_res = 1.0 / res
    gx = origin[0] * inv_res - k0[0]
    gy = origin[1] * inv_res - k0[1]
    gz = origin[2] * inv_res - k0[2]
    sx_lin = ny * nz
    for c in range(c0, c1):
        ex, ey, ez, hit = ray_end(origin, points, kind, cast[c], max_range)
        ok, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps = ray_setup(
            gx, gy, gz, ex * inv_res - k0[0], ey * inv_res - k0[1], ez * inv_res - k0[2],
            int(math.floor(ex * inv_res)) - k0[0], int(math.floor(ey * inv_res)) - k0[1],
            int(math.floor(ez * inv_res)) - k0[2], nx, ny, nz,
        )
        if not ok:
            continue
        # the surface guard's plane n . (c - p) = 0 in grid units; a cube of edge 1 centred at c
        # meets it when |n . (c - p)| <= (|n0| + |n1| + |n2|) / 2
        guard = hit and normals.shape[0] > 0 and not math.isnan(normals[cast[c], 0])
        n0 = n1 = n2 = ext = 0.0
        p0 = p1 = p2 = 0.0
        if guard:
            n0, n1, n2 = normals[cast[c], 0], normals[cast[c], 1], normals[cast[c], 2]
            ext = 0.5 * (abs(n0) + abs(n1) + abs(n2))
            p0 = ex * inv_res - k0[0] - 0.5
            p1 = ey * inv_res - k0[1] - 0.5
            p2 = ez * inv_res - k0[2] - 0.5
        # segment parameters [t_stop, t_resume) where the ray frees nothing (an edge's shadow)
        t_stop, t_resume, t_in = 2.0, 2.0, 0.0
        if normals.shape[0] > 0 and normals[cast[c], 4] < 1e30:
            L = max(math.sqrt((ex - origin[0]) ** 2 + (ey - origin[1]) ** 2 + (ez - origin[2]) ** 2), 1e-12)
            t_stop, t_resume = normals[cast[c], 4] / L, normals[cast[c], 5] / L
        row = ix * ny + iy
        lin = row * nz + iz
        for _ in range(n_steps):
            t_out = min(tmx, min(tmy, tmz))  # where the ray leaves this voxel
            shadow = t_out > t_stop and t_in < t_resume
            t_in = t_out
            if shadow:
                pass
            elif not guard or abs(n0 * (ix - p0) + n1 * (iy - p1) + n2 * (iz - p2)) > ext:
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
def _trace_serial(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res, normals):
    _trace_block(mark, row_dirty, origin, points, kind, cast, 0, n_cast, max_range, k0, res, normals)


@njit(cache=True, parallel=True)
def _trace_parallel(mark, row_dirty, origin, points, kind, cast, n_cast, max_range, k0, res, normals, n_workers):
    # interleaved blocks of rays so the workers share near and far parts of the image; the
    # only shared writes are idempotent (NONE -> FREE, dirty flags -> 1)
    block = 256
    n_blocks = (n_cast + block - 1) // block
    for w in prange(n_workers):
        for b in range(w, n_blocks, n_workers):
            _trace_block(mark, row_dirty, origin, points, kind, cast, b * block,
                         min(n_cast, (b + 1) * block), max_range, k0, res, normals)


@njit(cache=True)
def _apply(logodds, state, mark, row_dirty, claim, claimed, n_cast, hits, sticky,
           hit_log, miss_log, clamp_min_log, clamp_max_log, occ_log):
    """Update each marked voxel once (float32 log-odds, clamped) and clear the scratch; count
    the hits per voxel, and keep a voxel hit in `sticky` (>= 1) scans occupied."""
    nx, ny, nz = logodds.shape
    lo_flat = logodds.reshape(-1)
    st_flat = state.reshape(-1)
    mk = mark.reshape(-1)
    cl = claim.reshape(-1)
    hf = hits.reshape(-1)
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
            if m == _MARK_GUARD:
                continue
            v = lo_flat[base + k]
            h = hf[base + k]
            if m == _MARK_HIT or m == _MARK_HIT_PATCHED:
                v = v + hit_log
                if v > clamp_max_log:
                    v = clamp_max_log
                if h < 255:
                    h += 1
                    hf[base + k] = h
                if sticky > 0 and h >= sticky and v < occ_log:
                    v = occ_log
                n_hit += 1
            elif sticky > 0 and h >= sticky:
                continue
            else:
                v = v + miss_log
                if v < clamp_min_log:
                    v = clamp_min_log
                n_free += 1
            lo_flat[base + k] = v
            st_flat[base + k] = OCCUPIED if v >= occ_log else FREE
    return n_free, n_hit
