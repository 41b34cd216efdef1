"""Euclidean distance field of unsafe space, for collision checking against the map.

Unsafe = occupied or unknown (motion never enters unseen space), minus the voxels the caller
marks safe: a boolean voxel mask and/or spheres (e.g. the robot's own collision spheres at
the start configuration), a voxel being inside a sphere when its centre is.

`distances[i, j, k]` is the exact Euclidean distance [m] from the centre of voxel (i, j, k)
to the centre of the nearest unsafe voxel, 0 on unsafe voxels (the separable transform of
Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled Functions", 2012, in numba;
the same values as `scipy.ndimage.distance_transform_edt`, about 4x faster here). The
surface of that voxel is at least `d - sqrt(3) / 2 * resolution` away, so a collision
checker should subtract that margin (or half a voxel for axis-aligned approaches).

Outside the workspace box: with `outside_is_unsafe=True` (default) the space around the box
is unsafe: the field treats a one-voxel shell around the grid as unsafe and `distance_at`
returns 0 for points outside the box. With False, the outside neither blocks nor counts
and a point outside gets the value at its projection onto the box, which is a lower bound
of its distance to every unsafe voxel in the box (projection onto a convex set never
increases distances).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numba import njit, prange

from ..errors import CompassInputError, float_array, instance_of, points_array, check_field_types
from .occupancy import OccupancyMap, VoxelState


class Interpolation(IntEnum):
    NEAREST = 0  # value of the voxel containing the point
    TRILINEAR = 1  # trilinear between the 8 surrounding voxel centres


@dataclass(frozen=True)
class DistanceFieldConfig:
    outside_is_unsafe: bool = True
    interpolation: Interpolation = Interpolation.TRILINEAR

    def __post_init__(self) -> None:
        check_field_types(self)
        if self.interpolation not in tuple(Interpolation):
            raise CompassInputError(f"DistanceFieldConfig.interpolation = {self.interpolation!r} is not allowed; use "
                                    "Interpolation.NEAREST (0) or Interpolation.TRILINEAR (1)")


def unsafe_mask(
    occ_map: OccupancyMap,
    safe_voxels: np.ndarray | None = None,
    safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """(nx, ny, nz) bool: occupied or unknown, except voxels marked safe.

    safe_voxels: bool mask of the grid's shape. safe_spheres: (centers_world (S, 3) [m],
    radii (S,) [m]); voxels whose centres lie inside any sphere are safe.
    """
    unsafe = occ_map.state != VoxelState.FREE
    if safe_voxels is not None:
        sv = np.asarray(safe_voxels, dtype=bool)
        if sv.shape != unsafe.shape:
            raise CompassInputError(f"safe_voxels has shape {sv.shape}; the grid's shape {unsafe.shape} is required")
        unsafe &= ~sv
    if safe_spheres is not None:
        c = float_array(safe_spheres[0], "safe_spheres centres", "(S, 3) numbers [m]").reshape(-1, 3)
        r = float_array(safe_spheres[1], "safe_spheres radii", "(S,) numbers [m]").reshape(-1)
        if len(c) != len(r) or not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r >= 0)):
            raise CompassInputError("safe_spheres must be finite centres (S, 3) [m] and radii (S,) >= 0 [m]")
        _clear_spheres(unsafe, occ_map.grid_min, occ_map.resolution, c, r)
    return unsafe


def mark_in_spheres(mask: np.ndarray, grid_min: np.ndarray, resolution: float, centres: np.ndarray,
                    radii: np.ndarray) -> None:
    """Set True, in place, every voxel of mask (a bool grid with origin grid_min (3,) [m] and
    voxel edge resolution [m]) whose centre lies inside one of the spheres (centres (S, 3) [m],
    radii (S,) [m]). The same mask as testing every voxel of each sphere's box (tested against
    that brute force), through `_clear_spheres` on the complement: 4^3 blocks already all
    set, or out of a sphere's reach, are skipped, which is what makes the thousands of
    overlapping spheres of an executed way cheap on a 1 cm grid. The spheres go
    in largest first, repeats once (`union_order`): the union is the same in any order, and
    the blocks a large sphere fills are skipped by the smaller ones after it."""
    c = np.ascontiguousarray(centres, dtype=np.float64).reshape(-1, 3)
    r = np.ascontiguousarray(radii, dtype=np.float64).reshape(-1)
    keep = union_order(c, r)
    _mark_ordered(mask, grid_min, resolution, c[keep], r[keep])


def _mark_ordered(mask: np.ndarray, grid_min: np.ndarray, resolution: float, centres: np.ndarray,
                  radii: np.ndarray) -> None:
    """`mark_in_spheres` with the spheres (centres (S,3), radii (S,) [m]) taken in the order given."""
    if mask.dtype != np.bool_ or not mask.flags.c_contiguous:
        raise CompassInputError(f"mark_in_spheres needs a C-contiguous bool mask, not {mask.dtype}")
    rest = ~mask
    _clear_spheres(rest, np.asarray(grid_min, dtype=np.float64), float(resolution),
                   np.ascontiguousarray(centres, dtype=np.float64), np.ascontiguousarray(radii, dtype=np.float64))
    np.logical_not(rest, out=mask)


def union_order(centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Indices of the spheres (centres (S,3), radii (S,) [m]) by radius, largest first (ties
    in their order), each exact repeat (same centre and radius) once: the order in which
    `_clear_spheres` skips the most blocks, for the same union."""
    if len(radii) == 0:
        return np.zeros(0, np.int64)
    rows = np.ascontiguousarray(np.column_stack([centres, radii]), dtype=np.float64)
    _, first = np.unique(rows.view(np.dtype((np.void, 32))).ravel(), return_index=True)
    first = np.sort(first)
    return first[np.argsort(-radii[first], kind="stable")]


def voxels_in_spheres(select: np.ndarray, grid_min: np.ndarray, resolution: float, centres: np.ndarray,
                      radii: np.ndarray) -> np.ndarray:
    """(N, 3) int64 indices, in np.argwhere's order, of the True voxels of select (a bool grid
    with origin grid_min (3,) [m] and voxel edge resolution [m]) whose centres lie inside one
    of the spheres (centres (S, 3) [m], radii (S,) [m]). Only the box the spheres span is
    rasterised, and only where select is True (`_clear_spheres` skips blocks with nothing
    left), so a few spheres on a large, mostly unselected grid cost little."""
    c = np.ascontiguousarray(centres, dtype=np.float64).reshape(-1, 3)
    r = np.ascontiguousarray(radii, dtype=np.float64).reshape(-1)
    gm, res, shape = np.asarray(grid_min, dtype=np.float64), float(resolution), np.asarray(select.shape)
    if len(c) == 0:
        return np.zeros((0, 3), np.int64)
    lo = np.maximum(np.floor(((c - r[:, None]).min(0) - gm) / res - 0.5).astype(np.int64), 0)
    hi = np.minimum(np.ceil(((c + r[:, None]).max(0) - gm) / res - 0.5).astype(np.int64), shape - 1)
    if np.any(lo > hi):
        return np.zeros((0, 3), np.int64)
    box = tuple(slice(int(lo[a]), int(hi[a]) + 1) for a in range(3))
    sel = np.asarray(select, dtype=bool)[box]
    rest = np.array(sel, order="C")  # a copy: cleared in place
    _clear_spheres(rest, gm + lo * res, res, c, r)
    return np.argwhere(sel & ~rest) + lo


def mark_robot(mask: np.ndarray, occ_map: OccupancyMap, spheres, Q: np.ndarray, margin: float) -> None:
    """Set True, in place, the voxels of mask (occ_map's grid) inside the robot's spheres
    (`robot.spheres.SphereModel`) grown by margin [m] at every configuration of Q (m, 7) [rad]
    (`mark_in_spheres`): the swept space and start shell of `exploration.world_model`. The
    spheres go in as `way_order` gives them (the same union as `union_order`'s, without its
    sort of every sphere)."""
    _mark_ordered(mask, occ_map.grid_min, occ_map.resolution, *_robot_way(spheres, Q, margin))


def _robot_way(spheres, Q: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(centres (n, 3) [m], radii (n,) [m]): the robot's spheres grown by margin [m] at every
    configuration of Q (m, 7) [rad], in `way_order` (exact repeats dropped)."""
    Q = np.asarray(Q, dtype=np.float64).reshape(-1, 7)
    C = spheres.sphere_centers(Q)
    r = np.asarray(spheres.radii, dtype=np.float64) + margin
    take = way_order(C, r)
    return np.ascontiguousarray(C.reshape(-1, 3)[take]), np.ascontiguousarray(np.tile(r, len(Q))[take])


def robot_covers_any(mask: np.ndarray, occ_map: OccupancyMap, spheres, Q: np.ndarray, margin: float) -> bool:
    """True if `mark_robot(..., Q, margin)` would set a voxel that mask (occ_map's grid, bool)
    has set: the same spheres and the same per-voxel test (`_clear_spheres` on a copy of
    mask), without marking a grid: blocks of mask with nothing set are skipped."""
    if mask.dtype != np.bool_ or not mask.flags.c_contiguous:
        raise CompassInputError(f"robot_covers_any needs a C-contiguous bool mask, not {mask.dtype}")
    before = int(np.count_nonzero(mask))
    if before == 0:
        return False
    left = mask.copy()
    _clear_spheres(left, np.asarray(occ_map.grid_min, dtype=np.float64), float(occ_map.resolution),
                   *_robot_way(spheres, Q, margin))
    return int(np.count_nonzero(left)) < before


def way_order(C: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Indices into C.reshape(-1, 3) (C: (M, S, 3) [m], the centres of the same S spheres, radii
    (S,) [m], at M configurations in order): by radius, largest first, each model sphere along
    the way in order, dropping a sphere whose centre equals its own at the configuration
    before (a link the way did not move: the base at every configuration). The union of the
    spheres kept is the whole union: only exact repeats are dropped."""
    C = np.asarray(C, dtype=np.float64)
    M, S = C.shape[0], C.shape[1]
    moved = np.ones((M, S), bool)
    moved[1:] = np.any(C[1:] != C[:-1], axis=2)
    by_radius = np.argsort(-np.asarray(radii, dtype=np.float64), kind="stable")
    idx = np.arange(M)[None, :] * S + by_radius[:, None]  # (S, M): sphere by sphere, along the way
    return idx[moved[:, by_radius].T]


class DistanceField:
    """Distance [m] to the nearest unsafe voxel on the map's grid (see module doc)."""

    def __init__(self, distances: np.ndarray, grid_min: np.ndarray, resolution: float,
                 config: DistanceFieldConfig | None = None) -> None:
        self.distances = np.ascontiguousarray(distances, dtype=np.float32)
        self.grid_min = np.asarray(grid_min, dtype=np.float64)
        self.resolution = float(resolution)
        self.config = config or DistanceFieldConfig()

    @classmethod
    def from_map(
        cls,
        occ_map: OccupancyMap,
        config: DistanceFieldConfig | None = None,
        safe_voxels: np.ndarray | None = None,
        safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> DistanceField:
        instance_of(occ_map, OccupancyMap, "occ_map")
        config = DistanceFieldConfig() if config is None else instance_of(config, DistanceFieldConfig, "config")
        unsafe = unsafe_mask(occ_map, safe_voxels, safe_spheres)
        return cls.from_unsafe(unsafe, occ_map.grid_min, occ_map.resolution, config)

    @classmethod
    def from_unsafe(cls, unsafe: np.ndarray, grid_min: np.ndarray, resolution: float,
                    config: DistanceFieldConfig | None = None) -> DistanceField:
        """The field of a ready unsafe mask (nx, ny, nz) on a grid at grid_min (3,) [m]."""
        config = DistanceFieldConfig() if config is None else instance_of(config, DistanceFieldConfig, "config")
        unsafe = np.asarray(unsafe, dtype=bool)
        if config.outside_is_unsafe:
            unsafe = np.pad(unsafe, 1, constant_values=True)
        if unsafe.any():
            dist = _distances(unsafe, float(resolution))
        else:
            dist = np.full(unsafe.shape, np.inf, np.float32)
        if config.outside_is_unsafe:
            dist = dist[1:-1, 1:-1, 1:-1]
        return cls(dist, grid_min, resolution, config)

    def distance_at(self, points_world: np.ndarray) -> np.ndarray:
        """Distances (N,) [m] at world points (N, 3) [m] (interpolation and outside rule
        from the config)."""
        p = np.ascontiguousarray(points_array(points_world, "points_world"))
        return _lookup_many(self.distances, self.grid_min, 1.0 / self.resolution, p,
                            self.config.outside_is_unsafe, int(self.config.interpolation))


@njit(cache=True)
def distance_lookup(dist, grid_min, inv_res, x, y, z, outside_is_unsafe, interpolation):
    """Distance [m] at world point (x, y, z) [m]; callable from other numba code.

    dist: (nx, ny, nz) field; grid_min (3,) [m] low corner of the grid; inv_res [1/m];
    interpolation: 0 nearest, 1 trilinear (see `Interpolation`).
    """
    nx, ny, nz = dist.shape
    gx = (x - grid_min[0]) * inv_res
    gy = (y - grid_min[1]) * inv_res
    gz = (z - grid_min[2]) * inv_res
    if not (0.0 <= gx < nx and 0.0 <= gy < ny and 0.0 <= gz < nz):
        if outside_is_unsafe or math.isnan(gx + gy + gz):
            return 0.0
        gx = min(max(gx, 0.0), nx - 1e-9)
        gy = min(max(gy, 0.0), ny - 1e-9)
        gz = min(max(gz, 0.0), nz - 1e-9)
    if interpolation == 0:
        return float(dist[int(gx), int(gy), int(gz)])
    cx = min(max(gx - 0.5, 0.0), nx - 1.0)
    cy = min(max(gy - 0.5, 0.0), ny - 1.0)
    cz = min(max(gz - 0.5, 0.0), nz - 1.0)
    i0 = min(int(cx), max(nx - 2, 0))
    j0 = min(int(cy), max(ny - 2, 0))
    k0 = min(int(cz), max(nz - 2, 0))
    i1 = min(i0 + 1, nx - 1)
    j1 = min(j0 + 1, ny - 1)
    k1 = min(k0 + 1, nz - 1)
    fx = cx - i0
    fy = cy - j0
    fz = cz - k0
    c00 = dist[i0, j0, k0] * (1 - fx) + dist[i1, j0, k0] * fx
    c10 = dist[i0, j1, k0] * (1 - fx) + dist[i1, j1, k0] * fx
    c01 = dist[i0, j0, k1] * (1 - fx) + dist[i1, j0, k1] * fx
    c11 = dist[i0, j1, k1] * (1 - fx) + dist[i1, j1, k1] * fx
    c0 = c00 * (1 - fy) + c10 * fy
    c1 = c01 * (1 - fy) + c11 * fy
    return float(c0 * (1 - fz) + c1 * fz)


@njit(cache=True, parallel=True)
def _lookup_many(dist, grid_min, inv_res, points, outside_is_unsafe, interpolation):
    out = np.empty(points.shape[0])
    for n in prange(points.shape[0]):
        out[n] = distance_lookup(dist, grid_min, inv_res, points[n, 0], points[n, 1], points[n, 2],
                                 outside_is_unsafe, interpolation)
    return out


_FAR = 1.0e20  # squared distance [voxels^2] standing for "no unsafe voxel on this line"


@njit(cache=True, inline="always")
def _envelope_1d(f, n, d, v, z):
    """d[0:n] = min over p of (q - p)^2 + f[p]: lower envelope of parabolas (F&H)."""
    k = 0
    v[0] = 0
    z[0] = -10.0 * _FAR
    z[1] = 10.0 * _FAR
    for q in range(1, n):
        fq = f[q] + q * q
        p = v[k]
        s = (fq - (f[p] + p * p)) / (2.0 * (q - p))
        while s <= z[k]:
            k -= 1
            p = v[k]
            s = (fq - (f[p] + p * p)) / (2.0 * (q - p))
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = 10.0 * _FAR
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        p = v[k]
        d[q] = (q - p) * (q - p) + f[p]


def _distances(unsafe: np.ndarray, res: float) -> np.ndarray:
    """Distances [m] (float32) from each voxel centre to the nearest unsafe voxel centre
    (at least one voxel must be unsafe: every caller tests that). The squared distances in
    voxels are whole numbers; they are kept in float32 while every one possible is below
    2**24 (exact there: the same result as float64, with half the memory traffic), else in
    float64."""
    shape = np.shape(unsafe)
    exact32 = sum(int(n) ** 2 for n in shape) < 2**24
    sq = np.empty(shape, np.float32 if exact32 else np.float64)
    return _distances_into(unsafe, float(res), sq)


@njit(cache=True, parallel=True)
def _distances_into(unsafe, res, sq):
    """`_distances` with sq, a scratch array of unsafe's shape (float32 or float64)."""
    nx, ny, nz = unsafe.shape
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
    for i in prange(nx):  # along y
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
    for j in prange(ny):  # along x, then metres
        f = np.empty(m)
        d = np.empty(m)
        v = np.empty(m, np.int64)
        z = np.empty(m + 1)
        for k in range(nz):
            for i in range(nx):
                f[i] = sq[i, j, k]
            _envelope_1d(f, nx, d, v, z)
            for i in range(nx):
                out[i, j, k] = math.sqrt(d[i]) * res
    return out


_BLOCK = 4  # voxels per block edge in `_clear_spheres`' bookkeeping
#: Slack [m^2, relative to 1 + r^2] of `_clear_spheres`' whole-block tests: far above the
#: rounding of the per-voxel test, so a block within it of the sphere's surface takes the exact
#: per-voxel path, and a block skipped or filled whole gets what that path would give it.
_SLACK = 1e-9


@njit(cache=True, inline="always")
def _axis_span(g0, res, c, i0, i1):
    """(nearest, farthest) squared offset [m^2] along one axis from the sphere centre c [m]
    to the centres of voxels i0..i1 (grid origin g0 [m], edge res [m])."""
    d0 = g0 + (i0 + 0.5) * res - c
    d1 = g0 + (i1 + 0.5) * res - c
    far = max(d0 * d0, d1 * d1)
    if d0 <= 0.0 <= d1:
        return 0.0, far
    return min(d0 * d0, d1 * d1), far


@njit(cache=True)
def _clear_spheres(unsafe, grid_min, res, centers, radii):
    """Mark safe (False) every voxel whose centre lies inside one of the spheres.

    The result equals testing every voxel of every sphere's box (dx^2 + dy^2 + dz^2 <= r^2;
    `tests/test_grasp_field.py` compares it with that brute force), with shortcuts for the
    tens of thousands of heavily overlapping spheres of a robot's executed way, on blocks of
    4^3 voxels: a block with no unsafe voxel left is skipped (a count per block is kept as
    voxels are cleared; only the blocks the spheres' common bounding box touches are counted,
    so a few spheres on a large grid cost little); a block whose voxel centres all lie
    farther from the sphere's centre than its radius is skipped, and one whose centres all
    lie nearer is cleared whole, both decided on the block's nearest and farthest centre
    along each axis with a slack (`_SLACK`) far above rounding; only the blocks the sphere's
    surface crosses test their unsafe voxels one by one (the same expression as the brute
    force, term for term, so the same answer on every voxel)."""
    nx, ny, nz = unsafe.shape
    B = _BLOCK
    bx, by, bz = (nx + B - 1) // B, (ny + B - 1) // B, (nz + B - 1) // B
    n = (nx, ny, nz)
    S = centers.shape[0]
    boxes = np.empty((S, 6), np.int64)  # per sphere: lo (3), hi (3) voxel indices, clipped to the grid
    blo = np.array([nx, ny, nz], np.int64)
    bhi = np.full(3, -1, np.int64)
    for s in range(S):
        r = radii[s]
        for a in range(3):
            boxes[s, a] = max(int(math.floor((centers[s, a] - r - grid_min[a]) / res - 0.5)), 0)
            boxes[s, 3 + a] = min(int(math.ceil((centers[s, a] + r - grid_min[a]) / res - 0.5)), n[a] - 1)
        if boxes[s, 0] <= boxes[s, 3] and boxes[s, 1] <= boxes[s, 4] and boxes[s, 2] <= boxes[s, 5]:
            for a in range(3):
                blo[a] = min(blo[a], boxes[s, a])
                bhi[a] = max(bhi[a], boxes[s, 3 + a])
    if bhi[0] < 0:
        return
    left = np.zeros((bx, by, bz), np.int16)  # unsafe voxels left per block (at most B^3 = 64)
    for i in range((blo[0] // B) * B, min((bhi[0] // B + 1) * B, nx)):
        for j in range((blo[1] // B) * B, min((bhi[1] // B + 1) * B, ny)):
            for k in range((blo[2] // B) * B, min((bhi[2] // B + 1) * B, nz)):
                if unsafe[i, j, k]:
                    left[i // B, j // B, k // B] += 1
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    dz2 = np.empty(B)
    for s in range(S):
        r = radii[s]
        for a in range(3):
            lo[a] = boxes[s, a]
            hi[a] = boxes[s, 3 + a]
        if lo[0] > hi[0] or lo[1] > hi[1] or lo[2] > hi[2]:
            continue
        r2 = r * r
        out2 = r2 + _SLACK * (1.0 + r2)  # a block nearer than this may hold a voxel inside
        in2 = r2 - _SLACK * (1.0 + r2)  # a block within this holds only voxels inside
        for ib in range(lo[0] // B, hi[0] // B + 1):
            i0, i1 = max(lo[0], ib * B), min(hi[0], ib * B + B - 1)
            nx2, fx2 = _axis_span(grid_min[0], res, centers[s, 0], i0, i1)
            if nx2 > out2:
                continue
            for jb in range(lo[1] // B, hi[1] // B + 1):
                j0, j1 = max(lo[1], jb * B), min(hi[1], jb * B + B - 1)
                ny2, fy2 = _axis_span(grid_min[1], res, centers[s, 1], j0, j1)
                if nx2 + ny2 > out2:
                    continue
                h = math.sqrt(max(out2 - nx2 - ny2, 0.0))  # the half chord along z here, a voxel more each way
                kb0 = max(lo[2], int(math.floor((centers[s, 2] - h - grid_min[2]) / res - 1.5))) // B
                kb1 = min(hi[2], int(math.ceil((centers[s, 2] + h - grid_min[2]) / res + 0.5))) // B
                for kb in range(kb0, kb1 + 1):
                    if left[ib, jb, kb] == 0:
                        continue
                    klo, khi = max(lo[2], kb * B), min(hi[2], kb * B + B - 1)
                    nz2, fz2 = _axis_span(grid_min[2], res, centers[s, 2], klo, khi)
                    if nx2 + ny2 + nz2 > out2:  # no voxel centre of the block inside
                        continue
                    if fx2 + fy2 + fz2 < in2:  # every voxel centre of the block inside
                        for i in range(i0, i1 + 1):
                            for j in range(j0, j1 + 1):
                                for k in range(klo, khi + 1):
                                    if unsafe[i, j, k]:
                                        unsafe[i, j, k] = False
                                        left[ib, jb, kb] -= 1
                        continue
                    for k in range(klo, khi + 1):  # the sphere's surface crosses the block: per voxel
                        dz = grid_min[2] + (k + 0.5) * res - centers[s, 2]
                        dz2[k - klo] = dz * dz
                    for i in range(i0, i1 + 1):
                        dx = grid_min[0] + (i + 0.5) * res - centers[s, 0]
                        for j in range(j0, j1 + 1):
                            dy = grid_min[1] + (j + 0.5) * res - centers[s, 1]
                            dxy = dx * dx + dy * dy
                            if dxy > r2:
                                continue
                            for k in range(klo, khi + 1):  # the brute force's test, term for term
                                if unsafe[i, j, k] and dxy + dz2[k - klo] <= r2:
                                    unsafe[i, j, k] = False
                                    left[ib, jb, kb] -= 1
