"""What cuts an image region off: an occluder, the object's own silhouette, or a colour change.

A region of the query's colour that shows less than the query's size is cut off somewhere.
Looking just outside its outline tells how:

* **occluded**: the pixel outside is nearer the camera (by more than `jump_m`): something in
  front hides the rest; the object may go on behind it;
* **open**: the pixel outside is farther (or has no depth), or is a different surface at about
  the same depth (its normal turned by more than `max_turn_deg`, or off the region's tangent
  plane by more than `plane_m`): the object ends there (its silhouette, or where it stands on
  a floor or touches a neighbour);
* **continued**: the same surface goes on, at the same depth and in the same plane, in another
  colour: the region is a patch of a larger surface of another colour (seed 3131 level 3 scene
  8: the lit part of an orange book's side read as yellow), not an object of the query's
  colour whose rest is hidden.

Pure functions on the image's arrays; the detector calls `cut_kinds` for the regions it cannot
judge whole (`detector.Verdict.TENTATIVE`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .target import surface_normals


@dataclass(frozen=True)
class CutKinds:
    """Shares (summing to 1) of the pixels just outside a region's outline inside the image
    that are occluded / open / continued (see the module docstring); n: their number."""

    occluded: float
    open: float
    continued: float
    n: int


def cut_kinds(depth: np.ndarray, points: np.ndarray, region: np.ndarray, sl: tuple[slice, slice],
              ring_px: int = 3, jump_m: float = 0.015, plane_m: float = 0.005,
              max_turn_deg: float = 25.0, step: int = 2) -> CutKinds:
    """The kinds of the pixels `ring_px - 1` .. `ring_px` px outside a region.

    depth (H, W) z-depth [m] (0, inf or NaN: none); points (H, W, 3) the image's world points
    [m] (NaN where no depth); region (h, w) bool, the region's pixels in the window sl of the
    image. Each outside pixel is compared with its nearest region pixel: depth difference
    (`jump_m`), then the angle between their surface normals (`surface_normals` with `step`)
    and the outside point's distance from the region pixel's tangent plane (`plane_m`)."""
    H, W = depth.shape
    pad = ring_px + step + 1
    r0, r1 = max(0, sl[0].start - pad), min(H, sl[0].stop + pad)
    c0, c1 = max(0, sl[1].start - pad), min(W, sl[1].stop + pad)
    win = np.zeros((r1 - r0, c1 - c0), bool)
    win[sl[0].start - r0:sl[0].stop - r0, sl[1].start - c0:sl[1].stop - c0] = region
    ring = ndimage.binary_dilation(win, iterations=ring_px) & ~ndimage.binary_dilation(win, iterations=ring_px - 1)
    rr, rc = np.nonzero(ring)
    if len(rr) == 0:
        return CutKinds(0.0, 1.0, 0.0, 0)
    _, (ir, ic) = ndimage.distance_transform_edt(~win, return_indices=True)
    nr, nc = ir[rr, rc], ic[rr, rc]  # nearest region pixel of each ring pixel
    d = np.asarray(depth[r0:r1, c0:c1], np.float64)
    d_out, d_in = d[rr, rc], d[nr, nc]
    has = np.isfinite(d_out) & (d_out > 0)
    dz = np.where(has, d_out - d_in, np.inf)
    occluded = dz < -jump_m
    same_depth = np.abs(dz) <= jump_m
    P = points[r0:r1, c0:c1]
    N, ok = surface_normals(P, step, max_jump=jump_m)
    both = same_depth & ok[rr, rc] & ok[nr, nc]
    n_in, n_out = N[nr, nc], N[rr, rc]
    cos_turn = np.abs(np.sum(n_in * n_out, axis=1))
    off_plane = np.abs(np.sum((P[rr, rc] - P[nr, nc]) * n_in, axis=1))
    with np.errstate(invalid="ignore"):
        continued = both & (cos_turn >= np.cos(np.radians(max_turn_deg))) & (off_plane <= plane_m)
    n = len(rr)
    n_occ, n_cont = int(occluded.sum()), int(continued.sum())
    return CutKinds(n_occ / n, (n - n_occ - n_cont) / n, n_cont / n, n)
