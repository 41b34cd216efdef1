"""The robot's own body is never the target: a detector wrapper that blanks its pixels.

The wrist camera sees the arm's own links when it looks back towards the base (views the
exploration takes when the near field is what is left unknown). A detector working on
colour, shape and size alone then judges the robot's links like any object; the Panda's
white, round links match a white bottle's query (measured: Level 4, scene 0, seed 0, an
accepted "bottle" at the base link, 0.07 x 0.17 m, ended the trial as a false detection).
`SelfMaskedDetector` back-projects each observation's depth, drops the pixels whose world
points lie inside the robot's collision spheres at the observation's joint state `q`
(inflated by `margin` [m], the mapping's self filter, `mapping.selffilter`), and runs the
wrapped detector on the rest (their depth set to 0 = no measurement, which every detector
ignores). Only the robot's own model and `obs.q` are used: no simulator state. An inner
detector with a `may_detect(obs, query)` that is False (the appearance detector: too few
pixels of the query's colour even with every pixel's depth) gives () without the mask,
which is what it would give with it; most frames show no target colour, and the mask (a
back-projection of the whole image) was most of the detection thread's work.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import CompassInputError
from ..mapping.selffilter import SphereBodyFilter
from ..task import TargetQuery
from ..types import Observation
from .detector import Detection, Detector
from .target import backproject_image

#: Inflation [m] of the robot's spheres (depth noise, sphere-fit error; the mapping uses 1 cm).
SELF_MASK_MARGIN = 0.01


def self_pixels(obs: Observation, spheres, margin: float = SELF_MASK_MARGIN) -> np.ndarray:
    """(H, W) bool: pixels whose measured point lies on the robot (its spheres posed at
    obs.q, grown by margin [m]); pixels without depth are False."""
    pts, valid = backproject_image(obs.depth, obs.K, obs.T_world_cam)
    return _self_pixels_of(pts, valid, obs.q, spheres, margin)


def _self_pixels_of(pts: np.ndarray, valid: np.ndarray, q, spheres, margin: float) -> np.ndarray:
    """`self_pixels` from the image's world points and validity (`backproject_image`)."""
    if not valid.any():
        return np.zeros(valid.shape, bool)
    centres = spheres.sphere_centers(np.asarray(q, dtype=np.float64)[None])[0]
    body = SphereBodyFilter(centres, spheres.radii, margin=margin)
    return body.inside_where(pts.reshape(-1, 3), valid.reshape(-1)).reshape(valid.shape)  # = body(pts[valid]) there


class SelfMaskedDetector:
    """Runs `inner` on observations whose robot pixels have no depth (see the module
    docstring); spheres: a `robot.spheres.SphereModel` of the observing robot."""

    def __init__(self, inner: Detector, spheres, margin: float = SELF_MASK_MARGIN) -> None:
        if not callable(inner):
            raise CompassInputError(f"inner detector {inner!r:.60} is not callable; give obs, query -> detections")
        if not 0.0 <= float(margin) <= 0.2:
            raise CompassInputError(f"margin {margin} m is not allowed; use 0..0.2 m")
        self.inner, self.spheres, self.margin = inner, spheres, float(margin)

    def __call__(self, obs: Observation, query: TargetQuery) -> tuple[Detection, ...]:
        may_detect = getattr(self.inner, "may_detect", None)  # an inner detector that can tell
        if may_detect is not None and not may_detect(obs, query):  # it finds nothing even unmasked
            return ()
        pts, valid = backproject_image(obs.depth, obs.K, obs.T_world_cam)
        mine = _self_pixels_of(pts, valid, obs.q, self.spheres, self.margin)
        if mine.any():
            depth = np.array(obs.depth, dtype=np.float32, copy=True)
            depth[mine] = 0.0
            obs = replace(obs, depth=depth)
            pts[mine] = np.nan  # = backproject_image of the masked depth (no depth: NaN), the rest the same
        if getattr(self.inner, "takes_points_world", False):  # spare it the same back-projection
            return self.inner(obs, query, points_world=pts)
        return self.inner(obs, query)
