"""Information gain of camera viewpoints: distinct unknown voxels a view would observe.

A view casts a grid of rays (default 40 x 30) through the image. Each ray starts at the
camera centre and runs up to `max_range` [m] (Euclidean length along the ray), stops at the
first occupied voxel (not counted) or where it leaves the grid, and passes through free
and unknown voxels. The gain is the number of *distinct* unknown voxels the rays visit.
Ray traversal follows `raycast.ray_setup` (OctoMap's ray convention: the voxel holding the
end point at `max_range` is not counted, as a max-range measurement would not clear it).

Distinct voxels are counted with per-worker uint8 stamp grids kept with the map between
calls (see `gain_kernels`); batches run in parallel over views. Calls on the same map must
not run concurrently from several Python threads (they share those grids).
"""
from __future__ import annotations

import math
import weakref

import numba
import numpy as np

from ..errors import CompassInputError, instance_of, real_number
from ..geometry import check_intrinsics, check_rigid
from .occupancy import OccupancyMap
from . import gain_kernels


def camera_ray_directions(
    K: np.ndarray, rays: tuple[int, int] = (40, 30), image_size: tuple[int, int] | None = None
) -> np.ndarray:
    """Unit ray directions (nu * nv, 3) in the OpenCV camera frame.

    rays = (nu, nv) rays across the image width and height, through the centres of an
    nu x nv grid of equal cells tiling the image [-0.5, W - 0.5] x [-0.5, H - 0.5] (pixel
    centres at integer coordinates, OpenCV). image_size = (W, H) [px]; by default
    (2 cx + 1, 2 cy + 1), i.e. a centred principal point.
    """
    nu, nv = _int_pair(rays, "rays", 1, 10_000)
    if image_size is not None:
        W, H = _int_pair(image_size, "image_size", 1, 100_000)
        K = _check_K(K, (W, H))
    else:
        K = _check_K(K)
        W, H = 2.0 * K[0, 2] + 1.0, 2.0 * K[1, 2] + 1.0
        if not (W > 0 and H > 0):
            raise CompassInputError(f"K principal point ({K[0, 2]}, {K[1, 2]}) px gives no image; "
                                    "give image_size (W, H) or a principal point >= 0")
    u = (np.arange(nu) + 0.5) * (W / nu) - 0.5
    v = (np.arange(nv) + 0.5) * (H / nv) - 0.5
    uu, vv = np.meshgrid(u, v)
    d = np.stack(
        [(uu.ravel() - K[0, 2]) / K[0, 0], (vv.ravel() - K[1, 2]) / K[1, 1], np.ones(nu * nv)], axis=1
    )
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def info_gain(
    occ_map: OccupancyMap,
    T_world_cam: np.ndarray,
    K: np.ndarray,
    max_range: float,
    rays: tuple[int, int] = (40, 30),
    image_size: tuple[int, int] | None = None,
) -> int:
    """Number of distinct unknown voxels visible from camera pose T_world_cam (see module doc)."""
    T = check_rigid(T_world_cam, "T_world_cam")
    return int(info_gain_batch(occ_map, T[None], K, max_range, rays, image_size)[0])


def info_gain_batch(
    occ_map: OccupancyMap,
    T_world_cams: np.ndarray,
    K: np.ndarray,
    max_range: float,
    rays: tuple[int, int] = (40, 30),
    image_size: tuple[int, int] | None = None,
    skip_rays: np.ndarray | None = None,
) -> np.ndarray:
    """Information gain (M,) int64 of M camera poses T_world_cams (M, 4, 4), in parallel.
    skip_rays (M, nu * nv) bool: rays not cast (in `camera_ray_directions`' order), e.g. those
    the robot's own body blocks (`self_occlusion.self_blocked_rays`)."""
    instance_of(occ_map, OccupancyMap, "occ_map")
    Ts = _check_poses(T_world_cams)
    max_range = real_number(max_range, "max_range", "a finite number > 0 [m]")
    if not max_range > 0.0:
        raise CompassInputError(f"max_range {max_range} m is not allowed; use a finite value > 0 [m]")
    dirs = camera_ray_directions(K, rays, image_size)
    if skip_rays is None:
        skip = np.zeros((len(Ts), len(dirs)), np.bool_)
    else:
        skip = np.ascontiguousarray(skip_rays, dtype=np.bool_)
        if skip.shape != (len(Ts), len(dirs)):
            raise CompassInputError(f"skip_rays has shape {skip.shape}; ({len(Ts)}, {len(dirs)}) is required "
                                    "(views, rays)")
    n_workers = numba.get_num_threads()
    origins = np.ascontiguousarray(Ts[:, :3, 3])
    R = np.ascontiguousarray(Ts[:, :3, :3])
    k0, res = occ_map.grid_key_min, occ_map.resolution
    if len(Ts) >= VIEW_GRID_MIN_VIEWS:
        grids = _scratch(occ_map, "grids", (n_workers,) + tuple(n + 2 for n in occ_map.shape))
        gain_kernels.fill_view_grids(occ_map.state, grids)
        return gain_kernels.info_gain_grids_parallel(
            grids, np.asarray(occ_map.shape, np.int64), origins, R, dirs, float(max_range), k0, res, skip
        )
    stamps = _scratch(occ_map, "stamps", (n_workers, occ_map.state.size))
    last = _scratch(occ_map, "last", (n_workers,), np.int64)
    kernel = gain_kernels.info_gain_parallel if n_workers > 1 and len(Ts) >= 4 else gain_kernels.info_gain_serial
    return kernel(occ_map.state, stamps, last, origins, R, dirs, float(max_range), k0, res, skip)


def _check_K(K: np.ndarray, image_size=None) -> np.ndarray:
    return check_intrinsics(K, None if image_size is None else (image_size[1], image_size[0]))


def _check_poses(T_world_cams: np.ndarray) -> np.ndarray:
    """Vectorised rigidity check of (M, 4, 4) poses; names the first bad index."""
    Ts = np.asarray(T_world_cams, dtype=np.float64)
    if Ts.ndim != 3 or Ts.shape[1:] != (4, 4) or len(Ts) == 0:
        raise CompassInputError(f"T_world_cams must have shape (M, 4, 4) with M >= 1, got {Ts.shape}")
    R = Ts[:, :3, :3]
    with np.errstate(invalid="ignore"):
        ortho = np.abs(np.einsum("mji,mjk->mik", R, R) - np.eye(3)).max(axis=(1, 2)) < 1e-5
        ok = (
            np.isfinite(Ts).all(axis=(1, 2))
            & ortho
            & (np.abs(np.linalg.det(R) - 1.0) < 1e-5)
            & (np.abs(Ts[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1) < 1e-5)
        )
    if not ok.all():
        i = int(np.argmin(ok))
        check_rigid(Ts[i], f"T_world_cams[{i}]")
        raise CompassInputError(f"T_world_cams[{i}] is not a rigid transform")
    return Ts


def _int_pair(value, name: str, low: int, high: int) -> tuple[int, int]:
    """(a, b) of two whole numbers in low..high, or CompassInputError."""
    try:
        a, b = value
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{name} {value!r:.60} is not allowed; use two whole numbers {low}..{high}") from exc
    out = []
    for v in (a, b):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer, float, np.floating)) \
                or not math.isfinite(float(v)) or float(v) != int(v) or not low <= int(v) <= high:
            raise CompassInputError(f"{name} {value!r:.60} is not allowed; use two whole numbers {low}..{high}")
        out.append(int(v))
    return out[0], out[1]


#: Batches of at least this many views use the view-grid kernels (see gain_kernels).
VIEW_GRID_MIN_VIEWS = 16

_SCRATCH: "weakref.WeakKeyDictionary[OccupancyMap, dict]" = weakref.WeakKeyDictionary()


def _scratch(occ_map: OccupancyMap, name: str, shape: tuple[int, ...], dtype=np.uint8) -> np.ndarray:
    """A zero-initialised scratch array kept with the map between calls."""
    store = _SCRATCH.setdefault(occ_map, {})
    a = store.get(name)
    if a is None or a.shape != shape:
        a = store[name] = np.zeros(shape, dtype)
    return a
