"""Self-filtering: drop depth points that lie on the robot's own body.

A self-filter is any callable `points_world (N, 3) [m] -> bool (N,)` returning True for
points inside the robot (see `occupancy.PointFilter`); `OccupancyMap.integrate` drops those
pixels (neither hit nor ray) before integration. The filter works from geometry only, not
from simulator labels. `SphereBodyFilter` is the geometric implementation over a set of
body spheres, e.g. the robot's collision spheres posed at the current configuration.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import CompassInputError, float_array, points_array, real_number


class SphereBodyFilter:
    """Points inside any of the spheres (centers_world (S, 3) [m], radii (S,) [m]),
    each inflated by `margin` [m] (for depth noise and sphere-fit error).

    Build it once per robot configuration (well under 1 ms for the Panda's ~350 spheres); a
    uniform grid of `cell_size` [m] lists the spheres overlapping each cell, so a point is
    tested against the few spheres of its cell only."""

    def __init__(self, centers_world: np.ndarray, radii: np.ndarray, margin: float = 0.0,
                 cell_size: float = 0.04) -> None:
        c = np.ascontiguousarray(points_array(centers_world, "centers_world"))
        r = np.ascontiguousarray(float_array(radii, "radii", "(S,) numbers [m]").reshape(-1))
        if len(c) != len(r):
            raise CompassInputError(f"{len(c)} sphere centres but {len(r)} radii; counts must match")
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r >= 0.0)):
            raise CompassInputError("sphere centres must be finite [m] and radii finite and >= 0 [m]")
        margin = real_number(margin, "margin", "0..1 m")
        cell_size = real_number(cell_size, "cell_size", "0.005..1 m")
        if not 0.0 <= margin <= 1.0:
            raise CompassInputError(f"margin {margin} m is not allowed; use 0..1 m")
        if not 0.005 <= cell_size <= 1.0:
            raise CompassInputError(f"cell_size {cell_size} m is not allowed; use 0.005..1 m")
        if len(r) and np.any(r > 10.0):
            raise CompassInputError(f"sphere radius {r.max()} m is not allowed; use 0..10 m")
        self.centers_world = c
        self.radii = r
        self.margin = float(margin)
        rr = r + self.margin
        self._r2 = rr * rr
        # uniform grid over the spheres' bounding box; cell -> spheres whose boxes overlap it
        if len(c):
            lo_s = c - rr[:, None]
            hi_s = c + rr[:, None]
            self._lo = lo_s.min(axis=0)
            self._cell = float(cell_size)
            self._dims = np.floor((hi_s.max(axis=0) - self._lo) / self._cell).astype(np.int64) + 1
            a = np.clip(np.floor((lo_s - self._lo) / self._cell).astype(np.int64), 0, self._dims - 1)
            b = np.clip(np.floor((hi_s - self._lo) / self._cell).astype(np.int64), 0, self._dims - 1)
            self._start, self._items = _cell_lists(a, b, self._dims)
            # the spheres' bounding box, padded far beyond rounding: a point outside it is in
            # no sphere, and the box test (six comparisons) is much cheaper than the cell lookup
            self._box = np.concatenate([lo_s.min(axis=0) - _BOX_PAD_M, hi_s.max(axis=0) + _BOX_PAD_M])
        else:
            self._lo = np.zeros(3)
            self._cell = 1.0
            self._dims = np.zeros(3, np.int64)
            self._items = np.zeros(0, np.int64)
            self._start = np.zeros(1, np.int64)
            self._box = np.array([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf])

    def __call__(self, points_world: np.ndarray) -> np.ndarray:
        p = float_array(points_world, "points_world", "(N, 3) numbers [m]")
        if p.ndim != 2 or p.shape[1] != 3:
            raise CompassInputError(f"points_world must have shape (N, 3), got {p.shape}")
        return _inside_spheres(np.ascontiguousarray(p), _ALL, self.centers_world, self._r2, self._box, self._lo,
                               1.0 / self._cell, self._dims, self._start, self._items)

    def inside_where(self, points_world: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """bool (N,): `self(points_world[valid])` scattered back to the N points (False where
        not valid), without copying the valid points out (points_world (N, 3) float64 [m],
        valid (N,) bool; an invalid point's coordinates are never read)."""
        p = np.ascontiguousarray(points_world, dtype=np.float64).reshape(-1, 3)
        v = np.ascontiguousarray(valid, dtype=np.bool_).reshape(-1)
        if len(v) != len(p) or len(v) == 0:
            raise CompassInputError(f"valid has {len(v)} entries for {len(p)} points; give one per point (N >= 1)")
        return _inside_spheres(p, v, self.centers_world, self._r2, self._box, self._lo, 1.0 / self._cell, self._dims,
                               self._start, self._items)

    def invalidate_inside(self, points_world: np.ndarray, kind: np.ndarray, point_kind: int, invalid_kind: int) -> int:
        """In place: set kind[i] = invalid_kind for every point i of kind point_kind inside
        the spheres (points_world (N, 3) float64 [m], kind (N,) uint8); returns how many.
        The same as `kind[m[self(points_world[m])]] = invalid_kind` with m the points of
        point_kind, in one compiled pass (no copies of the image's points)."""
        return int(_invalidate_inside(points_world, kind, np.uint8(point_kind), np.uint8(invalid_kind),
                                      self.centers_world, self._r2, self._box, self._lo, 1.0 / self._cell, self._dims,
                                      self._start, self._items))


@njit(cache=True, inline="always")
def _in_a_sphere(x, y, z, centers, r2, box, lo, inv_cell, dims, start, items):
    """Whether the point (x, y, z) [m] lies in one of the spheres of its grid cell's list
    (box: the spheres' padded bounding box (lo xyz, hi xyz) [m]: a point beyond it is in none;
    the callers test it first too, in their own loops: a call per point costs more than the
    six comparisons)."""
    if x < box[0] or y < box[1] or z < box[2] or x > box[3] or y > box[4] or z > box[5]:
        return False
    a = math.floor((x - lo[0]) * inv_cell)
    b = math.floor((y - lo[1]) * inv_cell)
    c = math.floor((z - lo[2]) * inv_cell)
    if not (0 <= a < dims[0] and 0 <= b < dims[1] and 0 <= c < dims[2]):
        return False
    cell = (int(a) * dims[1] + int(b)) * dims[2] + int(c)
    for t in range(start[cell], start[cell + 1]):
        s = items[t]
        dx = x - centers[s, 0]
        dy = y - centers[s, 1]
        dz = z - centers[s, 2]
        if dx * dx + dy * dy + dz * dz <= r2[s]:
            return True
    return False


@njit(cache=True)
def _invalidate_inside(points, kind, point_kind, invalid_kind, centers, r2, box, lo, inv_cell, dims, start, items):
    """`_inside_spheres`'s test for the points of point_kind, setting their kind to invalid_kind."""
    n_dropped = 0
    for i in range(points.shape[0]):
        if kind[i] != point_kind:
            continue
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        if x < box[0] or y < box[1] or z < box[2] or x > box[3] or y > box[4] or z > box[5]:
            continue
        if _in_a_sphere(points[i, 0], points[i, 1], points[i, 2], centers, r2, box, lo, inv_cell, dims, start, items):
            kind[i] = invalid_kind
            n_dropped += 1
    return n_dropped


@njit(cache=True)
def _cell_lists(a, b, dims):
    """Cell lists of the grid (CSR): the spheres whose cell boxes a[s]..b[s] (S, 3) (cell
    indices, inclusive) hold cell c are items[start[c]:start[c + 1]], in sphere order."""
    n_cells = dims[0] * dims[1] * dims[2]
    start = np.zeros(n_cells + 1, np.int64)
    for s in range(a.shape[0]):  # count, then place (a counting sort by cell)
        for i in range(a[s, 0], b[s, 0] + 1):
            for j in range(a[s, 1], b[s, 1] + 1):
                for k in range(a[s, 2], b[s, 2] + 1):
                    start[(i * dims[1] + j) * dims[2] + k + 1] += 1
    for c in range(n_cells):
        start[c + 1] += start[c]
    items = np.empty(start[n_cells], np.int64)
    fill = start[:n_cells].copy()
    for s in range(a.shape[0]):
        for i in range(a[s, 0], b[s, 0] + 1):
            for j in range(a[s, 1], b[s, 1] + 1):
                for k in range(a[s, 2], b[s, 2] + 1):
                    cell = (i * dims[1] + j) * dims[2] + k
                    items[fill[cell]] = s
                    fill[cell] += 1
    return start, items


#: padding [m] of the spheres' bounding box in the point test (rounding is ~1e-16 m)
_BOX_PAD_M = 1e-6

#: `_inside_spheres`'s valid mask for "every point"
_ALL = np.zeros(0, np.bool_)


@njit(cache=True)
def _inside_spheres(points, valid, centers, r2, box, lo, inv_cell, dims, start, items):
    """Points inside a sphere; valid: (N,) bool (only those tested, the rest False) or empty (all)."""
    n = points.shape[0]
    out = np.zeros(n, np.bool_)
    masked = valid.shape[0] > 0
    for i in range(n):
        if masked and not valid[i]:
            continue
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        if x < box[0] or y < box[1] or z < box[2] or x > box[3] or y > box[4] or z > box[5]:
            continue
        out[i] = _in_a_sphere(points[i, 0], points[i, 1], points[i, 2], centers, r2, box, lo, inv_cell, dims, start,
                              items)
    return out
