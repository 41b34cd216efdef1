"""Volumetric information of a view (Isler, Sabzevari, Delmerico, Scaramuzza, ICRA 2016).

A view casts a grid of rays (`mapping.infogain.camera_ray_directions`) from the camera
centre up to `max_range` [m] through the occupancy map (3-D DDA, `mapping.raycast`
conventions). As in the authors' implementation, information is summed ray by ray over
the voxels each ray traverses (a voxel crossed by two rays counts twice), and only voxels
inside the region of interest (ROI mask) contribute; voxels outside it still occlude.

Formulations (`IGFormulation`):

* UNOBSERVED: Isler's "unobserved voxel" count: I(x) = 1 for an unknown voxel, 0 otherwise;
  a ray stops at its first occupied voxel.
* OCCLUSION_AWARE: entropy weighted by visibility: I(x) = P_v(x) H(x), with H the binary
  entropy [bit] of the voxel's occupancy probability P_o (from its log-odds; unknown voxels
  get `p_unknown`) and P_v(x) = prod over the voxels before x on the ray of (1 - P_o). The
  ray continues through occupied voxels (their P_o makes later voxels nearly invisible) and
  stops when P_v < `min_visibility`. Outside the ROI only voxels held occupied occlude
  (P_o from their log-odds; free and unknown voxels there count as P_o = 0): Isler et
  al.'s map covers only the object's bounding box, and unknown space between the camera
  and the confined space would otherwise hide every voxel of the ROI.
"""
from __future__ import annotations

import enum
import math

import numpy as np
from numba import njit, prange

from ..mapping.infogain import camera_ray_directions
from ..mapping.occupancy import OccupancyMap
from ..mapping.raycast import OCCUPIED, UNKNOWN, ray_setup


class IGFormulation(enum.Enum):
    UNOBSERVED = "unobserved-voxel"
    OCCLUSION_AWARE = "occlusion-aware"


def binary_entropy(p: np.ndarray) -> np.ndarray:
    """H(p) [bit] = -p log2 p - (1 - p) log2 (1 - p) (0 at p = 0 or 1)."""
    p = np.clip(np.asarray(p, float), 1e-12, 1 - 1e-12)
    return -(p * np.log2(p) + (1 - p) * np.log2(1 - p))


@njit(cache=True, inline="always")
def _entropy(p):
    if p <= 0.0 or p >= 1.0:
        return 0.0
    return -(p * math.log2(p) + (1.0 - p) * math.log2(1.0 - p))


@njit(cache=True, parallel=True)
def _view_information(state, logodds, roi, origins, R, dirs, max_range, k0, res, occlusion_aware, p_unknown,
                      min_visibility):
    nx, ny, nz = state.shape
    M = origins.shape[0]
    out = np.zeros(M)
    inv = 1.0 / res
    for m in prange(M):
        ox, oy, oz = origins[m, 0], origins[m, 1], origins[m, 2]
        gx, gy, gz = ox * inv - k0[0], oy * inv - k0[1], oz * inv - k0[2]
        total = 0.0
        for r in range(dirs.shape[0]):
            dx = R[m, 0, 0] * dirs[r, 0] + R[m, 0, 1] * dirs[r, 1] + R[m, 0, 2] * dirs[r, 2]
            dy = R[m, 1, 0] * dirs[r, 0] + R[m, 1, 1] * dirs[r, 1] + R[m, 1, 2] * dirs[r, 2]
            dz = R[m, 2, 0] * dirs[r, 0] + R[m, 2, 1] * dirs[r, 1] + R[m, 2, 2] * dirs[r, 2]
            ex, ey, ez = ox + max_range * dx, oy + max_range * dy, oz + max_range * dz
            ok, ix, iy, iz, sx, sy, sz, tmx, tmy, tmz, tdx, tdy, tdz, n_steps = ray_setup(
                gx, gy, gz, ex * inv - k0[0], ey * inv - k0[1], ez * inv - k0[2],
                int(math.floor(ex * inv)) - k0[0], int(math.floor(ey * inv)) - k0[1],
                int(math.floor(ez * inv)) - k0[2], nx, ny, nz)
            if not ok:
                continue
            vis = 1.0
            for _ in range(n_steps):
                s = state[ix, iy, iz]
                if occlusion_aware:
                    inside = roi[ix, iy, iz]
                    if s == UNKNOWN:
                        p = p_unknown if inside else 0.0
                    elif inside or s == OCCUPIED:
                        p = 1.0 / (1.0 + math.exp(-logodds[ix, iy, iz]))
                    else:
                        p = 0.0
                    if inside:
                        total += vis * _entropy(p)
                    vis *= 1.0 - p
                    if vis < min_visibility:
                        break
                else:
                    if s == OCCUPIED:
                        break
                    if s == UNKNOWN and roi[ix, iy, iz]:
                        total += 1.0
                if tmx < tmy:
                    if tmx < tmz:
                        ix += sx
                        tmx += tdx
                    else:
                        iz += sz
                        tmz += tdz
                else:
                    if tmy < tmz:
                        iy += sy
                        tmy += tdy
                    else:
                        iz += sz
                        tmz += tdz
                if ix < 0 or ix >= nx or iy < 0 or iy >= ny or iz < 0 or iz >= nz:
                    break
        out[m] = total
    return out


def roi_mask(occ: OccupancyMap, box_min: np.ndarray, box_max: np.ndarray) -> np.ndarray:
    """(nx, ny, nz) bool: voxels whose centres lie in the world box [m]."""
    c = occ.voxel_centers()
    return np.all((c >= np.asarray(box_min, float)) & (c <= np.asarray(box_max, float)), axis=-1)


def view_information(occ: OccupancyMap, roi: np.ndarray, T_world_cams: np.ndarray, K: np.ndarray,
                     max_range: float, rays: tuple[int, int], formulation: IGFormulation,
                     p_unknown: float = 0.5, min_visibility: float = 1e-3) -> np.ndarray:
    """Information (M,) of camera poses T_world_cams (M, 4, 4) under `formulation`: unknown
    voxels (UNOBSERVED) or bits (OCCLUSION_AWARE) summed over the rays (see module doc)."""
    T = np.asarray(T_world_cams, float).reshape(-1, 4, 4)
    dirs = camera_ray_directions(K, rays)
    return _view_information(occ.state, occ.logodds, np.ascontiguousarray(roi, dtype=np.bool_),
                             np.ascontiguousarray(T[:, :3, 3]), np.ascontiguousarray(T[:, :3, :3]), dirs,
                             float(max_range), occ.grid_key_min, occ.resolution,
                             formulation is IGFormulation.OCCLUSION_AWARE, float(p_unknown), float(min_visibility))
