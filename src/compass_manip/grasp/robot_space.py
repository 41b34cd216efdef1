"""The robot's own space in the map, kept as it moves.

Every configuration the robot passed through is free space (the robot was there), so its
collision spheres (grown by a margin) are marked safe in the grasp's map. A trial's way
holds tens of thousands of overlapping spheres; rasterising them all when the grasp is
selected cost about a second. `RobotSpaceMask` rasterises each executed segment when it
is executed (`add`), so the selection only reads the mask (`select_grasp(extra_safe=...)`).
The mask is exactly the one-shot rasterisation of all the configurations' spheres
(`mapping.distance.unsafe_mask` with those spheres; tested); configurations seen before
are skipped (bit-identical duplicates only, e.g. the home posture every way starts from).
The space around the base column (`base_volume`) is the robot's too; it does not depend on
the configuration, so its mask is computed once per grid (`base_volume_mask`); so is the
volume links 0-4 sweep near home (`near_body_swept`, the near-body assumption's space).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import CompassInputError
from ..mapping.distance import _clear_spheres, mark_in_spheres
from ..mapping.occupancy import OccupancyMap
from ..robot.model import Q_MAX, Q_MIN
from ..robot.spheres import SphereModel
from .carve import clear_spheres_box


class RobotSpaceMask:
    """Voxels of `occ`'s grid (its shape, origin, resolution) whose centres lie inside the
    robot's spheres (radii + margin [m]) at any configuration added so far; `mask` (bool,
    the map's shape), `n_configs` added (duplicates skipped) and `time_s` spent adding."""

    def __init__(self, occ: OccupancyMap, spheres: SphereModel, margin: float = 0.02):
        if not 0.0 <= margin <= 0.1:
            raise CompassInputError(f"margin {margin} m is not allowed; use 0..0.1 m")
        self.grid_min = np.asarray(occ.grid_min, dtype=np.float64)
        self.resolution = float(occ.resolution)
        self.spheres, self.margin = spheres, float(margin)
        self._outside = np.ones(occ.shape, dtype=bool)
        self._seen: set[bytes] = set()
        self.n_configs = 0
        self.time_s = 0.0

    @property
    def mask(self) -> np.ndarray:
        return ~self._outside

    def add(self, Q: np.ndarray) -> None:
        """Mark the spheres of configurations Q (n,7) [rad] (or one (7,)) safe."""
        t = time.perf_counter()
        Q = np.asarray(Q, dtype=np.float64).reshape(-1, 7)
        if not np.all(np.isfinite(Q)):
            raise CompassInputError("RobotSpaceMask.add needs finite configurations (n, 7) [rad]")
        new = []
        for q in Q:
            key = q.tobytes()
            if key not in self._seen:
                self._seen.add(key)
                new.append(q)
        if new:
            Qn = np.asarray(new)
            c = np.ascontiguousarray(self.spheres.sphere_centers(Qn).reshape(-1, 3))
            r = np.ascontiguousarray(np.tile(self.spheres.radii + self.margin, len(Qn)))
            _clear_spheres(self._outside, self.grid_min, self.resolution, c, r)
            self.n_configs += len(Qn)
        self.time_s += time.perf_counter() - t


def base_volume(spheres: SphereModel, q_ref: np.ndarray, n_q1: int = 36,
                n_q2: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Spheres (centres (S,3) [m], radii (S,) [m]) of the links up to panda_link2 swept over
    joints 1 and 2: the robot's own space around its base column, which no camera on the
    wrist sees and nothing else can occupy (it would collide at home already). Links 0-2
    move with joints 1 and 2 only, so the volume does not depend on q_ref's other joints."""
    keep = np.isin(spheres.body_index, [spheres.link_names.index(k) for k in ("panda_link0", "panda_link1",
                                                                               "panda_link2")])
    q1 = np.linspace(Q_MIN[0], Q_MAX[0], n_q1)
    q2 = np.linspace(-1.2, 1.2, n_q2)
    Q = np.repeat(np.asarray(q_ref, dtype=np.float64)[None], n_q1 * n_q2, axis=0)
    Q[:, 0] = np.repeat(q1, n_q2)
    Q[:, 1] = np.tile(q2, n_q1)
    C = spheres.sphere_centers(Q)[:, keep]
    return C.reshape(-1, 3), np.tile(spheres.radii[keep] + 0.02, len(Q))


_GRID_CONSTANTS: dict = {}


def _grid_constant(name: str, spheres: SphereModel, occ: OccupancyMap, extra: bytes, build) -> np.ndarray:
    """A mask of occ's grid that depends only on the sphere model, the grid and `extra`:
    `build()` once per such key, then the same array (at most a few kept)."""
    key = (name, id(spheres), occ.shape, occ.resolution, occ.grid_min.tobytes(), extra)
    if key not in _GRID_CONSTANTS:
        if len(_GRID_CONSTANTS) > 16:
            _GRID_CONSTANTS.clear()
        _GRID_CONSTANTS[key] = (spheres, build())  # the model is kept so its id stays unique
    return _GRID_CONSTANTS[key][1]


def base_volume_mask(spheres: SphereModel, occ: OccupancyMap) -> np.ndarray:
    """`base_volume` as a voxel mask of occ's grid, computed once per sphere model and grid
    (a constant of the robot: it does not depend on the configuration)."""
    def build():
        c, r = base_volume(spheres, 0.5 * (Q_MIN + Q_MAX))
        return ~clear_spheres_box(np.ones(occ.shape, dtype=bool), occ.grid_min, occ.resolution, c, r)

    return _grid_constant("base_volume", spheres, occ, b"", build)


#: Joint 1's range [rad] around home's of the near-body volume the assumption has swept since it
#: exists, and the grasp-only harness's; the trial's is narrower since 2026-11-24
#: (`trial.config.GraspTrialConfig.near_body_yaw`).
WIDE_NEAR_BODY_YAW = 1.2


def check_near_body_yaw(yaw) -> float:
    """yaw [rad] as a float, or CompassInputError naming it unless a number in 0..2.9 rad."""
    if isinstance(yaw, bool) or not isinstance(yaw, (int, float, np.floating)) or not 0.0 <= yaw <= 2.9:
        raise CompassInputError(f"near_body_yaw {yaw!r} rad is not allowed; use 0..2.9 rad")
    return float(yaw)


def near_body_spheres(spheres: SphereModel, q_home: np.ndarray,
                      yaw: float = WIDE_NEAR_BODY_YAW) -> tuple[np.ndarray, np.ndarray]:
    """(centres (S, 3) [m], radii (S,) [m]) of links 0-4's spheres swept around q_home: joint 1
    within +-yaw [rad] of q_home's (9 values), joints 2-4 over a grid (675 configurations)."""
    yaw = check_near_body_yaw(yaw)
    names = ("panda_link0", "panda_link1", "panda_link2", "panda_link3", "panda_link4")
    keep = np.isin(spheres.body_index, [spheres.link_names.index(k) for k in names])
    q1 = float(np.asarray(q_home, dtype=np.float64)[0]) + np.linspace(-yaw, yaw, 9)
    grids = np.meshgrid(q1, np.linspace(-1.2, 1.0, 5), (-0.5, 0.0, 0.5),
                        np.linspace(-3.0, -0.8, 5), indexing="ij")
    Q = np.repeat(np.asarray(q_home, dtype=np.float64)[None], grids[0].size, axis=0)
    for j in range(4):
        Q[:, j] = grids[j].ravel()
    return spheres.sphere_centers(Q)[:, keep].reshape(-1, 3), np.tile(spheres.radii[keep], len(Q))


def near_body_swept(occ: OccupancyMap, spheres: SphereModel, q_home: np.ndarray,
                    yaw: float = WIDE_NEAR_BODY_YAW) -> np.ndarray:
    """(nx, ny, nz) bool, read-only: the voxels of occ's grid whose centres lie inside
    `near_body_spheres` (joint 1 within +-yaw [rad] of q_home's). A constant of the robot and
    the grid, computed once per sphere model, grid, q_home and yaw (71,550 spheres)."""
    q_home = np.asarray(q_home, dtype=np.float64)
    yaw = check_near_body_yaw(yaw)

    def build():
        inside = np.zeros(occ.shape, bool)
        mark_in_spheres(inside, occ.grid_min, occ.resolution, *near_body_spheres(spheres, q_home, yaw))
        inside.flags.writeable = False
        return inside

    return _grid_constant("near_body", spheres, occ, q_home.tobytes() + np.float64(yaw).tobytes(), build)
