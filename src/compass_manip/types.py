"""Frozen records shared by layers."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Frame:
    """One wrist-camera observation.

    depth: (H, W) float32 z-depth along the optical axis [m]; 0 = no measurement (closer
        than the sensor's minimum range), inf = no return within the maximum range.
    rgb: (H, W, 3) uint8, or None when not rendered.
    seg: (H, W) int32 object labels (0 = background), or None when not rendered; the
        simulator says which label is which object.
    K: (3, 3) pinhole intrinsics [px], pixel centres at integer coordinates.
    T_world_cam: (4, 4) optical frame in the world (OpenCV: +z forward, +x right, +y down).
    t: simulated time [s] of the observation.
    q: (7,) arm configuration [rad] at which it was taken.
    """

    depth: np.ndarray
    rgb: np.ndarray | None
    seg: np.ndarray | None
    K: np.ndarray
    T_world_cam: np.ndarray
    t: float
    q: np.ndarray

    def observation(self) -> "Observation":
        """This frame as a method may see it: the segmentation labels dropped."""
        return Observation(self.depth, self.rgb, self.K, self.T_world_cam, self.t, self.q)


@dataclass(frozen=True, eq=False)
class Observation:
    """What a method receives from the wrist camera and the arm: a Frame without labels.

    depth: (H, W) float32 z-depth [m] (0 = closer than the minimum range, inf = no return);
    rgb: (H, W, 3) uint8 or None; K: (3, 3) intrinsics [px]; T_world_cam: (4, 4) optical
    frame (OpenCV) in the world; t: time [s]; q: (7,) joint state [rad].
    """

    depth: np.ndarray
    rgb: np.ndarray | None
    K: np.ndarray
    T_world_cam: np.ndarray
    t: float
    q: np.ndarray


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Timed joint trajectory: t (n,) [s] strictly increasing from 0, q (n, 7) [rad]."""

    t: np.ndarray
    q: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self.t) else 0.0
