"""Confirmation of TENTATIVE matches across frames (run by `buffer.DetectionBuffer`).

A TENTATIVE detection (`detector.Verdict`) matches the query in colour and shape family, but
less than `DetectorConfig.confirm_completeness` of it shows: a region cut by an occluder (or
by a colour change on a larger surface) has extents that are only lower bounds, so the size
test cannot tell the target from a larger object of the same colour. One frame never accepts
it. `Confirmer` keeps the places of tentative matches (candidates: their points, fused over
frames, and the camera positions that saw them) and, frame by frame, in order:

* drops (vetoes) a candidate when a region of the query's colour judged WRONG_SIZE covers it
  (at least half of the candidate's points within `overlap_m` of that region's points): a
  larger object of that colour is seen at that place. A WRONG_SHAPE region does not: the
  shape class of a slice flips between frames (seed 9191 level 2 scene 1: the 3.6 x 8.6 cm
  neck of the bottle queried, seen over a box, was 'round' in 9 frames and 'box' in 16 of
  the same motion, and a veto by shape lost that find);
* confirms a tentative detection when its centroid lies within `radius` (a share of the
  query's diagonal) of a candidate's, its camera is at least `baseline_m` from some camera
  that saw the candidate (a second, independent viewpoint) and the candidate's points with
  the detection's still fit the query's size (at most `size_tolerance` larger + 1 cm): the
  detection becomes ACCEPTED (its frame's time is the time found);
* a region of the query's colour and size classed another shape (WRONG_SHAPE, at least
  `support_completeness` of the query showing, not a patch of a larger surface of another
  colour: `Detection.patch`) is a supporting view of the same place: it
  joins or starts a candidate like a tentative one and confirms one that a tentative view
  (the right shape class) started or joined, under the same conditions; it is then the
  ACCEPTED detection (its shape as seen kept). On the severe levels the neck of the bottle
  queried is classed 'box' in most frames and 'round' in a few (seed 9191 level 4: with
  tentative views only, three finds came 40-140 s later or never);
* else a fused size too large vetoes the candidate, and a view from too near the
  candidate's cameras joins it; a view near no candidate starts one.

* a candidate with a tentative view that nothing confirmed nor vetoed for `accept_after_s` of
  simulated time (a frame that late is processed) is accepted then, with its latest tentative
  view (`due`; the detection's time set to that frame's: the time found). On the severe levels
  the views that see 30 % of the target lie within a few centimetres of each other (seed 9191
  level 4 scene 1: 8 frames within 3.4 cm, then none for 85 s; scene 2: one frame in 200 s), so
  without this some finds are lost; a larger object of that colour is usually seen larger
  within that time (None: never accepted this way).

When the exploration stops (no reachable view, nothing left to explore) before that, the
trial accepts what is waiting (`DetectionBuffer.accept_waiting`): no confirming view can be
had any more (seed 5151 level 2 scene 0: IG, which ignores points of interest, stopped 30 s
after its only tentative view and lost the find without this).

A vetoed candidate is kept so that later tentative matches at its place are never confirmed.
Matches seen whole (ACCEPTED by the detector) are not touched. Everything depends on the
frames' order and content only, so a seed still gives one trial.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from ..errors import CompassInputError, check_field_types
from ..task import TargetQuery
from .detector import Detection, Verdict, exceeds_size
from .target import upright_extents

_CONTRADICTING = (Verdict.WRONG_SIZE,)


@dataclass(frozen=True)
class ConfirmConfig:
    """baseline_m [m]: least distance between the camera of a confirming frame and some camera
    that saw the candidate; radius: a confirming detection's centroid within this share of the
    query's diagonal of the candidate's; size_tolerance: the fused points' upright extents may
    exceed the query's by this share (+ 1 cm); overlap_m [m]: a candidate point is covered by a
    contradicting region within this distance; support_completeness: least completeness of a
    WRONG_SHAPE region that counts as a supporting view (the detector's min_completeness, 0.3);
    accept_after_s [s]: simulated time after its first tentative view at which a candidate
    nothing confirmed nor vetoed is accepted (None: never); max_points: points kept per candidate."""

    baseline_m: float = 0.05
    radius: float = 0.5
    size_tolerance: float = 0.2
    overlap_m: float = 0.01
    support_completeness: float = 0.3
    accept_after_s: float | None = 30.0
    max_points: int = 3000

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        checks = (("baseline_m", 0.0, 1.0), ("radius", 0.05, 2.0), ("size_tolerance", 0.0, 1.0),
                  ("overlap_m", 0.001, 0.1), ("support_completeness", 0.0, 1.0))
        for name, lo, hi in checks:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
                raise CompassInputError(f"confirm {name} {v!r} is not allowed; use {lo}..{hi}")
        a = self.accept_after_s
        if a is not None and (isinstance(a, bool) or not isinstance(a, (int, float)) or not 0.0 < a <= 3600.0):
            raise CompassInputError(f"confirm accept_after_s {a!r} is not allowed; use 0..3600 s or None")
        n = self.max_points
        if isinstance(n, bool) or not isinstance(n, int) or not 10 <= n <= 100000:
            raise CompassInputError(f"confirm max_points {self.max_points!r} is not allowed; use 10..100000")


@dataclass(eq=False)
class Candidate:
    """The place of a tentative match: points (N, 3) [m] fused over its frames, the camera
    positions (M, 3) [m] that saw it, its first time t [s]; matched: a view of the right
    shape class (TENTATIVE) is among them; vetoed: a larger object of the query's colour was
    seen there."""

    points: np.ndarray
    cameras: list[np.ndarray]
    t: float
    matched: bool = True
    vetoed: bool = False
    n_frames: int = 1
    last: tuple | None = None  # (detection, observation) of its latest tentative view
    t_matched: float | None = None  # time [s] of its first tentative view
    accepted: bool = False
    centroid: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.centroid = self.points.mean(axis=0)


class Confirmer:
    """Turns a frame's TENTATIVE detections into ACCEPTED ones once confirmed (see the module
    docstring); `confirmed` counts them, `candidates` are the places seen so far."""

    def __init__(self, query: TargetQuery, config: ConfirmConfig | None = None) -> None:
        self.query, self.config = query, config or ConfirmConfig()
        size = np.asarray(query.size, float)
        self.radius_m = self.config.radius * float(np.linalg.norm(size))
        self.candidates: list[Candidate] = []
        self.confirmed = 0

    def __call__(self, detections: tuple[Detection, ...], obs=None) -> tuple[Detection, ...]:
        """The frame's detections (of observation obs), each TENTATIVE one that is confirmed
        now ACCEPTED."""
        for d in detections:
            if d.verdict in _CONTRADICTING:
                self._contradict(d)
        return tuple(self._view(d, obs) if self._is_view(d) else d for d in detections)

    def due(self, t: float, now: bool = False) -> list[tuple[Detection, object]]:
        """(ACCEPTED detection, its observation) of each candidate whose first tentative view
        is at least accept_after_s before t [s] (now=True: whatever its age, when no view to
        confirm it can be had) and that nothing vetoed; the detection's time is t (each
        candidate is accepted once)."""
        wait = self.config.accept_after_s
        out = []
        for c in self.candidates:
            if c.vetoed or c.accepted or c.last is None:
                continue
            if not now and (wait is None or t - c.t_matched < wait):
                continue
            c.accepted = True
            self.confirmed += 1
            d, obs = c.last
            out.append((replace(d, verdict=Verdict.ACCEPTED, t=float(t)), obs))
        return out

    def _is_view(self, d: Detection) -> bool:
        return d.verdict is Verdict.TENTATIVE or (
            d.verdict is Verdict.WRONG_SHAPE and d.score >= self.config.support_completeness and not d.patch)

    def _contradict(self, d: Detection) -> None:
        P = np.asarray(d.points_world, float).reshape(-1, 3)
        if len(P) == 0:
            return
        tree = None
        for c in self.candidates:
            if c.vetoed or np.linalg.norm(P - c.centroid, axis=1).min() > self.radius_m:
                continue
            tree = cKDTree(P) if tree is None else tree
            near = tree.query(c.points, distance_upper_bound=self.config.overlap_m)[0] <= self.config.overlap_m
            if near.mean() >= 0.5:
                c.vetoed = True

    def fits(self, points: np.ndarray) -> bool:
        """Whether points (N, 3) [m] fit in the query's size (upright extents at most
        size_tolerance larger + 1 cm; the major horizontal extent against the diagonal)."""
        return not exceeds_size(upright_extents(points), self.query.size, self.config.size_tolerance, 0.01)

    def _view(self, d: Detection, obs=None) -> Detection:
        """d (TENTATIVE, or a supporting WRONG_SHAPE view) as it stands after this frame."""
        matched = d.verdict is Verdict.TENTATIVE
        P = np.asarray(d.points_world, float).reshape(-1, 3)
        cam = np.asarray(d.T_world_cam, float)[:3, 3]
        near = [c for c in self.candidates if np.linalg.norm(c.centroid - d.centroid_world) <= self.radius_m]
        for c in near:
            if c.vetoed:
                continue
            fused = np.vstack([c.points, P])
            if not self.fits(fused):
                c.vetoed = True
                continue
            baseline = max(float(np.linalg.norm(cam - k)) for k in c.cameras)
            if (matched or c.matched) and baseline >= self.config.baseline_m:
                self.confirmed += 1
                return replace(d, verdict=Verdict.ACCEPTED)
        if near:
            c = near[0]
            c.points = self._thin(np.vstack([c.points, P]))
            c.cameras.append(cam)
            c.n_frames += 1
            c.matched = c.matched or matched
            c.centroid = c.points.mean(axis=0)
        elif len(P):
            c = Candidate(self._thin(P), [cam], float(d.t), matched)
            self.candidates.append(c)
        else:
            return d
        if matched:
            c.last = (d, obs)
            c.t_matched = float(d.t) if c.t_matched is None else c.t_matched
        return d

    def _thin(self, P: np.ndarray) -> np.ndarray:
        n = self.config.max_points
        return P if len(P) <= n else P[np.linspace(0, len(P) - 1, n).astype(int)]
