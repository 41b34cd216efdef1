"""The robot's own space in the map, kept as it moves.

Every configuration the robot passed through is free space (the robot was there), so its
collision spheres (grown by a margin) are marked safe in the grasp's map. A trial's way
holds tens of thousands of overlapping spheres; rasterising them all when the grasp is
selected cost about a second. `RobotSpaceMask` rasterises each executed segment when it
is executed (`add`), so the selection only reads the mask (`select_grasp(extra_safe=...)`).
The mask is exactly the one-shot rasterisation of all the configurations' spheres
(`mapping.distance.unsafe_mask` with those spheres; tested); configurations seen before
are skipped (bit-identical duplicates only, e.g. the home posture every way starts from).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import CompassInputError
from ..mapping.distance import _clear_spheres
from ..mapping.occupancy import OccupancyMap
from ..robot.spheres import SphereModel


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
