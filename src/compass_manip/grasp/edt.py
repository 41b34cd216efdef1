"""The exact Euclidean distance transform of the grasp's checked field, laid out for the cache.

`exact_distances(unsafe, res)` returns exactly what `mapping.distance._distances` returns
(the same three separable passes of Felzenszwalb & Huttenlocher's lower envelope, the same
float64 arithmetic per line, so every value is bit-identical; tested), but the last pass
(along x, the array's slowest axis) first copies each x-z plane into a contiguous buffer
instead of reading one value per x from a different memory page, and the squared distances
between passes are float32 (whole numbers below 2^24, exact; a line without an unsafe voxel
is inf there and the mapping's _FAR sentinel in the arithmetic: a finite parabola always
wins the envelope inside the line, so where any distance is finite it is the same). On the
grasp's fine grids (10^6-10^7 cells) this halves the memory the passes stream through.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..mapping.distance import _FAR, _distances, _envelope_1d


def exact_distances(unsafe: np.ndarray, res: float) -> np.ndarray:
    """(nx, ny, nz) float32 distances [m] from each voxel centre to the nearest unsafe voxel
    centre of the bool mask `unsafe` (voxel edge res [m]); as `mapping.distance._distances`."""
    unsafe = np.ascontiguousarray(unsafe, dtype=np.bool_)
    if not unsafe.any() or max(unsafe.shape) > 2000:  # no finite distance / squares beyond float32's integers
        return _distances(unsafe, float(res))
    return _edt(unsafe, float(res))


@njit(cache=True, inline="always")
def _load(x):
    """A float32 squared distance as the float64 the mapping's transform holds (inf: none)."""
    return _FAR if x == np.inf else float(x)


@njit(cache=True, parallel=True)
def _edt(unsafe, res):
    # squared distances are whole numbers below 2^24 (exact in float32): half the memory
    # traffic of float64; "none on this line" is inf here and _FAR in the arithmetic
    nx, ny, nz = unsafe.shape
    sq = np.empty((nx, ny, nz), np.float32)
    for i in prange(nx):  # along z: nearest unsafe voxel on the line, two scans
        for j in range(ny):
            last = -1
            for k in range(nz):
                if unsafe[i, j, k]:
                    last = k
                sq[i, j, k] = (k - last) if last >= 0 else np.inf
            last = -1
            for k in range(nz - 1, -1, -1):
                if unsafe[i, j, k]:
                    last = k
                if last >= 0 and last - k < sq[i, j, k]:
                    sq[i, j, k] = last - k
            for k in range(nz):
                a = sq[i, j, k]
                sq[i, j, k] = a * a
    m = max(nx, ny)
    for i in prange(nx):  # along y, within one contiguous y-z plane
        f = np.empty(m)
        d = np.empty(m)
        v = np.empty(m, np.int64)
        z = np.empty(m + 1)
        for k in range(nz):
            for j in range(ny):
                f[j] = _load(sq[i, j, k])
            _envelope_1d(f, ny, d, v, z)
            for j in range(ny):
                sq[i, j, k] = d[j] if d[j] < 0.5 * _FAR else np.inf
    out = np.empty((nx, ny, nz), np.float32)
    for j in prange(ny):  # along x, on a contiguous copy of the x-z plane, then metres
        f = np.empty(m)
        d = np.empty(m)
        v = np.empty(m, np.int64)
        z = np.empty(m + 1)
        buf = np.empty((nx, nz))
        for i in range(nx):
            for k in range(nz):
                buf[i, k] = _load(sq[i, j, k])
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
