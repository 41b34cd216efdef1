"""Dense log-odds occupancy map over an axis-aligned workspace box, fed by depth images.

The sensor model and update rule are OctoMap's (Hornung et al. 2013): log-odds per voxel,
a hit adds logit(prob_hit), a miss adds logit(prob_miss), values are clamped to
[logit(clamp_min), logit(clamp_max)], and a voxel is occupied when its log-odds is
>= logit(occupancy_threshold) (OctoMap's `isNodeOccupied`). Within one scan each voxel is
updated at most once and a voxel hit by the scan is not also cleared by it. Log-odds are
float32 as in OctoMap. Whether a voxel was ever observed is kept in a separate uint8 state
grid (`VoxelState`), so "unknown" never coincides with p = 0.5.

Voxel boundaries lie on multiples of the resolution (OctoMap's keys): the grid covers the
configured box rounded outwards to whole voxels.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Callable

import numba
import numpy as np

from ..errors import CompassInputError, real_number, float_array, points_array
from ..geometry import check_intrinsics, check_rigid
from . import raycast
from .depth_cues import depth_cues
from .integration import integrate_scan

_NO_NORMALS = np.zeros((0, 6))

#: A self-filter: world points (N, 3) [m] -> bool (N,), True for points on the robot's body.
PointFilter = Callable[[np.ndarray], np.ndarray]


class VoxelState(IntEnum):
    """Value of a voxel in `OccupancyMap.state`."""

    UNKNOWN = 0
    FREE = 1
    OCCUPIED = 2


def _logit(p: float) -> np.float32:
    return np.float32(math.log(p / (1.0 - p)))


@dataclass(frozen=True)
class MapConfig:
    """Occupancy map settings.

    box_min, box_max: workspace box corners in the world frame [m]. resolution: voxel edge
    [m]. prob_hit / prob_miss: sensor model; clamp_min / clamp_max: probability clamping;
    occupancy_threshold: occupied when p >= threshold (all OctoMap defaults).
    pixel_stride: integrate every s-th pixel in u and v (1 = every pixel).
    ray_grouping: 0 traces the free-space ray of every pixel (labels and log-odds identical
    to OctoMap's insertPointCloud); g = 1 or 2 traces one free-space ray per end cell of
    edge resolution / g (the first pixel's; rays leaving the grid are grouped by exit cell
    of edge resolution / 2), hits still come from every pixel. Grouped rays cross nearly the
    same voxels, so a few free voxels at the edges of ray bundles stay unknown. 1 is the
    default: on the Level-4 benchmark frames 4-5x less CPU than 0, with 99.94 % of the
    workspace voxels and 99.6 % of the observed voxels labelled as OctoMap labels them
    (2: about 2x less CPU, 99.97 % / 99.8 %).
    surface_guard: a ray ending on a surface whose normal the depth image gives (`integrate`)
    frees no voxel whose cube meets the tangent plane at its end point, so the voxels a
    grazing ray crosses just above a wall or board are not freed (OctoMap frees every voxel
    the ray's line crosses, also one a board fills in part). sticky_hits k >= 1: a voxel hit
    in k scans stays occupied, misses no longer lower it (a static scene; 0: OctoMap's rule,
    where a few misses of rays through a voxel's empty part flip a once-hit voxel to free).
    With both off the labels are OctoMap's (measured in docs/grasping_log.md, "Free space the grasp can trust").
    """

    box_min: tuple[float, float, float] = (-0.6, -0.8, -0.05)
    box_max: tuple[float, float, float] = (1.1, 0.8, 1.3)
    resolution: float = 0.01
    prob_hit: float = 0.7
    prob_miss: float = 0.4
    clamp_min: float = 0.12
    clamp_max: float = 0.97
    occupancy_threshold: float = 0.5
    pixel_stride: int = 1
    ray_grouping: int = 1
    surface_guard: bool = True
    sticky_hits: int = 1

    def __post_init__(self) -> None:
        lo = float_array(self.box_min, "MapConfig.box_min", "3 finite numbers [m]")
        hi = float_array(self.box_max, "MapConfig.box_max", "3 finite numbers [m]")
        for name in ("resolution", "prob_hit", "prob_miss", "clamp_min", "clamp_max", "occupancy_threshold"):
            real_number(getattr(self, name), f"MapConfig.{name}")
        if lo.shape != (3,) or hi.shape != (3,) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise CompassInputError(f"box_min {self.box_min} / box_max {self.box_max} must be finite 3-vectors [m]")
        if not np.all(hi > lo):
            raise CompassInputError(f"box_max {self.box_max} must exceed box_min {self.box_min} on every axis")
        if not (0.001 <= self.resolution <= 1.0):
            raise CompassInputError(f"resolution {self.resolution} m is not allowed; use 0.001..1 m")
        if not (0.5 < self.prob_hit < 1.0 and 0.0 < self.prob_miss < 0.5):
            raise CompassInputError(
                f"prob_hit {self.prob_hit} / prob_miss {self.prob_miss} not allowed; need 0.5 < hit < 1, 0 < miss < 0.5"
            )
        if not (0.0 < self.clamp_min < self.occupancy_threshold < self.clamp_max < 1.0):
            raise CompassInputError(
                f"clamp_min {self.clamp_min}, occupancy_threshold {self.occupancy_threshold}, clamp_max "
                f"{self.clamp_max} not allowed; need 0 < clamp_min < threshold < clamp_max < 1"
            )
        if isinstance(self.pixel_stride, bool) or not (isinstance(self.pixel_stride, int) and 1 <= self.pixel_stride <= 16):
            raise CompassInputError(f"pixel_stride {self.pixel_stride} is not allowed; use an int 1..16")
        if isinstance(self.ray_grouping, bool) or not isinstance(self.ray_grouping, int) or self.ray_grouping not in (0, 1, 2):
            raise CompassInputError(f"ray_grouping {self.ray_grouping} is not allowed; use 0, 1 or 2")
        if not isinstance(self.surface_guard, (bool, np.bool_)):
            raise CompassInputError(f"surface_guard {self.surface_guard!r:.40} is not allowed; use True or False")
        sticky = self.sticky_hits
        if isinstance(sticky, bool) or not isinstance(sticky, int) or not 0 <= sticky <= 255:
            raise CompassInputError(f"sticky_hits {sticky!r:.40} is not allowed; use an int 0..255 (0: off)")
        n = np.ceil(hi / self.resolution - 1e-9) - np.floor(lo / self.resolution + 1e-9)
        if np.prod(n) > 2e8:
            raise CompassInputError(f"map of {n.astype(int)} voxels is too large; at most 2e8 voxels")


def check_depth(depth: np.ndarray) -> np.ndarray:
    """A depth image (H, W) of z-depths [m] as given, or CompassInputError: it must be a
    non-empty 2-D floating-point array (metres). Integer images are refused, since sensors
    and PNG files store millimetres as integers; bool images are masks, not depth."""
    d = np.asarray(depth)
    if d.ndim != 2 or d.size == 0:
        raise CompassInputError(f"depth must be a non-empty (H, W) image [m], got shape {d.shape}")
    if not np.issubdtype(d.dtype, np.floating):
        hint = (" (integer depth is usually millimetres: pass depth.astype(np.float32) / 1000, with 0 for "
                "no return)" if np.issubdtype(d.dtype, np.integer) else "")
        raise CompassInputError(f"depth has dtype {d.dtype}; floating-point metres are required{hint}")
    return d


def _voxel_state(state) -> VoxelState:
    try:
        return VoxelState(state)
    except (ValueError, TypeError) as exc:
        raise CompassInputError(f"voxel state {state!r:.40} is not allowed; use a VoxelState "
                                "(UNKNOWN 0, FREE 1, OCCUPIED 2)") from exc


def _float_array(value, name: str) -> np.ndarray:
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{name} must be numbers [m], got {value!r:.60}") from exc


@dataclass(frozen=True)
class IntegrationStats:
    """What one `integrate` call did: valid rays, pixels dropped by the self-filter,
    voxels updated as free and as occupied, free-space rays traced (after grouping)."""

    n_rays: int
    n_filtered: int
    n_free_updates: int
    n_hit_updates: int
    n_traced: int


@dataclass(frozen=True)
class VoxelCounts:
    free: int
    occupied: int
    unknown: int


class OccupancyMap:
    """Log-odds voxel grid. `logodds` (nx, ny, nz) float32 and `state` (nx, ny, nz) uint8
    (`VoxelState`) are indexed [i, j, k] along world x, y, z. Both may be read freely;
    write them only together (or through `set_voxels` / `set_box`). A map keeps scratch
    grids for integration: one `integrate` call at a time per map (not thread-safe)."""

    def __init__(self, config: MapConfig | None = None) -> None:
        self.config = config or MapConfig()
        res = self.config.resolution
        k_lo = np.floor(np.asarray(self.config.box_min) / res + 1e-9).astype(np.int64)
        k_hi = np.ceil(np.asarray(self.config.box_max) / res - 1e-9).astype(np.int64)
        #: integer key (floor(x / res)) of voxel [0, 0, 0] along each axis
        self.grid_key_min = k_lo
        self.shape = tuple(int(v) for v in (k_hi - k_lo))
        self.resolution = float(res)
        self.logodds = np.zeros(self.shape, np.float32)
        self.state = np.zeros(self.shape, np.uint8)
        self._mark = np.zeros(self.shape, np.uint8)
        self._row_dirty = np.zeros(self.shape[0] * self.shape[1], np.uint8)
        self._claim = np.zeros(self.shape, np.uint8)
        #: scans that hit each voxel (saturating at 255), for `MapConfig.sticky_hits`
        self.hits = np.zeros(self.shape, np.uint8)
        c = self.config
        self._logs = (
            _logit(c.prob_hit), _logit(c.prob_miss), _logit(c.clamp_min), _logit(c.clamp_max),
            _logit(c.occupancy_threshold),
        )

    # ----------------------------------------------------------------- geometry
    @property
    def grid_min(self) -> np.ndarray:
        """World corner [m] of voxel [0, 0, 0] (the low corner of the grid)."""
        return self.grid_key_min * self.resolution

    @property
    def grid_max(self) -> np.ndarray:
        """World corner [m] opposite `grid_min`."""
        return (self.grid_key_min + np.asarray(self.shape)) * self.resolution

    def world_to_voxel(self, points_world: np.ndarray) -> np.ndarray:
        """Voxel indices (N, 3) int64 of world points (N, 3) [m]; may lie outside the grid."""
        p = points_array(points_world, "points_world")
        return np.floor(p * (1.0 / self.resolution)).astype(np.int64) - self.grid_key_min

    def voxel_to_world(self, index: np.ndarray) -> np.ndarray:
        """World centres (N, 3) [m] of voxel indices (N, 3)."""
        idx = points_array(index, "voxel index")
        return (idx + self.grid_key_min + 0.5) * self.resolution

    def in_grid(self, index: np.ndarray) -> np.ndarray:
        """(N,) bool: voxel indices (N, 3) inside the grid."""
        idx = np.asarray(index).reshape(-1, 3)
        return np.all((idx >= 0) & (idx < np.asarray(self.shape)), axis=1)

    def voxel_centers(self) -> np.ndarray:
        """World centres (nx, ny, nz, 3) [m] of all voxels."""
        axes = [(np.arange(n) + k + 0.5) * self.resolution for n, k in zip(self.shape, self.grid_key_min)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    # ----------------------------------------------------------------- updates
    def integrate(
        self,
        depth: np.ndarray,
        K: np.ndarray,
        T_world_cam: np.ndarray,
        max_range: float,
        point_filter: PointFilter | None = None,
    ) -> IntegrationStats:
        """Integrate a depth image (H, W) of z-depths [m] taken from camera pose T_world_cam.

        K: 3x3 intrinsics [px], pixel centres at integer coordinates (OpenCV).
        depth must be floating point in metres (float16/32/64): integer depth (e.g. a
        sensor's millimetres) or a bool mask raises CompassInputError saying how to convert.
        K must be a pinhole matrix without skew whose principal point fits the image.
        NaN, 0 and negative depths are ignored. +inf (no return) and points farther than
        max_range [m] (Euclidean, along the ray, as OctoMap's maxrange) clear free space
        up to max_range with no hit. point_filter (robot self-filter) drops the pixels
        whose measured world point it flags (neither hit nor ray; a filter with
        an `invalidate_inside` method, as `SphereBodyFilter`, drops them in place). A non-finite or
        non-rigid pose raises CompassInputError and leaves the map unchanged.
        """
        T = check_rigid(T_world_cam, "T_world_cam")
        max_range = self._check_range(max_range)
        depth = check_depth(depth)
        K = check_intrinsics(K, depth.shape)
        if point_filter is not None and not callable(point_filter):
            raise CompassInputError(f"point_filter {point_filter!r:.60} is not callable; give a function "
                                    "points (N, 3) -> bool (N,) or None")
        points, kind = raycast.backproject(
            np.ascontiguousarray(depth, dtype=np.float32), K[0, 0], K[1, 1], K[0, 2], K[1, 2],
            np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]), self.config.pixel_stride,
        )
        normals = _NO_NORMALS
        if self.config.surface_guard:
            normals = depth_cues(
                np.ascontiguousarray(depth, dtype=np.float32), K[0, 0], K[1, 1], K[0, 2], K[1, 2],
                np.ascontiguousarray(T[:3, :3]), self.config.pixel_stride, 0.5 * self.resolution,
                0.5 * math.sqrt(3.0) * self.resolution,
            )
        return self._integrate(points, kind, T[:3, 3], max_range, point_filter, normals)

    def integrate_points(
        self,
        points_world: np.ndarray,
        origin_world: np.ndarray,
        max_range: float = math.inf,
        point_filter: PointFilter | None = None,
    ) -> IntegrationStats:
        """Integrate measured world points (N, 3) [m] seen from origin_world (3,) [m]:
        OctoMap's `insertPointCloud(points, origin, maxrange)` on this grid (points carry no
        surface normals: no surface guard; sticky hits apply)."""
        p = _float_array(points_world, "points_world")
        o = _float_array(origin_world, "origin_world")
        if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
            raise CompassInputError(f"points_world must be finite (N, 3) [m], got shape {p.shape}")
        if o.shape != (3,) or not np.all(np.isfinite(o)):
            raise CompassInputError(f"origin_world must be a finite 3-vector [m], got {o}")
        if not (isinstance(max_range, (int, float, np.floating, np.integer)) and max_range == math.inf):
            max_range = self._check_range(max_range)
        kind = np.full(len(p), raycast.KIND_POINT, np.uint8)
        return self._integrate(np.ascontiguousarray(p), kind, o, max_range, point_filter, _NO_NORMALS)

    def _integrate(self, points, kind, origin, max_range, point_filter, normals) -> IntegrationStats:
        n_filtered = 0
        invalidate = getattr(point_filter, "invalidate_inside", None)
        if invalidate is not None:  # a SphereBodyFilter: the same pixels dropped in one compiled pass
            n_filtered = invalidate(points, kind, raycast.KIND_POINT, raycast.KIND_INVALID)
        elif point_filter is not None:
            measured = np.flatnonzero(kind == raycast.KIND_POINT)
            drop = np.asarray(point_filter(points[measured]), dtype=bool)
            if drop.shape != measured.shape:
                raise CompassInputError(
                    f"point_filter returned shape {drop.shape}; a bool mask of shape {measured.shape} is required"
                )
            kind[measured[drop]] = raycast.KIND_INVALID
            n_filtered = int(drop.sum())
        n_free, n_hit, n_traced = integrate_scan(
            self.logodds, self.state, self._mark, self._row_dirty, self._claim,
            np.asarray(origin, dtype=np.float64), points, kind, float(min(max_range, 1e9)),
            self.grid_key_min, self.resolution, self._logs, self.config.ray_grouping,
            numba.get_num_threads(), normals, self.hits, self.config.sticky_hits,
        )
        n_rays = int(np.count_nonzero(kind != raycast.KIND_INVALID))
        return IntegrationStats(n_rays, n_filtered, int(n_free), int(n_hit), int(n_traced))

    @staticmethod
    def _check_range(max_range) -> float:
        v = real_number(max_range, "max_range", "a finite number > 0 [m]")
        if not v > 0.0:
            raise CompassInputError(f"max_range {max_range} m is not allowed; use a finite value > 0 [m]")
        return v

    def set_voxels(self, index: np.ndarray, state: VoxelState) -> None:
        """Force voxels (N, 3) indices to a state: FREE / OCCUPIED get the clamping log-odds
        (as OctoMap's readBinary does), UNKNOWN resets them. Indices outside the grid raise."""
        raw = points_array(index, "voxel index")
        if not np.all(np.isfinite(raw)) or np.any(raw != np.round(raw)):
            raise CompassInputError("voxel indices must be finite whole numbers")
        idx = raw.astype(np.int64)
        if not np.all(self.in_grid(idx)):
            bad = idx[~self.in_grid(idx)][0]
            raise CompassInputError(f"voxel index {bad.tolist()} is outside the grid of shape {self.shape}")
        state = _voxel_state(state)
        value = {VoxelState.UNKNOWN: 0.0, VoxelState.FREE: self._logs[2], VoxelState.OCCUPIED: self._logs[3]}[state]
        self.logodds[idx[:, 0], idx[:, 1], idx[:, 2]] = value
        self.state[idx[:, 0], idx[:, 1], idx[:, 2]] = int(state)
        self.hits[idx[:, 0], idx[:, 1], idx[:, 2]] = 0  # a forced state is a prior, not a hit

    def set_box(self, box_min: np.ndarray, box_max: np.ndarray, state: VoxelState) -> None:
        """Force every voxel whose centre lies in the world box [box_min, box_max] [m] to a state."""
        sl = self._box_slices(box_min, box_max)
        value = {VoxelState.UNKNOWN: 0.0, VoxelState.FREE: self._logs[2], VoxelState.OCCUPIED: self._logs[3]}
        self.logodds[sl] = value[_voxel_state(state)]
        self.state[sl] = int(state)
        self.hits[sl] = 0

    def reset(self) -> None:
        """Forget everything: all voxels unknown."""
        self.logodds[...] = 0.0
        self.state[...] = VoxelState.UNKNOWN
        self.hits[...] = 0

    def copy(self) -> OccupancyMap:
        other = OccupancyMap(self.config)
        other.logodds[...] = self.logodds
        other.state[...] = self.state
        other.hits[...] = self.hits
        return other

    # ----------------------------------------------------------------- queries
    def free_mask(self) -> np.ndarray:
        return self.state == VoxelState.FREE

    def occupied_mask(self) -> np.ndarray:
        return self.state == VoxelState.OCCUPIED

    def unknown_mask(self) -> np.ndarray:
        return self.state == VoxelState.UNKNOWN

    def counts(self) -> VoxelCounts:
        c = np.bincount(self.state.ravel(), minlength=3)
        return VoxelCounts(free=int(c[1]), occupied=int(c[2]), unknown=int(c[0]))

    def state_at(self, points_world: np.ndarray) -> np.ndarray:
        """VoxelState values (N,) uint8 at world points (N, 3) [m]; UNKNOWN outside the grid."""
        idx = self.world_to_voxel(points_world)
        out = np.zeros(len(idx), np.uint8)
        inside = self.in_grid(idx)
        i = idx[inside]
        out[inside] = self.state[i[:, 0], i[:, 1], i[:, 2]]
        return out

    def known_fraction(self, box_min: np.ndarray, box_max: np.ndarray) -> float:
        """Fraction of the voxels overlapping the world box [box_min, box_max] [m] that are
        known (free or occupied); voxels of the box outside the grid count as unknown.
        This is the paper's explored-volume metric on a target's bounding box."""
        lo, hi = self._check_box(box_min, box_max)
        k_lo = np.floor(lo / self.resolution).astype(np.int64)
        k_hi = np.floor(hi / self.resolution).astype(np.int64) + 1
        total = int(np.prod(k_hi - k_lo))
        a = np.clip(k_lo - self.grid_key_min, 0, self.shape)
        b = np.clip(k_hi - self.grid_key_min, 0, self.shape)
        sub = self.state[a[0]:b[0], a[1]:b[1], a[2]:b[2]]
        return float(np.count_nonzero(sub)) / total

    def _check_box(self, box_min, box_max) -> tuple[np.ndarray, np.ndarray]:
        lo = float_array(box_min, "box_min", "3 numbers [m]")
        hi = float_array(box_max, "box_max", "3 numbers [m]")
        if lo.shape != (3,) or hi.shape != (3,) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise CompassInputError(f"box corners {box_min}, {box_max} must be finite 3-vectors [m]")
        if not np.all(hi >= lo):
            raise CompassInputError(f"box_max {hi.tolist()} must be >= box_min {lo.tolist()} on every axis")
        return lo, hi

    def _box_slices(self, box_min, box_max) -> tuple[slice, slice, slice]:
        """Index slices of the voxels whose centres lie in the world box."""
        lo, hi = self._check_box(box_min, box_max)
        a = np.ceil(lo / self.resolution - 0.5).astype(np.int64) - self.grid_key_min
        b = np.floor(hi / self.resolution - 0.5).astype(np.int64) - self.grid_key_min + 1
        a = np.clip(a, 0, self.shape)
        b = np.clip(b, 0, self.shape)
        return tuple(slice(int(x), int(y)) for x, y in zip(a, b))
