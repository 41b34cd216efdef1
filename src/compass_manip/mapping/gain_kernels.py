"""Numba kernels of `infogain`: distinct unknown voxels crossed by the rays of many views.

Two variants with identical results:
- stamp kernels (small batches): read the map's state grid and a per-worker uint8 stamp
  grid that persists between calls (cleared every 255 views);
- view-grid kernels (large batches): each worker first copies the state into its own
  padded uint8 grid (255 = occupied or outside the grid, 254 = free, 0..253 = unknown with
  the stamp of the last view that counted it). One load and one store per DDA step, no
  bounds checks (the padding stops every ray), so about 1.4x faster per step; the copy
  costs about one view's worth of time per worker and call.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .raycast import FREE, OCCUPIED, UNKNOWN, ray_setup

_WALL = np.uint8(255)
_FREE_MARK = np.uint8(254)
_MAX_STAMP = 253


@njit(cache=True, inline="always")
def _view_ray(R_world_cams, m, dirs_cam, r, ox, oy, oz, gx, gy, gz, max_range, inv_res, k0, nx, ny, nz):
    """DDA set-up (see `raycast.ray_setup`) of ray r of view m: from the camera origin
    (ox, oy, oz) [m] (grid coordinates gx, gy, gz) to max_range [m] along the ray."""
    ex = ox + max_range * (R_world_cams[m, 0, 0] * dirs_cam[r, 0] + R_world_cams[m, 0, 1] * dirs_cam[r, 1] + R_world_cams[m, 0, 2] * dirs_cam[r, 2])
    ey = oy + max_range * (R_world_cams[m, 1, 0] * dirs_cam[r, 0] + R_world_cams[m, 1, 1] * dirs_cam[r, 1] + R_world_cams[m, 1, 2] * dirs_cam[r, 2])
    ez = oz + max_range * (R_world_cams[m, 2, 0] * dirs_cam[r, 0] + R_world_cams[m, 2, 1] * dirs_cam[r, 1] + R_world_cams[m, 2, 2] * dirs_cam[r, 2])
    return ray_setup(
        gx, gy, gz, ex * inv_res - k0[0], ey * inv_res - k0[1], ez * inv_res - k0[2],
        int(math.floor(ex * inv_res)) - k0[0], int(math.floor(ey * inv_res)) - k0[1],
        int(math.floor(ez * inv_res)) - k0[2], nx, ny, nz,
    )


@njit(cache=True, inline="always")
def _views(gains, w, n_workers, state, stamps, last, origins, R_world_cams, dirs_cam, max_range, k0, res, skip):
    """Gains of views w, w + n_workers, ... with worker w's stamp grid (rays r of view m with
    skip[m, r] not cast)."""
    nx, ny, nz = state.shape
    st = state.reshape(-1)
    inv_res = 1.0 / res
    n_views = origins.shape[0]
    n_rays = dirs_cam.shape[0]
    sx_lin = ny * nz
    stamp = stamps[w]
    for m in range(w, n_views, n_workers):
        nxt = last[w] + 1
        if nxt > 255:
            stamp[:] = 0
            nxt = 1
        last[w] = nxt
        cur = np.uint8(nxt)
        ox = origins[m, 0]
        oy = origins[m, 1]
        oz = origins[m, 2]
        gx = ox * inv_res - k0[0]
        gy = oy * inv_res - k0[1]
        gz = oz * inv_res - k0[2]
        count = 0
        for r in range(n_rays):
            if skip[m, r]:
                continue
            ok, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps = _view_ray(
                R_world_cams, m, dirs_cam, r, ox, oy, oz, gx, gy, gz, max_range, inv_res, k0, nx, ny, nz
            )
            if not ok:
                continue
            lin = (ix * ny + iy) * nz + iz
            for _ in range(n_steps):
                s = st[lin]
                if s == OCCUPIED:
                    break
                # branch-free: whether a voxel is new is unpredictable; stamping free
                # voxels too is harmless (only unknown ones are counted)
                count += np.int64((s == UNKNOWN) & (stamp[lin] != cur))
                stamp[lin] = cur
                if tmx < tmy:
                    if tmx < tmz:
                        ix += sx
                        if ix < 0 or ix >= nx:
                            break
                        lin += sx * sx_lin
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
                        tmy += tdy
                    else:
                        iz += sz
                        if iz < 0 or iz >= nz:
                            break
                        lin += sz
                        tmz += tdz
        gains[m] = count


@njit(cache=True)
def info_gain_serial(state, stamps, last, origins, R_world_cams, dirs_cam, max_range, k0, res, skip):
    gains = np.zeros(origins.shape[0], np.int64)
    _views(gains, 0, 1, state, stamps, last, origins, R_world_cams, dirs_cam, max_range, k0, res, skip)
    return gains


@njit(cache=True, parallel=True)
def info_gain_parallel(state, stamps, last, origins, R_world_cams, dirs_cam, max_range, k0, res, skip):
    gains = np.zeros(origins.shape[0], np.int64)
    n_workers = stamps.shape[0]
    for w in prange(n_workers):
        _views(gains, w, n_workers, state, stamps, last, origins, R_world_cams, dirs_cam, max_range, k0, res, skip)
    return gains


@njit(cache=True, parallel=True)
def fill_view_grids(state, grids):
    """grids (W, nx + 2, ny + 2, nz + 2) uint8 <- padded copies of state (see module doc)."""
    nx, ny, nz = state.shape
    n_workers = grids.shape[0]
    for i in prange(nx + 2):
        for w in range(n_workers):
            for j in range(ny + 2):
                for k in range(nz + 2):
                    if i == 0 or j == 0 or k == 0 or i == nx + 1 or j == ny + 1 or k == nz + 1:
                        grids[w, i, j, k] = _WALL
                    else:
                        s = state[i - 1, j - 1, k - 1]
                        grids[w, i, j, k] = _WALL if s == OCCUPIED else (_FREE_MARK if s == FREE else 0)


@njit(cache=True, inline="always")
def _views_padded(gains, w, n_workers, grids, shape, origins, R_world_cams, dirs_cam, max_range, k0, res, skip):
    """Gains of views w, w + n_workers, ... on worker w's padded view grid (rays r of view m
    with skip[m, r] not cast)."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    g = grids[w].reshape(-1)
    py = ny + 2
    pz = nz + 2
    sx_lin = py * pz
    inv_res = 1.0 / res
    n_views = origins.shape[0]
    n_rays = dirs_cam.shape[0]
    cur = 0
    for m in range(w, n_views, n_workers):
        cur += 1
        if cur > _MAX_STAMP:  # forget the stamps, keep walls and free voxels
            for a in range(g.size):
                if g[a] < _FREE_MARK:
                    g[a] = 0
            cur = 1
        stamp = np.uint8(cur)
        ox = origins[m, 0]
        oy = origins[m, 1]
        oz = origins[m, 2]
        gx = ox * inv_res - k0[0]
        gy = oy * inv_res - k0[1]
        gz = oz * inv_res - k0[2]
        count = 0
        for r in range(n_rays):
            if skip[m, r]:
                continue
            ok, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps = _view_ray(
                R_world_cams, m, dirs_cam, r, ox, oy, oz, gx, gy, gz, max_range, inv_res, k0, nx, ny, nz
            )
            if not ok:
                continue
            lin = ((ix + 1) * py + (iy + 1)) * pz + (iz + 1)
            dlx = sx * sx_lin
            dly = sy * pz
            for _ in range(n_steps):
                v = g[lin]
                if v == _WALL:
                    break
                count += np.int64(v < stamp)  # unknown and not yet counted in this view
                g[lin] = max(v, stamp)  # free (254) stays free
                if tmx < tmy:
                    if tmx < tmz:
                        lin += dlx
                        tmx += tdx
                    else:
                        lin += sz
                        tmz += tdz
                else:
                    if tmy < tmz:
                        lin += dly
                        tmy += tdy
                    else:
                        lin += sz
                        tmz += tdz
        gains[m] = count


@njit(cache=True, parallel=True)
def info_gain_grids_parallel(grids, shape, origins, R_world_cams, dirs_cam, max_range, k0, res, skip):
    gains = np.zeros(origins.shape[0], np.int64)
    n_workers = grids.shape[0]
    for w in prange(n_workers):
        _views_padded(gains, w, n_workers, grids, shape, origins, R_world_cams, dirs_cam, max_range, k0, res, skip)
    return gains
