"""The exact Euclidean distance transform of the grasp's checked field, laid out for the cache.

`exact_distances(unsafe, res)` returns exactly what `mapping.distance._distances` returns
(the same three separable passes of Felzenszwalb & Huttenlocher's lower envelope, the same
float64 arithmetic per line, so every value is bit-identical; tested), but the last pass
(along x, the array's slowest axis) first copies each x-z plane into a contiguous buffer
instead of reading one value per x from a different memory page. On the grasp's fine
grids (10^6-10^7 cells) that pass took most of the transform.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..mapping.distance import _FAR, _envelope_1d


def exact_distances(unsafe: np.ndarray, res: float) -> np.ndarray:
    """(nx, ny, nz) float32 distances [m] from each voxel centre to the nearest unsafe voxel
    centre of the bool mask `unsafe` (voxel edge res [m]); as `mapping.distance._distances`."""
    return _edt(np.ascontiguousarray(unsafe, dtype=np.bool_), float(res))


@njit(cache=True, parallel=True)
def _edt(unsafe, res):
    nx, ny, nz = unsafe.shape
    sq = np.empty((nx, ny, nz))
    for i in prange(nx):  # along z: nearest unsafe voxel on the line, two scans
        for j in range(ny):
            last = -1
            for k in range(nz):
                if unsafe[i, j, k]:
                    last = k
                sq[i, j, k] = (k - last) if last >= 0 else _FAR
            last = -1
            for k in range(nz - 1, -1, -1):
                if unsafe[i, j, k]:
                    last = k
                if last >= 0 and last - k < sq[i, j, k]:
                    sq[i, j, k] = last - k
            for k in range(nz):
                a = sq[i, j, k]
                sq[i, j, k] = a * a if a < _FAR else _FAR
    m = max(nx, ny)
    for i in prange(nx):  # along y, within one contiguous y-z plane
        f = np.empty(m)
        d = np.empty(m)
        v = np.empty(m, np.int64)
        z = np.empty(m + 1)
        for k in range(nz):
            for j in range(ny):
                f[j] = sq[i, j, k]
            _envelope_1d(f, ny, d, v, z)
            for j in range(ny):
                sq[i, j, k] = d[j]
    out = np.empty((nx, ny, nz), np.float32)
    for j in prange(ny):  # along x, on a contiguous copy of the x-z plane, then metres
        f = np.empty(m)
        d = np.empty(m)
        v = np.empty(m, np.int64)
        z = np.empty(m + 1)
        buf = np.empty((nx, nz))
        for i in range(nx):
            for k in range(nz):
                buf[i, k] = sq[i, j, k]
        for k in range(nz):
            for i in range(nx):
                f[i] = buf[i, k]
            _envelope_1d(f, nx, d, v, z)
            for i in range(nx):
                buf[i, k] = d[i]
        for i in range(nx):
            for k in range(nz):
                out[i, j, k] = math.sqrt(buf[i, k]) * res
    return out
