"""The map the grasp is checked against: unknown and occupied space stay unsafe, except the
target's own volume, which the closing fingers must enter.

The map holds the target as occupied voxels and the space behind it as unknown, so with
"unknown is unsafe" no finger could ever close around it. `target_carve` marks safe the
voxels within `clearance` [m] of the target model's points (seen and symmetry-completed)
that are either unknown or occupied by the target (they contain one of its points or lie
inside the box its points span along its principal axes), and lie above its lowest point.
Occupied voxels without a target point (a neighbouring object, a wall, the shelf under the
target) stay unsafe; so does everything else the camera has not seen. The one assumption:
unknown space within `clearance` of the target is free, which the fingers' opening needs.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import CompassInputError
from ..mapping.distance import DistanceField, _clear_spheres, unsafe_mask
from ..mapping.occupancy import OccupancyMap, VoxelState
from .target import TargetModel


def target_carve(occ: OccupancyMap, target: TargetModel, clearance: float, own_radius: float = 0.0) -> np.ndarray:
    """(nx, ny, nz) bool mask of voxels to treat as safe around the target (module doc).
    own_radius [m]: an occupied voxel whose centre lies within it of a target point is the
    target's too (on a grid finer than the points' spacing a surface voxel may hold none)."""
    res = occ.resolution
    shape = np.asarray(occ.shape)
    lo = occ.world_to_voxel((target.points.min(0) - clearance - res)[None])[0]
    hi = occ.world_to_voxel((target.points.max(0) + clearance + res)[None])[0]
    lo, hi = np.clip(lo, 0, shape - 1), np.clip(hi, 0, shape - 1)
    mask = np.zeros(occ.shape, dtype=bool)
    axes = [np.arange(lo[a], hi[a] + 1) for a in range(3)]
    ijk = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    st = occ.state[ijk[:, 0], ijk[:, 1], ijk[:, 2]]
    keep = st != VoxelState.FREE  # only unknown or occupied voxels are ever carved
    ijk, st = ijk[keep], st[keep]
    centres = occ.voxel_to_world(ijk)
    near = centres[:, 2] >= target.bottom_z
    near[near] = cKDTree(target.points).query(centres[near], k=1, distance_upper_bound=clearance)[0] <= clearance
    has_point = np.zeros(occ.shape, dtype=bool)
    tv = occ.world_to_voxel(target.points)
    tv = tv[occ.in_grid(tv)]
    has_point[tv[:, 0], tv[:, 1], tv[:, 2]] = True
    proj = target.points @ target.axes
    mid = 0.5 * (proj.min(0) + proj.max(0))
    inside = np.all(np.abs(centres @ target.axes - mid) <= 0.5 * (proj.max(0) - proj.min(0)), axis=1)
    own = has_point[ijk[:, 0], ijk[:, 1], ijk[:, 2]] | inside
    if own_radius > 0.0 and len(centres):
        own |= cKDTree(target.points).query(centres, k=1, distance_upper_bound=own_radius)[0] <= own_radius
    ok = near & ((st == VoxelState.UNKNOWN) | ((st == VoxelState.OCCUPIED) & own))
    sel = ijk[ok]
    mask[sel[:, 0], sel[:, 1], sel[:, 2]] = True
    return mask


def grasp_unsafe(occ: OccupancyMap, target: TargetModel, clearance: float,
                 safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
                 extra_safe: np.ndarray | None = None) -> np.ndarray:
    """(nx, ny, nz) bool: unsafe space (unknown or occupied) less the target's carve, the
    robot's own volume (`safe_spheres` = (centres (S,3) [m], radii (S,) [m])) and any
    `extra_safe` voxels."""
    carve = target_carve(occ, target, clearance)
    if extra_safe is not None:
        carve |= np.asarray(extra_safe, dtype=bool)
    return unsafe_mask(occ, safe_voxels=carve, safe_spheres=safe_spheres)


def clear_spheres_box(mask: np.ndarray, origin: np.ndarray, resolution: float, centres: np.ndarray,
                      radii: np.ndarray) -> np.ndarray:
    """Set False in `mask` (a box of voxels, low corner origin (3,) [m]) every voxel whose
    centre lies inside a sphere (centres (S,3), radii (S,) [m]); spheres that cannot reach
    the box are skipped before the kernel. Returns mask."""
    c = np.ascontiguousarray(np.asarray(centres, dtype=np.float64).reshape(-1, 3))
    r = np.ascontiguousarray(np.asarray(radii, dtype=np.float64).reshape(-1))
    if len(c) != len(r) or not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r >= 0)):
        raise CompassInputError("safe spheres must be finite centres (S, 3) [m] and radii (S,) >= 0 [m]")
    hi = np.asarray(origin) + np.asarray(mask.shape) * resolution
    near = np.all((c + r[:, None] >= origin) & (c - r[:, None] <= hi), axis=1)
    _clear_spheres(mask, np.asarray(origin, dtype=np.float64), float(resolution), c[near], r[near])
    return mask


def grasp_unsafe_box(occ: OccupancyMap, target: TargetModel, clearance: float, a: np.ndarray, b: np.ndarray,
                     safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
                     extra_safe: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`grasp_unsafe` restricted to the map-voxel index box [a, b) (3,) (only that box is
    computed), with the robot's own space in it: (unsafe, robot_safe, carve) bool masks of
    the box's shape; robot_safe holds the voxels the spheres or `extra_safe` mark safe."""
    sl = tuple(slice(int(a[k]), int(b[k])) for k in range(3))
    carve = target_carve(occ, target, clearance)[sl]
    robot = np.zeros(carve.shape, dtype=bool)
    if extra_safe is not None:
        es = np.asarray(extra_safe, dtype=bool)
        if es.shape != occ.shape:
            raise CompassInputError(f"extra_safe has shape {es.shape}; the map's shape {occ.shape} is required")
        robot |= es[sl]
    if safe_spheres is not None:
        free = np.ones(carve.shape, dtype=bool)
        origin = occ.grid_min + np.asarray(a) * occ.resolution
        robot |= ~clear_spheres_box(free, origin, occ.resolution, safe_spheres[0], safe_spheres[1])
    unsafe = (occ.state[sl] != VoxelState.FREE) & ~carve & ~robot
    return unsafe, robot, carve


def grasp_field(occ: OccupancyMap, target: TargetModel, clearance: float,
                safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
                extra_safe: np.ndarray | None = None) -> DistanceField:
    """Distance field of `grasp_unsafe` on the map's grid."""
    return DistanceField.from_unsafe(grasp_unsafe(occ, target, clearance, safe_spheres, extra_safe),
                                     occ.grid_min, occ.resolution)


def local_fine_field(unsafe: np.ndarray, occ: OccupancyMap, lo: np.ndarray, hi: np.ndarray,
                     upsample: int) -> DistanceField:
    """The distance field of the unsafe mask (map grid) in the box lo..hi (3,) [m], on a grid
    `upsample` times finer: each unsafe voxel is split into upsample^3 unsafe sub-voxels (the
    same cubes), so a checker's bound loses half a fine voxel diagonal instead of half a map
    voxel diagonal. Unsafe voxels outside the box are not seen by the field (it is meant for
    points well inside the box); points outside the box are unsafe."""
    if isinstance(upsample, bool) or not isinstance(upsample, int) or not 1 <= upsample <= 4:
        raise CompassInputError(f"upsample {upsample!r} is not allowed; use an integer 1..4")
    shape = np.asarray(unsafe.shape)
    a = np.clip(occ.world_to_voxel(np.asarray(lo, dtype=np.float64)[None])[0], 0, shape - 1)
    b = np.clip(occ.world_to_voxel(np.asarray(hi, dtype=np.float64)[None])[0], 0, shape - 1) + 1
    sub = unsafe[a[0]:b[0], a[1]:b[1], a[2]:b[2]]
    fine = sub.repeat(upsample, 0).repeat(upsample, 1).repeat(upsample, 2)
    origin = occ.grid_min + a * occ.resolution
    return DistanceField.from_unsafe(fine, origin, occ.resolution / upsample)
