"""The obstacle halo of a method's map, kept from one checker rebuild to the next.

`world_model.method_safe_voxels` leaves out of the unknown space assumed free every voxel
within `obstacle_halo` (L1, in voxels) of a voxel seen occupied: `manhattan_dilate` of the
occupied mask, a pass over the whole grid at every rebuild (about 1 ms on the 2 cm map, one
rebuild per decision). Between two rebuilds a few frames change a few voxels: when no voxel
stopped being occupied, the halo of the new occupied set is the old halo plus the L1 balls
of the new voxels (a dilation of a union is the union of the dilations; in a box grid the
L1 distance between two voxels does not depend on the box), so only those balls are
marked. A voxel that stopped being occupied makes the whole dilation run again. Either way
the mask equals `manhattan_dilate(occupied, r)` (tests/test_exploration_halo.py).
"""
from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def manhattan_dilate(mask, r):
    """Voxels within r 6-connected steps (L1 distance, in voxels) of a True voxel of mask
    (nx, ny, nz): `scipy.ndimage.binary_dilation(mask, iterations=r)` with its default
    structure, as a two-pass L1 distance transform per axis (exact for the L1 metric)."""
    nx, ny, nz = mask.shape
    big = r + 1
    d = np.empty((nx, ny, nz), np.int32)
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                d[i, j, k] = 0 if mask[i, j, k] else big
    for i in range(1, nx):  # each pass keeps the contiguous axis innermost
        for j in range(ny):
            for k in range(nz):
                d[i, j, k] = min(d[i, j, k], d[i - 1, j, k] + 1)
    for i in range(nx - 2, -1, -1):
        for j in range(ny):
            for k in range(nz):
                d[i, j, k] = min(d[i, j, k], d[i + 1, j, k] + 1)
    for i in range(nx):
        for j in range(1, ny):
            for k in range(nz):
                d[i, j, k] = min(d[i, j, k], d[i, j - 1, k] + 1)
        for j in range(ny - 2, -1, -1):
            for k in range(nz):
                d[i, j, k] = min(d[i, j, k], d[i, j + 1, k] + 1)
        for j in range(ny):
            for k in range(1, nz):
                d[i, j, k] = min(d[i, j, k], d[i, j, k - 1] + 1)
            for k in range(nz - 2, -1, -1):
                d[i, j, k] = min(d[i, j, k], d[i, j, k + 1] + 1)
    return d <= r


@nb.njit(cache=True)
def occupied_change(previous, current):
    """(any voxel occupied in `previous` but not in `current`, indices (n, 3) of the voxels
    occupied in `current` but not in `previous`) of two (nx, ny, nz) bool masks."""
    nx, ny, nz = current.shape
    removed = False
    n = 0
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if current[i, j, k] != previous[i, j, k]:
                    if current[i, j, k]:
                        n += 1
                    else:
                        removed = True
    out = np.empty((n, 3), np.int64)
    if removed or n == 0:
        return removed, out[:0]
    m = 0
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if current[i, j, k] and not previous[i, j, k]:
                    out[m, 0], out[m, 1], out[m, 2] = i, j, k
                    m += 1
    return removed, out


@nb.njit(cache=True)
def mark_l1_balls(mask, voxels, r):
    """Set every voxel of mask within L1 distance r (voxels) of one of `voxels` (n, 3)."""
    nx, ny, nz = mask.shape
    for v in range(voxels.shape[0]):
        ci, cj, ck = voxels[v, 0], voxels[v, 1], voxels[v, 2]
        for i in range(max(0, ci - r), min(nx - 1, ci + r) + 1):
            ri = r - abs(i - ci)
            for j in range(max(0, cj - ri), min(ny - 1, cj + ri) + 1):
                rj = ri - abs(j - cj)
                for k in range(max(0, ck - rj), min(nz - 1, ck + rj) + 1):
                    mask[i, j, k] = True


class ObstacleHalo:
    """`near(occupied)` = `manhattan_dilate(occupied, r)`, updated from the last call's
    occupied mask when voxels were only added (see the module docstring)."""

    def __init__(self, r: int) -> None:
        self.r = int(r)
        self._occupied: np.ndarray | None = None
        self._near: np.ndarray | None = None
        self.full_updates = 0

    def near(self, occupied: np.ndarray) -> np.ndarray:
        """(nx, ny, nz) bool, owned by this object (valid until the next call)."""
        occupied = np.ascontiguousarray(occupied, dtype=bool)
        removed, added = (True, None) if self._occupied is None or self._occupied.shape != occupied.shape \
            else occupied_change(self._occupied, occupied)
        if removed:
            self._near = manhattan_dilate(occupied, self.r)
            self.full_updates += 1
        elif len(added):
            mark_l1_balls(self._near, added, self.r)
        self._occupied = occupied.copy()
        return self._near
