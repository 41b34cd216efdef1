"""Target detection from RGB + depth + camera pose, against a `TargetQuery`.

`AppearanceDetector` finds image regions of the query's colour, back-projects them with
depth, and checks the region's 3D shape class (planar faces for boxes, a curved side for
round objects, doubly curved surface for spheres) and its size against the query. It never
sees simulator labels. Every region of the right colour is reported as a `Detection` with
a `Verdict`: ACCEPTED regions may end exploration; TENTATIVE ones (a match of which less than
`confirm_completeness` shows: its extents are lower bounds, so the size test cannot tell it
from a larger object of that colour cut by an occluder) wait for a confirming frame
(`perception.confirm`, run by the detection buffer) and are points of interest meanwhile;
PARTIAL ones (too little of the object visible to judge) become points of interest for the
exploration; the others are rejected distractors.

Plug-in point for a learned open-vocabulary detector (e.g. YOLO-World, where weights
exist): implement `BoxModel` (RGB image + the query's text -> 2D boxes and scores) and wrap
it in `BoxModelDetector`, which turns boxes into `Detection`s with depth; register the
factory in `DETECTORS`. Anything with `__call__(obs, query) -> tuple[Detection, ...]` is a
detector.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np
from scipy import ndimage

from ..errors import CompassInputError, check_field_types, check_ranges
from ..task import TargetQuery
from ..types import Observation
from .colour import ColourMaskCache, colour_mask  # noqa: F401 (colour_mask: part of this module's API)
from .cut import CutKinds, cut_kinds
from .shape import classify_shape, curved_like  # noqa: F401 (classify_shape: part of this module's API)
from .target import backproject_image, region_normals, upright_extents

#: Shape classes of a TargetQuery grouped by the surface a depth camera sees.
SHAPE_FAMILY = {"box": "box", "book": "box", "cereal_box": "box", "cylinder": "round", "can": "round",
                "bottle": "round", "mug": "round", "bowl": "round", "sphere": "sphere"}


def exceeds_size(ext, size, tolerance: float, slack: float) -> bool:
    """Whether upright extents ext (major horizontal, minor horizontal, height) [m] exceed a
    query's size (a, b, c) [m]: the height c, or the major extent the horizontal diagonal
    hypot(a, b), by more than the share `tolerance` plus `slack` [m]."""
    a, b, c = (float(v) for v in size)
    tol = 1.0 + tolerance
    return bool(ext[2] > c * tol + slack or ext[0] > math.hypot(a, b) * tol + slack)


class Verdict(enum.Enum):
    ACCEPTED = "accepted"
    TENTATIVE = "tentative"  # a match, but not clearly whole: accepted once confirmed (perception.confirm)
    PARTIAL = "partial"  # right colour, nothing contradicts the query, too little seen
    WRONG_SHAPE = "wrong shape"
    WRONG_SIZE = "wrong size"


@dataclass(frozen=True)
class DetectorConfig:
    """colour_max_angle_deg: largest angle between a pixel's RGB vector and the query
    colour's (shading scales RGB, so the direction carries the colour); min_value: darkest
    pixel considered (max channel in [0, 1]); min_pixels: smallest region; max_depth [m];
    planar_fraction_box / planar_fraction_round: fraction of side normals within
    `mode_halfwidth_deg` of the two dominant horizontal directions above which a region is a
    box, below which it is round; sphere_slant_fraction: fraction of slanted normals above
    which it is a sphere; min_side_pixels for a shape verdict; size_tolerance: measured
    extents may exceed the query's by this fraction (+ size_slack [m]); min_completeness:
    visible height and width over the query's needed to accept (0.3, as a good view sees 30 % of
    the target: with 0.6 a bottle of which only the neck and shoulder show above a box in front
    never passed; on the seed-101 side-by-side 0.3 accepted no wrong object); border_px: a region
    within this many pixels of the image border is cut by it: its extents along the cut are
    lower bounds, so the size test cannot tell it from a larger object of the same colour and
    shape, and it is partial (a point of interest) unless border_completeness is set, in which
    case it is accepted when at least that share of the object shows (0.75 from 2026-11-22 until
    2026-11-24: on seed 9191 level 1 scene 3 it accepted the corner of a white cereal box, 8.1 x
    11.4 cm of it in the image's corner, as the 4.7 x 4.6 x 13.5 cm white box queried);
    min_curvature_ratio: a region classed round must deviate from its best plane by at least
    this share of what a cylinder of the query's radius would over the same visible width
    (`shape.curved_like`), else its side is flat (a sliver of a box face is not a can);
    confirm_completeness: a match showing less than this share of the query's height or width
    (but at least min_completeness) is TENTATIVE, accepted only when a later frame confirms it
    (`perception.confirm`; None: accepted at once, the rule until 2026-11-24: on fresh seed 3131
    level 3 scene 8 it accepted, at the first frame, a 4.0 x 3.6 cm lit slice of an orange book's
    side read as yellow, completeness 0.33, as the 5.6 x 5.5 x 10.9 cm yellow box queried);
    max_continued: a TENTATIVE or WRONG_SHAPE region whose outline lies for at least this share
    on a surface that goes on in another colour (`cut.cut_kinds`: same depth, same plane) is a
    patch of a larger surface (`Detection.patch`): a TENTATIVE one is PARTIAL instead (a point
    of interest, never accepted), a WRONG_SHAPE one supports no confirmation (None: off, the
    rule until 2026-11-24's fourth session; the book's slice above has 41-52 % of its outline
    on the book's side, and no region of a target in 35 find-only trials more than 0 %);
    hue_check: a pixel of a chromatic query colour must also have its hue nearest that
    colour's among the palette's chromatic colours (`colour.nearest_hue`; brown, white and grey
    are not in that contest). A white highlight turns the RGB direction towards white, not
    the hue: on the default set's level 1 scene 11 (FV) the lit top of an orange cereal box,
    mean RGB (230, 165, 63), 6.2 deg from yellow's direction and 12.6 deg from orange's, was
    accepted as the yellow box queried; its hue is 36.7 deg, orange's 30, yellow's 50.8 (False:
    the direction test alone, the rule until 2026-11-24's fifth session)."""

    colour_max_angle_deg: float = 10.0
    min_value: float = 0.12
    min_pixels: int = 40
    max_depth: float = 1.6
    planar_fraction_box: float = 0.8
    planar_fraction_round: float = 0.6
    mode_halfwidth_deg: float = 7.0
    sphere_slant_fraction: float = 0.35
    min_side_pixels: int = 30
    size_tolerance: float = 0.2
    size_slack: float = 0.01
    min_completeness: float = 0.3
    border_px: int = 2
    border_completeness: float | None = None
    min_curvature_ratio: float = 0.5
    max_points: int = 3000
    confirm_completeness: float | None = 0.6
    max_continued: float | None = 0.3
    hue_check: bool = True

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, min_value=(0.0, 1.0, ""), max_depth=(0.01, 20.0, "m"),
                     planar_fraction_box=(0.0, 1.0, ""), planar_fraction_round=(0.0, 1.0, ""),
                     mode_halfwidth_deg=(0.0, 90.0, "deg"), sphere_slant_fraction=(0.0, 1.0, ""),
                     size_tolerance=(0.0, 10.0, ""), size_slack=(0.0, 0.5, "m"),
                     min_curvature_ratio=(0.0, 10.0, ""))
        if not 0 < self.colour_max_angle_deg < 45:
            raise CompassInputError(f"colour_max_angle_deg {self.colour_max_angle_deg} must be in (0, 45)")
        if self.border_completeness is not None and not 0 < self.border_completeness <= 1:
            raise CompassInputError(f"border_completeness {self.border_completeness} must be in (0, 1] or None")
        if not 0 < self.min_completeness <= 1:
            raise CompassInputError(f"min_completeness {self.min_completeness} must be in (0, 1]")
        if self.confirm_completeness is not None and not (
                isinstance(self.confirm_completeness, (int, float)) and not isinstance(self.confirm_completeness, bool)
                and self.min_completeness <= self.confirm_completeness <= 1):
            raise CompassInputError(f"confirm_completeness {self.confirm_completeness!r} must be in "
                                    f"[min_completeness = {self.min_completeness}, 1] or None")
        m = self.max_continued
        if m is not None and (isinstance(m, bool) or not isinstance(m, (int, float)) or not 0 < m <= 1):
            raise CompassInputError(f"max_continued {m!r} is not allowed; use a share in (0, 1] or None")
        if self.min_pixels < 1:
            raise CompassInputError(f"min_pixels {self.min_pixels} must be >= 1")
        if not isinstance(self.hue_check, bool):
            raise CompassInputError(f"hue_check {self.hue_check!r} is not allowed; use True or False")


@dataclass(frozen=True, eq=False)
class Detection:
    """One image region of the query's colour.

    t [s] and T_world_cam of its image; bbox (u0, v0, u1, v1) [px] inclusive; centre_px
    (u, v) of the box; n_pixels; points_world (N, 3) [m] (subsampled); centroid_world (3,);
    extents (major horizontal, minor horizontal, vertical) [m]; shape: 'box' | 'round' |
    'sphere' | 'unknown' as seen; score in [0, 1] (completeness of the view); verdict; cut:
    what cuts a TENTATIVE or WRONG_SHAPE region off (`cut.cut_kinds`; None for the others);
    patch: the region is a patch of a larger surface of another colour (`max_continued`).
    """

    t: float
    T_world_cam: np.ndarray
    bbox: tuple[int, int, int, int]
    centre_px: tuple[float, float]
    n_pixels: int
    points_world: np.ndarray
    centroid_world: np.ndarray
    extents: tuple[float, float, float]
    shape: str
    score: float
    verdict: Verdict
    cut: CutKinds | None = None
    patch: bool = False

    @property
    def accepted(self) -> bool:
        return self.verdict is Verdict.ACCEPTED

    def centre_offset(self, image_size: tuple[int, int]) -> float:
        """Distance [px] from the box centre to the image centre; image_size (W, H)."""
        W, H = image_size
        return float(math.hypot(self.centre_px[0] - (W - 1) / 2, self.centre_px[1] - (H - 1) / 2))


class Detector(Protocol):
    def __call__(self, obs: Observation, query: TargetQuery) -> tuple[Detection, ...]: ...


class AppearanceDetector:
    """Colour + 3D shape class + size detector (see the module docstring). `__call__`
    takes the observation's world points when its caller has them (`takes_points_world`)."""

    takes_points_world = True

    def __init__(self, config: DetectorConfig | None = None) -> None:
        self.config = config or DetectorConfig()
        self._colours = ColourMaskCache(self.config)
        self._last: tuple | None = None  # (rgb array, colour, its colour mask): the last image's

    def _colour_mask(self, rgb: np.ndarray, colour: str) -> np.ndarray:
        """A new array equal to `self._colours(rgb, colour)`; the mask of the last image asked
        for is kept (with a reference to that image), so `may_detect` and `__call__` on the same
        observation compute it once (an observation's arrays are never written to)."""
        last = self._last
        if last is not None and last[0] is rgb and last[1] == colour:
            return last[2].copy()
        mask = self._colours(rgb, colour)
        self._last = (rgb, colour, mask.copy())
        return mask

    def may_detect(self, obs: Observation, query: TargetQuery) -> bool:
        """False when this detector finds nothing in obs nor in obs with the depth of any
        pixels removed (fewer than min_pixels pixels of the query's colour with depth in
        range; removing depth only removes pixels). `SelfMaskedDetector` then skips its
        self mask: the same (empty) result for less work."""
        if obs.rgb is None:
            return True  # __call__ says what is wrong
        depth = np.asarray(obs.depth, dtype=np.float32)
        mask = self._colour_mask(obs.rgb, query.colour)
        mask &= np.isfinite(depth) & (depth > 0) & (depth <= self.config.max_depth)
        return bool(mask.sum() >= self.config.min_pixels)

    def __call__(self, obs: Observation, query: TargetQuery, points_world: np.ndarray | None = None
                 ) -> tuple[Detection, ...]:
        """points_world: `backproject_image(obs.depth, obs.K, obs.T_world_cam)[0]` (H, W, 3) [m]
        when the caller has it (the self mask), else computed here."""
        if obs.rgb is None:
            raise CompassInputError("AppearanceDetector needs an RGB image; the observation has none")
        config = self.config
        depth = np.asarray(obs.depth, dtype=np.float32)
        mask = self._colour_mask(obs.rgb, query.colour)  # = colour_mask(obs.rgb, query.colour, config)
        mask &= np.isfinite(depth) & (depth > 0) & (depth <= config.max_depth)
        if mask.sum() < config.min_pixels:
            return ()
        labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        keep = [k for k in range(1, n + 1) if sizes[k] >= config.min_pixels]
        if not keep:
            return ()
        pts = backproject_image(depth, obs.K, obs.T_world_cam)[0] if points_world is None else points_world
        slices = ndimage.find_objects(labels)
        out = [self._region(obs, labels, k, slices[k - 1], pts, query) for k in keep]
        return tuple(out)

    def _needed_completeness(self, at_border: bool) -> float:
        """The share of the query's height and width a region must show to be accepted (inf:
        never, for a region cut by the image border unless `border_completeness` is set)."""
        if not at_border:
            return self.config.min_completeness
        return math.inf if self.config.border_completeness is None else self.config.border_completeness

    def _region(self, obs, labels, k, sl, pts, query) -> Detection:
        config = self.config
        H, W = labels.shape
        sub = labels[sl] == k
        rows, cols = np.nonzero(sub)
        rows, cols = rows + sl[0].start, cols + sl[1].start
        P = pts[rows, cols]
        nrm, nok = region_normals(pts, sl)  # the region's window only (same values as the whole image's)
        inner = ndimage.binary_erosion(sub, iterations=2)
        ir, ic = np.nonzero(inner & nok)
        inner_pts = pts[sl][ir, ic]
        shape = classify_shape(nrm[ir, ic], inner_pts, obs.T_world_cam[:3, 3], config)
        ext = upright_extents(P)
        a, b, c = (float(v) for v in query.size)
        if shape == "round" and not curved_like(inner_pts, 0.5 * min(a, b), ext[0], config.min_curvature_ratio):
            shape = "box"  # normals spread by the region's edges, but the surface is a plane
        too_big = exceeds_size(ext, query.size, config.size_tolerance, config.size_slack)
        completeness = min(1.0, ext[2] / c, ext[0] / b)
        u0, u1, v0, v1 = int(cols.min()), int(cols.max()), int(rows.min()), int(rows.max())
        at_border = (u0 < config.border_px or v0 < config.border_px or u1 >= W - config.border_px
                     or v1 >= H - config.border_px)
        family = SHAPE_FAMILY[query.shape]
        if too_big:
            verdict = Verdict.WRONG_SIZE
        elif shape not in ("unknown", family):
            verdict = Verdict.WRONG_SHAPE
        elif shape == family and completeness >= self._needed_completeness(at_border):
            whole = config.confirm_completeness is None or completeness >= config.confirm_completeness
            verdict = Verdict.ACCEPTED if whole else Verdict.TENTATIVE
        else:
            verdict = Verdict.PARTIAL
        cut = cut_kinds(obs.depth, pts, sub, sl) if verdict in (Verdict.TENTATIVE, Verdict.WRONG_SHAPE) else None
        patch = cut is not None and config.max_continued is not None and cut.continued >= config.max_continued
        if patch and verdict is Verdict.TENTATIVE:
            verdict = Verdict.PARTIAL
        if len(P) > config.max_points:
            P = P[np.linspace(0, len(P) - 1, config.max_points).astype(int)]
        return Detection(
            t=float(obs.t), T_world_cam=np.asarray(obs.T_world_cam), bbox=(u0, v0, u1, v1),
            centre_px=((u0 + u1) / 2, (v0 + v1) / 2), n_pixels=int(len(rows)), points_world=P,
            centroid_world=P.mean(axis=0), extents=ext, shape=shape, score=float(completeness), verdict=verdict,
            cut=cut, patch=patch,
        )


class BoxModel(Protocol):
    """A learned open-vocabulary detector: (H, W, 3) uint8 RGB and a text prompt ->
    boxes (N, 4) [px] as (u0, v0, u1, v1) and scores (N,) in [0, 1]."""

    def __call__(self, rgb: np.ndarray, text: str) -> tuple[np.ndarray, np.ndarray]: ...


class BoxModelDetector:
    """Adapter from a `BoxModel` to `Detection`s: the box's depth pixels nearest the camera
    (within `depth_band` [m] of the box's 20th depth percentile) are the object's points;
    boxes scoring >= accept_score are ACCEPTED, those >= hint_score PARTIAL."""

    def __init__(self, model: BoxModel, accept_score: float = 0.5, hint_score: float = 0.2,
                 depth_band: float = 0.05) -> None:
        self.model, self.accept_score, self.hint_score, self.depth_band = model, accept_score, hint_score, depth_band

    def __call__(self, obs: Observation, query: TargetQuery) -> tuple[Detection, ...]:
        boxes, scores = self.model(obs.rgb, query.text)
        pts, valid = backproject_image(obs.depth, obs.K, obs.T_world_cam)
        H, W = obs.depth.shape
        out = []
        for (u0, v0, u1, v1), s in zip(np.asarray(boxes, dtype=float).reshape(-1, 4), np.asarray(scores, float)):
            if s < self.hint_score:
                continue
            u0, v0 = max(0, int(u0)), max(0, int(v0))
            u1, v1 = min(W - 1, int(u1)), min(H - 1, int(v1))
            if u1 < u0 or v1 < v0:
                continue
            d = np.asarray(obs.depth[v0:v1 + 1, u0:u1 + 1], float)
            ok = valid[v0:v1 + 1, u0:u1 + 1]
            if not ok.any():
                continue
            near = ok & (d <= np.percentile(d[ok], 20) + self.depth_band)
            P = pts[v0:v1 + 1, u0:u1 + 1][near]
            out.append(Detection(
                t=float(obs.t), T_world_cam=np.asarray(obs.T_world_cam), bbox=(u0, v0, u1, v1),
                centre_px=((u0 + u1) / 2, (v0 + v1) / 2), n_pixels=int(near.sum()), points_world=P,
                centroid_world=P.mean(axis=0), extents=upright_extents(P), shape="unknown", score=float(s),
                verdict=Verdict.ACCEPTED if s >= self.accept_score else Verdict.PARTIAL,
            ))
        return tuple(out)


#: Detector factories by name (config -> detector). The oracle detector used for
#: ablations lives in `sim.oracle` and is wired in by the trial runner, never here.
DETECTORS: dict[str, Callable[[DetectorConfig], Detector]] = {
    "appearance": lambda config: AppearanceDetector(config),
}
