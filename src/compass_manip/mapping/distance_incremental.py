"""A capped Euclidean distance field of unsafe space, updated where the unsafe mask changed.

A collision checker compares the field with thresholds no larger than its largest sphere
plus margins, so the field is only needed up to a cap C (voxels): every value above it can
read C without changing a verdict. Capping also bounds how far a change travels through the
separable transform (Felzenszwalb & Huttenlocher, as in `mapping.distance`): with the first
(z) pass capped at C^2, the lower envelopes of the y and x passes give
min(true squared distance, C^2) exactly (the p = q term of each envelope is <= C^2), and a
voxel whose unsafe flag changed alters the first pass within C voxels along z, the second
within C along y and the third within C along x. `CappedDistance.update` keeps both
intermediate passes and recomputes only the lines in those ranges, so a map update that
touches a small region costs a fraction of the whole transform. Its result equals the full
transform capped at C voxels, bit for bit (`tests/test_distance_incremental.py`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..errors import CompassInputError
from .distance import _envelope_1d


@njit(cache=True, parallel=True)
def _pass_z(unsafe, s1, i0, i1, j0, j1, cap2):
    """Capped squared distance along z for the lines (i, j) in [i0, i1] x [j0, j1] into s1;
    returns (k_lo, k_hi) of the values that changed (k_lo > k_hi: none)."""
    nz = unsafe.shape[2]
    n = (i1 - i0 + 1) * (j1 - j0 + 1)
    lo = np.full(n, nz, np.int64)
    hi = np.full(n, -1, np.int64)
    for t in prange(n):
        i = i0 + t // (j1 - j0 + 1)
        j = j0 + t % (j1 - j0 + 1)
        col = np.empty(nz)
        last = -1
        for k in range(nz):
            if unsafe[i, j, k]:
                last = k
            col[k] = (k - last) if last >= 0 else 1.0e9
        last = -1
        for k in range(nz - 1, -1, -1):
            if unsafe[i, j, k]:
                last = k
            if last >= 0 and last - k < col[k]:
                col[k] = last - k
        for k in range(nz):
            v = min(col[k] * col[k], cap2)
            if v != s1[i, j, k]:
                s1[i, j, k] = v
                lo[t] = min(lo[t], k)
                hi[t] = max(hi[t], k)
    return lo.min(), hi.max()


@njit(cache=True, parallel=True)
def _pass_y(s1, s2, i0, i1, k0, k1):
    """Envelope along y of s1's lines (i, k) in [i0, i1] x [k0, k1] into s2; returns the
    (j_lo, j_hi, k_lo, k_hi) ranges of the values that changed."""
    ny = s1.shape[1]
    n = (i1 - i0 + 1) * (k1 - k0 + 1)
    jl = np.full(n, ny, np.int64)
    jh = np.full(n, -1, np.int64)
    kl = np.full(n, s1.shape[2], np.int64)
    kh = np.full(n, -1, np.int64)
    for t in prange(n):
        i = i0 + t // (k1 - k0 + 1)
        k = k0 + t % (k1 - k0 + 1)
        f = np.empty(ny)
        d = np.empty(ny)
        v = np.empty(ny, np.int64)
        z = np.empty(ny + 1)
        for j in range(ny):
            f[j] = s1[i, j, k]
        _envelope_1d(f, ny, d, v, z)
        for j in range(ny):
            if d[j] != s2[i, j, k]:
                s2[i, j, k] = d[j]
                jl[t] = min(jl[t], j)
                jh[t] = max(jh[t], j)
                kl[t] = k
                kh[t] = k
    return jl.min(), jh.max(), kl.min(), kh.max()


@njit(cache=True, parallel=True)
def _pass_x(s2, out, j0, j1, k0, k1, res):
    """Envelope along x of s2's lines (j, k) in [j0, j1] x [k0, k1], in metres, into out."""
    nx = s2.shape[0]
    n = (j1 - j0 + 1) * (k1 - k0 + 1)
    for t in prange(n):
        j = j0 + t // (k1 - k0 + 1)
        k = k0 + t % (k1 - k0 + 1)
        f = np.empty(nx)
        d = np.empty(nx)
        v = np.empty(nx, np.int64)
        z = np.empty(nx + 1)
        for i in range(nx):
            f[i] = s2[i, j, k]
        _envelope_1d(f, nx, d, v, z)
        for i in range(nx):
            out[i, j, k] = math.sqrt(d[i]) * res


def _changed_box(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Inclusive index bounds (lo (3,), hi (3,)) of the voxels where a and b differ, or None."""
    diff = a != b
    lo, hi = np.zeros(3, np.int64), np.zeros(3, np.int64)
    for ax in range(3):
        other = tuple(x for x in range(3) if x != ax)
        idx = np.flatnonzero(diff.any(axis=other))
        if len(idx) == 0:
            return None
        lo[ax], hi[ax] = idx[0], idx[-1]
    return lo, hi


class CappedDistance:
    """Distances [m] from voxel centres to the nearest unsafe voxel centre, capped at
    cap_voxels * resolution, kept up to date as the unsafe mask changes.

    outside_is_unsafe: a one-voxel unsafe shell around the grid, as
    `mapping.distance.DistanceFieldConfig` (the shell never changes). `update(unsafe)`
    returns a new float32 array (nx, ny, nz) [m]; arrays returned earlier are not modified.
    """

    def __init__(self, resolution: float, cap_voxels: int, outside_is_unsafe: bool = True) -> None:
        if not (isinstance(cap_voxels, (int, np.integer)) and 1 <= cap_voxels <= 10000):
            raise CompassInputError(f"cap_voxels {cap_voxels!r} not allowed; use an integer 1..10000")
        if not (math.isfinite(resolution) and resolution > 0):
            raise CompassInputError(f"resolution {resolution!r} m not allowed; use a finite value > 0")
        self.resolution = float(resolution)
        self.cap_voxels = int(cap_voxels)
        self.outside_is_unsafe = bool(outside_is_unsafe)
        self._unsafe: np.ndarray | None = None
        self._s1 = self._s2 = self._out = None
        self.lines_last = 0  # lines recomputed by the last update (all three passes), for benchmarks

    @property
    def cap_m(self) -> float:
        return self.cap_voxels * self.resolution

    def update(self, unsafe: np.ndarray) -> np.ndarray:
        u = np.asarray(unsafe, dtype=bool)
        if u.ndim != 3:
            raise CompassInputError(f"unsafe mask has shape {u.shape}; an (nx, ny, nz) array is required")
        p = 1 if self.outside_is_unsafe else 0
        if p:
            u = np.pad(u, 1, constant_values=True)
        if self._unsafe is None or self._unsafe.shape != u.shape:
            self._unsafe = np.zeros(u.shape, bool)
            self._s1 = np.full(u.shape, -1.0)  # no valid value yet: every line is recomputed
            self._s2 = np.full(u.shape, -1.0)
            self._out = np.empty(u.shape, np.float32)
            box = (np.zeros(3, np.int64), np.asarray(u.shape, np.int64) - 1)
        else:
            box = _changed_box(self._unsafe, u)
        self.lines_last = 0
        if box is not None:
            self._recompute(u, *box)
        self._unsafe = u
        return (self._out[p:-p, p:-p, p:-p] if p else self._out).copy()

    def _recompute(self, u: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        C = self.cap_voxels
        k_lo, k_hi = _pass_z(u, self._s1, lo[0], hi[0], lo[1], hi[1], float(C * C))
        lines = (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)
        if k_lo > k_hi:
            self.lines_last = int(lines)
            return
        j_lo, j_hi, k2_lo, k2_hi = _pass_y(self._s1, self._s2, lo[0], hi[0], k_lo, k_hi)
        lines += (hi[0] - lo[0] + 1) * (k_hi - k_lo + 1)
        if j_lo <= j_hi:
            _pass_x(self._s2, self._out, j_lo, j_hi, k2_lo, k2_hi, self.resolution)
            lines += (j_hi - j_lo + 1) * (k2_hi - k2_lo + 1)
        self.lines_last = int(lines)
