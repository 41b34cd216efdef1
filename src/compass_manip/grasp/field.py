"""The distance field a grasp selection checks against: fine near the target, cheap elsewhere.

One grid `upsample` times finer than the map covers a box holding the robot as it stands
and the target (outside it is unsafe), so the whole-arm validity checker and the rigid-hand
checks share it. Only an inner box around the target gets an exact fine transform; the
rest of the grid takes a bound derived from the map-resolution transform:

* outer cells: v(c) = D(C) - |c - c_C| - h_map + h_fine, with C the map voxel holding the
  fine cell c, D(C) the map-grid distance from C's centre to the nearest unsafe centre and
  h the half voxel diagonals. A checker that subtracts |p - c| + h_fine from v(c) (every
  user here does: `hand_clear`, `ValidityChecker`'s grid bound) then subtracts at least
  |p - c_C| + h_map from D(C), which is the map grid's own sound bound.
* inner cells: min(d_in(c), max(b(c) + h_fine, v(c))): d_in the exact distance to the
  fine unsafe voxels inside the inner box, b(c) the distance from c to the inner box's
  outside (every unsafe voxel outside the inner box is at least that far), v(c) as above.

The inner unsafe voxels are the map's unsafe voxels split into fine ones, or, with a fine
local occupancy map integrated from the same depth frames (`fine_unsafe`), its own 5 mm
labels: a fine voxel seen free is safe, one seen occupied unsafe (unless it is the target's
or the robot's own space), and an unseen one keeps the map's label.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..errors import CompassInputError
from ..mapping.distance import DistanceField, _distances
from ..mapping.observe import integrate_observation
from ..mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from .carve import target_carve


def upsample_mask(mask: np.ndarray, u: int) -> np.ndarray:
    """Each voxel of a 3-D mask split into u^3 voxels of the same value."""
    return mask.repeat(u, 0).repeat(u, 1).repeat(u, 2)


def coarse_distances(unsafe: np.ndarray, resolution: float) -> np.ndarray:
    """The map-grid distances [m] of an unsafe mask (outside it unsafe): as
    `DistanceField.from_unsafe(unsafe, ..., resolution).distances`, with the cache-friendly
    transform (`mapping.distance._distances`)."""
    return _distances(np.pad(np.asarray(unsafe, dtype=bool), 1, constant_values=True),
                           float(resolution))[1:-1, 1:-1, 1:-1]


def checked_field(unsafe: np.ndarray, origin: np.ndarray, resolution: float, inner_a: np.ndarray,
                  inner_b: np.ndarray, upsample: int, fine_unsafe: np.ndarray | None = None,
                  safe_spheres: tuple[np.ndarray, np.ndarray] | None = None,
                  more_boxes: tuple = (), coarse: np.ndarray | None = None) -> DistanceField:
    """The composite field (module doc) on a grid `upsample` times finer than `unsafe`.

    unsafe (nx, ny, nz) bool on the map grid, its low corner at origin (3,) [m], voxel edge
    resolution [m]; inner_a / inner_b (3,) map-voxel index range [a, b) of the inner box;
    fine_unsafe: the inner box's fine unsafe voxels (default: `unsafe` there, split), which
    must lie in map voxels outside safe_spheres; more_boxes: further (a, b) index ranges
    computed exactly from `unsafe` split, or (a, b, fine unsafe cells of that box, the same
    conditions as fine_unsafe) (each overlays the field built so far: its outside is
    bounded by that field); safe_spheres (centres (S,3), radii (S,) [m]):
    spheres whose map voxels were all made safe (the robot as it stands): every unsafe
    map-voxel centre is farther than R from such a sphere's centre, so no fine unsafe
    centre is nearer than R - |c - c_s| - (h_map - h_fine) to a fine centre c; that bound
    raises the field where it is larger. coarse: `coarse_distances(unsafe, resolution)` when
    the caller has it already (a second field on the same mask)."""
    if isinstance(upsample, bool) or not isinstance(upsample, int) or not 1 <= upsample <= 4:
        raise CompassInputError(f"upsample {upsample!r} is not allowed; use an integer 1..4")
    shape = np.asarray(unsafe.shape)
    if coarse is None:
        coarse = coarse_distances(unsafe, resolution)
    elif coarse.shape != unsafe.shape:
        raise CompassInputError(f"coarse has shape {coarse.shape}; the mask's shape {unsafe.shape} is required")
    fine_res = resolution / upsample
    out = None
    for n, box in enumerate([(inner_a, inner_b, fine_unsafe)] + list(more_boxes)):
        a = np.clip(np.asarray(box[0], dtype=np.int64), 0, shape)
        b = np.clip(np.asarray(box[1], dtype=np.int64), a, shape)
        fu = box[2] if len(box) > 2 else None
        if fu is None:
            fu = upsample_mask(unsafe[a[0]:b[0], a[1]:b[1], a[2]:b[2]], upsample)
        if fu.shape != tuple(upsample * (b - a)):
            raise CompassInputError(f"fine_unsafe has shape {fu.shape}; the inner box needs "
                                    f"{tuple(int(x) for x in upsample * (b - a))}")
        if fu.size and fu.any():
            d_in = _distances(fu, fine_res)
        else:
            d_in = np.full(fu.shape, np.inf, np.float32)
        if out is None:
            out = _compose(coarse, d_in, a * upsample, upsample, float(resolution))
        else:
            _overlay(out, d_in, a * upsample, fine_res)
    if safe_spheres is not None:
        h = 0.5 * math.sqrt(3.0) * (resolution - fine_res)
        _raise_in_spheres(out, np.asarray(origin, dtype=np.float64), fine_res,
                          np.ascontiguousarray(np.asarray(safe_spheres[0], dtype=np.float64).reshape(-1, 3)),
                          np.ascontiguousarray(np.asarray(safe_spheres[1], dtype=np.float64).reshape(-1)), h)
    return DistanceField(out, origin, fine_res)


@njit(cache=True, parallel=True)
def _overlay(out, d_in, ia, fres):
    """out <- min(d_in, max(b + h_fine, out)) inside the box at fine index ia (module doc)."""
    h_fine = 0.5 * math.sqrt(3.0) * fres
    mx, my, mz = d_in.shape
    for li in prange(mx):
        for lj in range(my):
            for lk in range(mz):
                bnd = min(li + 0.5, mx - li - 0.5, lj + 0.5, my - lj - 0.5, lk + 0.5, mz - lk - 0.5) * fres
                I, J, K = li + ia[0], lj + ia[1], lk + ia[2]
                out[I, J, K] = min(d_in[li, lj, lk], max(bnd + h_fine, out[I, J, K]))


@njit(cache=True, parallel=True)
def _raise_in_spheres(out, origin, res, centres, radii, h):
    """out <- max(out, R - |c - c_s| - h) inside each sphere; in parallel over x slices, each
    slice taking every sphere (max is exact and order-free: the same field as one by one)."""
    nx, ny, nz = out.shape
    S = centres.shape[0]
    lo = np.empty((S, 3), np.int64)
    hi = np.empty((S, 3), np.int64)
    n = np.array([nx, ny, nz])
    for s in range(S):
        for a in range(3):
            lo[s, a] = max(int(math.floor((centres[s, a] - radii[s] - origin[a]) / res)), 0)
            hi[s, a] = min(int(math.ceil((centres[s, a] + radii[s] - origin[a]) / res)), n[a] - 1)
    for i in prange(nx):
        for s in range(S):
            if i < lo[s, 0] or i > hi[s, 0]:
                continue
            R = radii[s]
            dx = origin[0] + (i + 0.5) * res - centres[s, 0]
            for j in range(lo[s, 1], hi[s, 1] + 1):
                dy = origin[1] + (j + 0.5) * res - centres[s, 1]
                for k in range(lo[s, 2], hi[s, 2] + 1):
                    dz = origin[2] + (k + 0.5) * res - centres[s, 2]
                    v = R - math.sqrt(dx * dx + dy * dy + dz * dz) - h
                    if v > out[i, j, k]:
                        out[i, j, k] = v


@njit(cache=True, parallel=True)
def _compose(coarse, d_in, ia, u, res):
    """The composite field (module doc) of the map-grid distances coarse and the inner box's
    exact distances d_in at fine index ia, written row by row of the fine grid (each fine
    cell the same expression as cell by cell under each map voxel)."""
    nx, ny, nz = coarse.shape
    fres = res / u
    h_map = 0.5 * math.sqrt(3.0) * res
    h_fine = 0.5 * math.sqrt(3.0) * fres
    off = np.empty(u)
    for t in range(u):
        off[t] = (((t + 0.5) / u - 0.5) * res) ** 2
    rad = np.empty((u, u, u))  # each fine centre's distance to its map voxel's centre
    for ti in range(u):
        for tj in range(u):
            for tk in range(u):
                rad[ti, tj, tk] = math.sqrt(off[ti] + off[tj] + off[tk])
    out = np.empty((nx * u, ny * u, nz * u), np.float32)
    mx, my, mz = d_in.shape
    for I in prange(nx * u):
        ci, ti = I // u, I % u
        li = I - ia[0]
        for J in range(ny * u):
            cj, tj = J // u, J % u
            lj = J - ia[1]
            inner = 0 <= li < mx and 0 <= lj < my  # the row crosses the inner box
            for ck in range(nz):
                base = coarse[ci, cj, ck] - h_map + h_fine
                for tk in range(u):
                    K = ck * u + tk
                    v = base - rad[ti, tj, tk]
                    if v < 0.0:
                        v = 0.0
                    if inner:
                        lk = K - ia[2]
                        if 0 <= lk < mz:
                            bnd = min(li + 0.5, mx - li - 0.5, lj + 0.5, my - lj - 0.5,
                                      lk + 0.5, mz - lk - 0.5) * fres
                            v = min(d_in[li, lj, lk], max(bnd + h_fine, v))
                    out[I, J, K] = v
    return out


def local_fine_map(occ: OccupancyMap, lo: np.ndarray, hi: np.ndarray, upsample: int = 2) -> OccupancyMap:
    """An empty occupancy map `upsample` times finer than `occ` over the box lo..hi (3,) [m],
    snapped outwards to occ's voxels (so each fine voxel lies in one map voxel), with occ's
    sensor model. Integrate the same depth frames into it as into occ."""
    if isinstance(upsample, bool) or not isinstance(upsample, int) or not 1 <= upsample <= 4:
        raise CompassInputError(f"upsample {upsample!r} is not allowed; use an integer 1..4")
    res = occ.resolution
    a = np.clip(occ.world_to_voxel(np.asarray(lo, dtype=np.float64)[None])[0], 0, np.asarray(occ.shape) - 1)
    b = np.clip(occ.world_to_voxel(np.asarray(hi, dtype=np.float64)[None])[0], 0, np.asarray(occ.shape) - 1) + 1
    c = occ.config
    cfg = MapConfig(box_min=tuple(occ.grid_min + a * res), box_max=tuple(occ.grid_min + b * res),
                    resolution=res / upsample, prob_hit=c.prob_hit, prob_miss=c.prob_miss, clamp_min=c.clamp_min,
                    clamp_max=c.clamp_max, occupancy_threshold=c.occupancy_threshold,
                    pixel_stride=c.pixel_stride, ray_grouping=c.ray_grouping, surface_guard=c.surface_guard,
                    sticky_hits=c.sticky_hits)
    fine = OccupancyMap(cfg)
    if fine.shape != tuple(upsample * (b - a)) or not np.allclose(fine.grid_min, occ.grid_min + a * res):
        raise CompassInputError("the fine map's grid does not align with the map's voxels")
    return fine


class FineMaps:
    """`local_fine_map`s of `occ`'s depth frames kept per box: `get(lo, hi, upsample, frames)`
    integrates into the box's map only the frames (a list in order, growing) it has not yet
    taken, so it equals integrating all of them afresh (frames go in in order); spheres: the
    robot model of the self filter; max_range [m] of the sensor."""

    def __init__(self, occ: OccupancyMap, spheres, max_range: float) -> None:
        self.occ, self.spheres, self.max_range = occ, spheres, float(max_range)
        self._maps: dict = {}  # (lo, hi, upsample) -> [fine map, frames integrated into it]

    def get(self, lo: np.ndarray, hi: np.ndarray, upsample: int, frames: list) -> OccupancyMap:
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        key = (tuple(np.round(lo, 9)), tuple(np.round(hi, 9)), int(upsample))
        if key not in self._maps:
            self._maps[key] = [local_fine_map(self.occ, lo, hi, upsample), 0]
        entry = self._maps[key]
        for obs in frames[entry[1]:]:
            integrate_observation(entry[0], obs, self.spheres, self.max_range)
        entry[1] = len(frames)
        return entry[0]


def fine_map_range(occ: OccupancyMap, fine: OccupancyMap) -> tuple[np.ndarray, np.ndarray, int]:
    """(a, b, upsample): the map-voxel index range [a, b) a fine map covers and its factor."""
    u = int(round(occ.resolution / fine.resolution))
    a = np.rint((fine.grid_min - occ.grid_min) / occ.resolution).astype(np.int64)
    b = a + np.asarray(fine.shape) // max(u, 1)
    ok = u >= 1 and abs(occ.resolution / u - fine.resolution) < 1e-9 and np.allclose(occ.grid_min + a * occ.resolution,
                                                                                        fine.grid_min)
    if not ok or np.any(np.asarray(fine.shape) != u * (b - a)):
        raise CompassInputError(f"fine map (resolution {fine.resolution} m at {fine.grid_min}) is not aligned with "
                                f"the map ({occ.resolution} m at {occ.grid_min}); build it with local_fine_map")
    return a, b, u


def fine_unsafe_labels(state: np.ndarray, coarse_unsafe: np.ndarray, coarse_robot_safe: np.ndarray,
                       fine_carve: np.ndarray, u: int) -> np.ndarray:
    """Fine unsafe voxels (module doc) from a fine map's `state` over a box of map voxels
    (coarse_* masks of that box, fine_carve of the fine box): seen free -> safe; seen occupied -> unsafe unless the
    target's carve (on the fine map) or the robot's own space (its map voxel marked safe
    by the robot's spheres or the caller) holds it; unseen -> the map's label (after the
    carve and the robot's space), unless carved on the fine map."""
    st = state
    occ_ = (st == VoxelState.OCCUPIED) & ~fine_carve & ~upsample_mask(coarse_robot_safe, u)
    unk = (st == VoxelState.UNKNOWN) & ~fine_carve & upsample_mask(coarse_unsafe, u)
    return occ_ | unk


def fine_labels_in_box(occ: OccupancyMap, fine_map: OccupancyMap, target, clearance: float, u: int,
                       a: np.ndarray, b: np.ndarray, unsafe: np.ndarray, robot: np.ndarray):
    """(lo, hi, labels): the fine map's unsafe labels (`field.fine_unsafe_labels`) over the
    map-voxel range [lo, hi) where it overlaps the checked box [a, b) (labels None when it
    does not); each label depends on its own cell only, so any inner box takes a slice.
    target: the `TargetModel` (its carve on the fine map, `carve.target_carve`); clearance [m]
    of that carve; u the checked field's upsampling; unsafe / robot: the box's masks
    (`carve.grasp_unsafe_box`)."""
    fa, fb, fu = fine_map_range(occ, fine_map)
    if fu != u:
        raise CompassInputError(f"fine_map is {fu} times finer than the map; field_upsample {u} needs {u}")
    lo, hi = np.maximum(fa, a), np.minimum(fb, b)
    if not np.all(hi > lo):
        return lo, hi, None
    sl = tuple(slice(int(lo[k] - a[k]), int(hi[k] - a[k])) for k in range(3))
    fsl = tuple(slice(int(u * (lo[k] - fa[k])), int(u * (hi[k] - fa[k]))) for k in range(3))
    fine_carve = target_carve(fine_map, target, clearance,  # a fine voxel diagonal: as a map voxel
                              math.sqrt(3.0) * fine_map.resolution)[fsl]  # holding a point reaches
    return lo, hi, fine_unsafe_labels(fine_map.state[fsl], unsafe[sl], robot[sl], fine_carve, u)
