"""Environment geometry for collision checking, with numba distance kernels.

`PrimitiveSet`: known obstacles (oriented boxes, spheres, capped cylinders). All poses are
world frame, lengths [m]; a cylinder's axis is its local z, `half_length` half its height.
Distances are signed: negative inside a primitive. `DistanceGrid`: the map's Euclidean
distance field of unsafe space, with a conservative lookup (`grid_clearance`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from ..errors import CompassInputError, float_array, points_array, real_number
from ..geometry import check_rigid


@dataclass(frozen=True, eq=False)
class PrimitiveSet:
    """Obstacles as arrays. box_R (B,3,3) / box_t (B,3): pose of each box centre in the world,
    box_half (B,3) half extents; sphere_c (M,3), sphere_r (M,); cyl_R (C,3,3) / cyl_t (C,3)
    pose of each cylinder centre (axis = local z), cyl_r (C,) radius, cyl_h (C,) half length."""

    box_R: np.ndarray
    box_t: np.ndarray
    box_half: np.ndarray
    sphere_c: np.ndarray
    sphere_r: np.ndarray
    cyl_R: np.ndarray
    cyl_t: np.ndarray
    cyl_r: np.ndarray
    cyl_h: np.ndarray

    @classmethod
    def from_lists(cls, boxes=(), spheres=(), cylinders=()) -> "PrimitiveSet":
        """boxes: [(T_world_box 4x4, half_extents (3,))]; spheres: [(center (3,), radius)];
        cylinders: [(T_world_cyl 4x4, radius, half_length)]. Anything else raises
        CompassInputError naming the list and the item."""
        try:
            return cls._from_lists(boxes, spheres, cylinders)
        except CompassInputError:
            raise
        except (TypeError, ValueError) as exc:  # not lists of tuples of numbers
            raise CompassInputError(
                "primitives must be lists boxes=[(T 4x4, half extents (3,))], spheres=[(centre (3,), radius)], "
                f"cylinders=[(T 4x4, radius, half_length)] [m]; got an item that is not ({exc})") from exc

    @classmethod
    def _from_lists(cls, boxes, spheres, cylinders) -> "PrimitiveSet":
        bR, bt, bh = [], [], []
        for i, (T, h) in enumerate(boxes):
            T = check_rigid(T, f"boxes[{i}] pose")
            h = float_array(h, f"boxes[{i}] half extents", "3 numbers [m]")
            if h.shape != (3,) or not np.all(np.isfinite(h)) or np.any(h <= 0):
                raise CompassInputError(f"boxes[{i}] half extents {h} must be 3 finite values > 0 [m]")
            bR.append(T[:3, :3])
            bt.append(T[:3, 3])
            bh.append(h)
        sc, sr = [], []
        for i, (c, r) in enumerate(spheres):
            c = float_array(c, f"spheres[{i}] centre", "3 numbers [m]")
            r = real_number(r, f"spheres[{i}] radius", "a finite radius > 0 [m]")
            if c.shape != (3,) or not np.all(np.isfinite(c)) or not r > 0:
                raise CompassInputError(f"spheres[{i}] needs a finite centre (3,) [m] and radius > 0 [m]")
            sc.append(c)
            sr.append(float(r))
        cR, ct, cr, ch = [], [], [], []
        for i, (T, r, h) in enumerate(cylinders):
            T = check_rigid(T, f"cylinders[{i}] pose")
            r = real_number(r, f"cylinders[{i}] radius", "a finite radius > 0 [m]")
            h = real_number(h, f"cylinders[{i}] half_length", "a finite half length > 0 [m]")
            if not (r > 0 and h > 0):
                raise CompassInputError(f"cylinders[{i}] radius {r} and half_length {h} must be > 0 [m]")
            cR.append(T[:3, :3])
            ct.append(T[:3, 3])
            cr.append(float(r))
            ch.append(float(h))

        def arr(x, shape):
            return np.ascontiguousarray(np.array(x, np.float64).reshape(shape))

        return cls(
            arr(bR, (-1, 3, 3)), arr(bt, (-1, 3)), arr(bh, (-1, 3)),
            arr(sc, (-1, 3)), arr(sr, (-1,)),
            arr(cR, (-1, 3, 3)), arr(ct, (-1, 3)), arr(cr, (-1,)), arr(ch, (-1,)),
        )

    @classmethod
    def from_shapes(cls, items, floor_z: float | None = None, floor_half: float = 3.0) -> "PrimitiveSet":
        """From records with `shape` ('box' | 'cylinder' | 'sphere'), `size` (box half extents;
        cylinder radius, half height; sphere radius) [m], `pos` centre [m] and `yaw` [rad] about
        world z (e.g. the simulator's scene primitives). floor_z [m]: add a 0.1 m thick floor
        slab with its top at that height (half size floor_half [m] in x and y)."""
        boxes, spheres, cylinders = [], [], []
        for it in items:
            c, s = np.cos(it.yaw), np.sin(it.yaw)
            T = np.eye(4)
            T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
            T[:3, 3] = it.pos
            if it.shape == "box":
                boxes.append((T, it.size))
            elif it.shape == "cylinder":
                cylinders.append((T, it.size[0], it.size[1]))
            elif it.shape == "sphere":
                spheres.append((np.asarray(it.pos, np.float64), it.size[0]))
            else:
                raise CompassInputError(f"shape {it.shape!r} is not one of box, cylinder, sphere")
        if floor_z is not None:
            T = np.eye(4)
            T[:3, 3] = [0.0, 0.0, floor_z - 0.05]
            boxes.append((T, [floor_half, floor_half, 0.05]))
        return cls.from_lists(boxes=boxes, spheres=spheres, cylinders=cylinders)

    @classmethod
    def empty(cls) -> "PrimitiveSet":
        return cls.from_lists()

    def merged(self, other: "PrimitiveSet") -> "PrimitiveSet":
        """Union of two sets."""
        pairs = zip(self.arrays(), other.arrays())
        return PrimitiveSet(*(np.ascontiguousarray(np.concatenate([a, b])) for a, b in pairs))

    def arrays(self) -> tuple:
        """The arrays in kernel argument order."""
        return (self.box_R, self.box_t, self.box_half, self.sphere_c, self.sphere_r,
                self.cyl_R, self.cyl_t, self.cyl_r, self.cyl_h)

    @property
    def n_primitives(self) -> int:
        return self.box_t.shape[0] + self.sphere_c.shape[0] + self.cyl_t.shape[0]

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance [m] of each world point (N,3) to the nearest primitive (inf if none)."""
        P = np.ascontiguousarray(points_array(points, "points"), dtype=np.float64)
        return _distances_kernel(P, self.arrays())


@nb.njit(cache=True, inline="always")
def box_distance(p, R, t, half):
    """Signed distance [m] from world point p to an oriented box (centre t, rotation R)."""
    dx, dy, dz = p[0] - t[0], p[1] - t[1], p[2] - t[2]
    out2 = 0.0
    inside = -np.inf
    for a in range(3):
        local = R[0, a] * dx + R[1, a] * dy + R[2, a] * dz
        e = abs(local) - half[a]
        if e > 0.0:
            out2 += e * e
        inside = max(inside, e)
    if out2 > 0.0:
        return np.sqrt(out2)
    return inside


@nb.njit(cache=True, inline="always")
def cylinder_distance(p, R, t, radius, half_length):
    """Signed distance [m] from world point p to a capped cylinder (axis = local z)."""
    dx, dy, dz = p[0] - t[0], p[1] - t[1], p[2] - t[2]
    x = R[0, 0] * dx + R[1, 0] * dy + R[2, 0] * dz
    y = R[0, 1] * dx + R[1, 1] * dy + R[2, 1] * dz
    z = R[0, 2] * dx + R[1, 2] * dy + R[2, 2] * dz
    er = np.sqrt(x * x + y * y) - radius
    ez = abs(z) - half_length
    if er > 0.0 or ez > 0.0:
        return np.sqrt(max(er, 0.0) ** 2 + max(ez, 0.0) ** 2)
    return max(er, ez)


@nb.njit(cache=True, inline="always")
def primitives_distance(p, prims, stop_below):
    """Signed distance [m] from p to the nearest primitive (inf if none). Returns early, with
    some value < stop_below, as soon as one primitive is closer than stop_below."""
    box_R, box_t, box_half, sphere_c, sphere_r, cyl_R, cyl_t, cyl_r, cyl_h = prims
    best = np.inf
    for i in range(box_t.shape[0]):
        best = min(best, box_distance(p, box_R[i], box_t[i], box_half[i]))
        if best < stop_below:
            return best
    for i in range(sphere_c.shape[0]):
        d = np.sqrt((p[0] - sphere_c[i, 0]) ** 2 + (p[1] - sphere_c[i, 1]) ** 2 + (p[2] - sphere_c[i, 2]) ** 2)
        best = min(best, d - sphere_r[i])
        if best < stop_below:
            return best
    for i in range(cyl_t.shape[0]):
        best = min(best, cylinder_distance(p, cyl_R[i], cyl_t[i], cyl_r[i], cyl_h[i]))
        if best < stop_below:
            return best
    return best


@nb.njit(cache=True)
def _distances_kernel(P, prims):
    """`primitives_distance` of each point of P (N,3) with no early stop, in one compiled loop
    (the same arithmetic per point as calling it point by point from Python, ~100 x faster:
    the aiming of level 4's obstacles measures thousands of sphere centres per draw)."""
    out = np.empty(P.shape[0])
    for i in range(P.shape[0]):
        out[i] = primitives_distance(P[i], prims, -np.inf)
    return out


@dataclass(frozen=True, eq=False)
class DistanceGrid:
    """Euclidean distance field of unsafe space on a dense voxel grid.

    dist (X,Y,Z) float32 [m]: distance from each voxel centre to the nearest unsafe voxel
    centre (0 in unsafe voxels), e.g. `scipy.ndimage.distance_transform_edt(~unsafe) * res`;
    origin (3,) [m]: world position of the minimum corner of voxel (0,0,0); resolution [m]:
    voxel edge. Voxel (i,j,k) has its centre at origin + (i+0.5, j+0.5, k+0.5) * resolution.
    """

    dist: np.ndarray
    origin: np.ndarray
    resolution: float

    def __post_init__(self) -> None:
        d = self.dist
        if not (isinstance(d, np.ndarray) and d.dtype == np.float32):  # a float32 field is taken as it is
            d = float_array(d, "DistanceGrid.dist", "an (X, Y, Z) array [m]")
        d = np.ascontiguousarray(d, dtype=np.float32)
        if d.ndim != 3 or min(d.shape) < 1:
            raise CompassInputError(f"DistanceGrid.dist must be a non-empty (X,Y,Z) array, got {d.shape}")
        o = float_array(self.origin, "DistanceGrid.origin", "3 numbers [m]")
        if o.shape != (3,) or not np.all(np.isfinite(o)):
            raise CompassInputError(f"DistanceGrid.origin must be 3 finite values [m], got {self.origin}")
        if not real_number(self.resolution, "DistanceGrid.resolution", "a finite value > 0 [m]") > 0:
            raise CompassInputError(f"DistanceGrid.resolution {self.resolution} m must be > 0")
        object.__setattr__(self, "dist", d)
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "resolution", float(self.resolution))

    @classmethod
    def from_distance_field(cls, field) -> "DistanceGrid":
        """From `mapping.distance.DistanceField` (or any object with `distances`, `grid_min`
        (minimum corner [m]) and `resolution` [m] of the same meaning)."""
        return cls(field.distances, field.grid_min, field.resolution)

    @classmethod
    def from_unsafe_mask(cls, unsafe: np.ndarray, origin: np.ndarray, resolution: float) -> "DistanceGrid":
        """Euclidean distance transform of a boolean (X,Y,Z) mask of unsafe voxels."""
        from scipy.ndimage import distance_transform_edt

        unsafe = np.asarray(unsafe, bool)
        if not unsafe.any():
            return cls(np.full(unsafe.shape, np.inf, np.float32), origin, resolution)
        return cls(distance_transform_edt(~unsafe, sampling=resolution).astype(np.float32), origin, resolution)


@nb.njit(cache=True, inline="always")
def grid_clearance(p, grid, half_diag):
    """Lower bound [m] on the distance from world point p to unsafe space of the grid.

    For any voxel v, d(p, unsafe) >= dist[v] - |p - centre(v)| - half_diag (the field is
    1-Lipschitz; half_diag accounts for unsafe voxels being cubes). v is the voxel containing
    p. Outside the grid: -inf (unsafe), or with outside_free the bound at the nearest voxel,
    raised to the distance from p to the grid box (all unsafe voxels lie inside it).
    """
    dist, origin, res, active, outside_free = grid
    if not active:
        return np.inf
    nx, ny, nz = dist.shape
    fi = (p[0] - origin[0]) / res - 0.5
    fj = (p[1] - origin[1]) / res - 0.5
    fk = (p[2] - origin[2]) / res - 0.5
    i, j, k = int(np.floor(fi + 0.5)), int(np.floor(fj + 0.5)), int(np.floor(fk + 0.5))
    box = 0.0
    if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
        if not outside_free:
            return -np.inf
        i, j, k = min(max(i, 0), nx - 1), min(max(j, 0), ny - 1), min(max(k, 0), nz - 1)
        ex = max(0.0, -fi - 0.5, fi + 0.5 - nx)
        ey = max(0.0, -fj - 0.5, fj + 0.5 - ny)
        ez = max(0.0, -fk - 0.5, fk + 0.5 - nz)
        box = np.sqrt(ex * ex + ey * ey + ez * ez) * res
    off = np.sqrt((fi - i) ** 2 + (fj - j) ** 2 + (fk - k) ** 2) * res
    return max(dist[i, j, k] - off - half_diag, box)
