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
from ..mapping.distance import DistanceField, unsafe_mask
from ..mapping.occupancy import OccupancyMap, VoxelState
from .target import TargetModel


def target_carve(occ: OccupancyMap, target: TargetModel, clearance: float) -> np.ndarray:
    """(nx, ny, nz) bool mask of voxels to treat as safe around the target (module doc)."""
    res = occ.resolution
    shape = np.asarray(occ.shape)
    lo = occ.world_to_voxel((target.points.min(0) - clearance - res)[None])[0]
    hi = occ.world_to_voxel((target.points.max(0) + clearance + res)[None])[0]
    lo, hi = np.clip(lo, 0, shape - 1), np.clip(hi, 0, shape - 1)
    mask = np.zeros(occ.shape, dtype=bool)
    axes = [np.arange(lo[a], hi[a] + 1) for a in range(3)]
    ijk = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    centres = occ.voxel_to_world(ijk)
    near = cKDTree(target.points).query(centres, k=1, distance_upper_bound=clearance)[0] <= clearance
    near &= centres[:, 2] >= target.bottom_z
    st = occ.state[ijk[:, 0], ijk[:, 1], ijk[:, 2]]
    has_point = np.zeros(occ.shape, dtype=bool)
    tv = occ.world_to_voxel(target.points)
    tv = tv[occ.in_grid(tv)]
    has_point[tv[:, 0], tv[:, 1], tv[:, 2]] = True
    proj = target.points @ target.axes
    mid = 0.5 * (proj.min(0) + proj.max(0))
    inside = np.all(np.abs(centres @ target.axes - mid) <= 0.5 * (proj.max(0) - proj.min(0)), axis=1)
    own = has_point[ijk[:, 0], ijk[:, 1], ijk[:, 2]] | inside
    ok = near & ((st == VoxelState.UNKNOWN) | ((st == VoxelState.OCCUPIED) & own))
    sel = ijk[ok]
    mask[sel[:, 0], sel[:, 1], sel[:, 2]] = True
    return mask


def grasp_field(occ: OccupancyMap, target: TargetModel, clearance: float,
                safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
                extra_safe: np.ndarray | None = None, upsample: int = 1) -> DistanceField:
    """Distance field of unsafe space with the target carved (and the robot's own volume,
    `safe_spheres` = (centres (S,3) [m], radii (S,) [m]), and any `extra_safe` voxels).

    upsample k > 1: the field is computed on a grid k times finer (each unsafe voxel split
    into k^3 unsafe sub-voxels, so the unsafe space is the same cubes). A checker's
    conservative bound (distance at the nearest grid centre minus the offset to it) then
    loses at most half a fine voxel diagonal instead of half a map voxel diagonal: at
    1 cm voxels the difference is the centimetre the certified scenes leave around the hand."""
    carve = target_carve(occ, target, clearance)
    if extra_safe is not None:
        carve |= np.asarray(extra_safe, dtype=bool)
    if upsample == 1:
        return DistanceField.from_map(occ, safe_voxels=carve, safe_spheres=safe_spheres)
    if not isinstance(upsample, int) or not 1 <= upsample <= 4:
        raise CompassInputError(f"upsample {upsample!r} is not allowed; use an integer 1..4")
    unsafe = unsafe_mask(occ, safe_voxels=carve, safe_spheres=safe_spheres)
    fine = unsafe.repeat(upsample, 0).repeat(upsample, 1).repeat(upsample, 2)
    return DistanceField.from_unsafe(fine, occ.grid_min, occ.resolution / upsample)
