"""Antipodal parallel-jaw grasp candidates on the target model, scored as GraspNet labels
grasps, and the plug-in point for a learned grasp network.

A candidate is the paper's g = (e, w, s): e the TCP pose (hand frame convention: z the
approach, from the palm towards the fingertips; y the closing line; x = y x z), w the
contact width [m] and s the GraspNet score (`quality.graspnet_score`). Sampling: a first
contact p1 on the surface, the closing direction into the object along its inward normal,
the second contact p2 the farthest surface point on that line (within `line_radius`) whose
normal faces along it; the pair is kept when w fits the hand with clearance, nothing of the
target lies outside the contacts on the closing line, and nothing of it reaches the palm.
Each pair gives `n_rolls` approach directions around the closing line, each with the hand
both ways round (the fingers are symmetric; the wrist camera on one side of the hand is not).
"""
from __future__ import annotations

import inspect
import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numba import njit, prange

from ..errors import CompassInputError, check_field_types, check_ranges
from ..robot.model import GRIPPER_MAX_WIDTH
from .hand_volume import PAD_BACK, PAD_TIP, depth_keep, palm_clear
from .quality import graspnet_score, graspnet_score_cones
from .target import TargetModel, normal_cones


@dataclass(frozen=True)
class CandidateConfig:
    """n_contacts first contacts sampled; n_directions closing directions per first contact:
    the inward normal and n_directions - 1 drawn within `cone` [rad] of it (GraspNet labels
    the whole spectrum of friction needs, not only perfect antipodal pairs); n_rolls
    approach directions per contact pair;
    line_radius [m]: second-contact search radius around the closing line; width_clearance
    [m]: free opening beyond the contacts on each side (w + 2 clearance <= 0.08 m);
    min_width [m]; depths [m]: TCP offsets along the approach past the contact midpoint;
    top_fraction of the first contacts drawn within top_band [m] of the target's top;
    top_margin [m]: both contacts at least this far below the target's highest point (0:
    not checked; a contact in the top layer of points lies on the rim of the top face, an
    edge, where the PCA normals blend the top and the side); max_tilt [rad]: the closing
    line within this angle of the horizontal (None: not checked; a flat pad on a vertical
    side under a tilted closing line touches it along one of its own edges). Both off by
    default: on levels 1 + 3 of seed 0 they turned the executed grasps that dropped or
    slipped into selection failures without a grasp gained (docs/grasping_log.md, branch
    gmod).
    Depths (GraspNet samples several per approach): a pair's hand is placed at each depth d
    [m] (the contacts d behind the TCP, on the pads while d <= PAD_BACK - 5 mm); a deeper one
    (d > 0) is kept only when the target's points between the pads (`pad_section`) stay
    within the hand's opening; and where some depth of a pair's approach puts the section's
    centre (the mean along the approach of the target's points between the pads: a round
    target's axis) at least `centre_margin` [m] inside the fingertips, the depths that do not
    are dropped (level 3 scene 6 of seed 0: a front chord of a bottle at d = 0, its axis 2 mm
    beyond the fingertips in truth, was wedged out of the pads); opening_all: the opening
    test at every depth, d = 0 too (off: it was not measured in full runs).
    edge_angle [rad] (None: off): a contact whose neighbours within edge_radius [m] (its
    edge_k - 1 nearest) have normals more than edge_angle from its own is on an edge, and the
    pair is scored with every normal of its cone (`target.normal_cones`,
    `quality.graspnet_score_cones`) instead of its blended PCA normal.
    Both off by default (`DEEP_EDGE` turns them on): on levels 1 + 3 of seed 0 together they
    grasped 35/40 against 34/40, but 16/20 against 17/20 on the fresh scenes 10-19
    (docs/grasping_log.md, branch gdeep)."""

    n_contacts: int = 120
    n_directions: int = 4
    cone: float = 0.75
    n_rolls: int = 16
    line_radius: float = 0.004
    width_clearance: float = 0.006
    min_width: float = 0.01
    depths: tuple[float, ...] = (0.0,)
    centre_margin: float = 0.005
    top_fraction: float = 0.5
    top_band: float = 0.05
    top_margin: float = 0.0
    max_tilt: float | None = None
    edge_angle: float | None = None
    edge_radius: float = 0.006
    edge_k: int = 9
    opening_all: bool = False

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, line_radius=(0.0, 0.1, "m"))
        if not self.depths or any(not 0.0 <= d <= PAD_BACK - 0.005 for d in self.depths):
            raise CompassInputError(f"depths {self.depths} m are not allowed; give at least one in "
                                    f"0..{PAD_BACK - 0.005:.3f} m (the contacts must stay on the pads)")
        if not 0.0 <= self.centre_margin <= PAD_TIP + PAD_BACK:
            raise CompassInputError(f"centre_margin {self.centre_margin} m is not allowed; use 0..0.044 m")
        if self.edge_angle is not None and not 0.0 < self.edge_angle < np.pi / 2:
            raise CompassInputError(f"edge_angle {self.edge_angle} rad is not allowed; use (0, pi/2) or None")
        if not 0.0 < self.edge_radius <= 0.05 or not 2 <= self.edge_k <= 64:
            raise CompassInputError(f"edge_radius {self.edge_radius} m / edge_k {self.edge_k} not allowed; "
                                    "use (0, 0.05] m and 2..64")
        if not 0.0 <= self.top_margin <= 0.05:
            raise CompassInputError(f"top_margin {self.top_margin} m is not allowed; use 0..0.05 m")
        if self.max_tilt is not None and not 0.0 <= self.max_tilt <= np.pi / 2:
            raise CompassInputError(f"max_tilt {self.max_tilt} rad is not allowed; use [0, pi/2] or None")
        if not 1 <= self.n_directions <= 100 or not 0.0 <= self.cone < np.pi / 2:
            raise CompassInputError(f"n_directions {self.n_directions} / cone {self.cone} rad not allowed; "
                                    "use 1..100 and [0, pi/2)")
        if not 1 <= self.n_contacts <= 100000 or not 1 <= self.n_rolls <= 360:
            raise CompassInputError(f"n_contacts {self.n_contacts} / n_rolls {self.n_rolls} not allowed; "
                                    "use 1..100000 and 1..360")
        if not 0.0 <= self.top_fraction <= 1.0 or not 0.0 < self.top_band <= 1.0:
            raise CompassInputError(f"top_fraction {self.top_fraction} / top_band {self.top_band} m not allowed; "
                                    "use 0..1 and (0, 1] m")
        if not 0.0 <= 2 * self.width_clearance + self.min_width < GRIPPER_MAX_WIDTH:
            raise CompassInputError(f"min_width {self.min_width} m + 2 x width_clearance {self.width_clearance} m "
                                    f"must stay below the hand's opening {GRIPPER_MAX_WIDTH} m")

    @property
    def max_width(self) -> float:
        """Widest contact pair [m] accepted."""
        return GRIPPER_MAX_WIDTH - 2 * self.width_clearance


#: The options of branch gdeep: depth samples 0, 1 and 2 cm and edge cones at 30 deg
#: (`CandidateConfig(**DEEP_EDGE)`).
DEEP_EDGE = {"depths": (0.0, 0.01, 0.02), "edge_angle": math.radians(30.0)}


@dataclass(frozen=True, eq=False)
class GraspCandidates:
    """M candidates: T_world_tcp (M,4,4), width (M,) [m], score (M,) GraspNet s, contacts
    p1, p2 (M,3) [m] and their outward normals n1, n2 (M,3)."""

    T_world_tcp: np.ndarray
    width: np.ndarray
    score: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    n1: np.ndarray
    n2: np.ndarray

    def __len__(self) -> int:
        return int(self.width.shape[0])

    @property
    def approach(self) -> np.ndarray:
        """(M,3) approach directions (z of the TCP frame)."""
        return self.T_world_tcp[:, :3, 2]

    def take(self, idx) -> "GraspCandidates":
        idx = np.asarray(idx, dtype=np.int64)
        return GraspCandidates(*(a[idx] for a in (self.T_world_tcp, self.width, self.score, self.p1, self.p2,
                                                 self.n1, self.n2)))

    @classmethod
    def empty(cls) -> "GraspCandidates":
        z = np.zeros((0, 3))
        return cls(np.zeros((0, 4, 4)), np.zeros(0), np.zeros(0), z, z, z, z)

    @classmethod
    def concat(cls, parts) -> "GraspCandidates":
        """The candidates of every GraspCandidates in `parts`, in order."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        names = ("T_world_tcp", "width", "score", "p1", "p2", "n1", "n2")
        return cls(*(np.concatenate([getattr(p, n) for p in parts]) for n in names))


class GraspProposer(Protocol):
    """The plug-in point for a learned grasp network (GraspNet, Contact-GraspNet, ...):
    anything that turns a target model into scored candidates. A network's own scores may
    be kept, or its contacts re-scored with `quality.graspnet_score` for comparability.
    toward (3,) / max_angle [rad] (optional keywords; the selection passes them when the
    proposer's `propose` accepts `toward`): only approaches within max_angle of toward are
    wanted (a proposer may return others; the selection filters them)."""

    def propose(self, target: TargetModel, rng: np.random.Generator,
                toward: np.ndarray | None = None, max_angle: float | None = None) -> GraspCandidates: ...


def propose_in_cone(proposer: GraspProposer, target: TargetModel, rng: np.random.Generator, toward: np.ndarray,
                    max_angle: float) -> GraspCandidates:
    """The proposer's candidates, asking for approaches within max_angle [rad] of toward (3,)
    when its `propose` accepts those keywords (a proposer without them proposes freely)."""
    if "toward" in inspect.signature(proposer.propose).parameters:
        return proposer.propose(target, rng, toward=toward, max_angle=max_angle)
    return proposer.propose(target, rng)


class PinnedProposer:
    """A proposer whose candidates start with `pinned` (GraspCandidates kept from earlier
    calls, e.g. the grasp hypotheses INSPECT looked for) followed by `base`'s own: a grasp
    whose way in was made visible is then always among those checked, whatever the base
    proposer draws this time."""

    def __init__(self, base: GraspProposer, pinned: GraspCandidates):
        self.base, self.pinned = base, pinned

    def propose(self, target: TargetModel, rng: np.random.Generator,
                toward: np.ndarray | None = None, max_angle: float | None = None) -> GraspCandidates:
        fresh = propose_in_cone(self.base, target, rng, toward, max_angle) if toward is not None \
            else self.base.propose(target, rng)
        return GraspCandidates.concat([self.pinned, fresh])


class AntipodalProposer:
    """The analytic proposer: antipodal sampling + GraspNet's force-closure score."""

    def __init__(self, config: CandidateConfig | None = None):
        self.config = config or CandidateConfig()

    def propose(self, target: TargetModel, rng: np.random.Generator,
                toward: np.ndarray | None = None, max_angle: float | None = None) -> GraspCandidates:
        return antipodal_candidates(target, self.config, rng, toward, max_angle)


def contact_pairs(points: np.ndarray, normals: np.ndarray, first: np.ndarray, config: CandidateConfig,
                  directions: np.ndarray | None = None):
    """For first-contact indices and closing directions (default: the inward normals), the
    partner index (-1 where none) and width [m]: along each closing line c through p1 (the
    points within `line_radius` of it), p1 must be outermost (no point more than
    line_radius behind it) and the partner is the farthest point at least `min_width` along
    c whose normal faces along c, with no point more than line_radius beyond it. One numba
    pass over the points per first contact."""
    P = np.ascontiguousarray(points, dtype=np.float64)
    N = np.ascontiguousarray(normals, dtype=np.float64)
    first = np.ascontiguousarray(first, dtype=np.int64)
    dirs = -N[first] if directions is None else np.asarray(directions, dtype=np.float64)
    out_j = _contact_pairs(P, N, first, np.ascontiguousarray(dirs), float(config.line_radius),
                           float(config.min_width))
    ok = out_j >= 0
    width = np.zeros(len(first))
    width[ok] = np.linalg.norm(P[out_j[ok]] - P[first[ok]], axis=1)
    return out_j, width


@njit(cache=True, parallel=True)
def _contact_pairs(P, N, first, dirs, line_radius, min_width):
    out = np.full(first.shape[0], -1, np.int64)
    for k in prange(first.shape[0]):
        i = first[k]
        c0, c1, c2 = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        best, best_t, behind = -1, -np.inf, False
        t_max_line = -np.inf  # the largest t of a point on the line
        for n in range(P.shape[0]):
            d0, d1, d2 = P[n, 0] - P[i, 0], P[n, 1] - P[i, 1], P[n, 2] - P[i, 2]
            t = d0 * c0 + d1 * c1 + d2 * c2
            e0, e1, e2 = d0 - t * c0, d1 - t * c1, d2 - t * c2
            if math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) > line_radius:
                continue
            if t < -line_radius:
                behind = True
                break
            if t > t_max_line:
                t_max_line = t
            if t >= min_width and N[n, 0] * c0 + N[n, 1] * c1 + N[n, 2] * c2 > 0.0 and t > best_t:
                best, best_t = n, t
        if behind or best < 0 or t_max_line > best_t + line_radius:
            continue
        out[k] = best
    return out


def closing_directions(normals: np.ndarray, first: np.ndarray, config: CandidateConfig,
                       rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """First-contact indices repeated n_directions times and their closing directions: the
    inward normal, then directions uniform in angle within `cone` [rad] of it."""
    idx = np.repeat(first, config.n_directions)
    c = -normals[idx]
    e1, e2 = _perp_basis(c)
    th = rng.uniform(0.0, config.cone, len(idx))
    th[:: config.n_directions] = 0.0
    ph = rng.uniform(0.0, 2 * np.pi, len(idx))
    d = np.cos(th)[:, None] * c + np.sin(th)[:, None] * (np.cos(ph)[:, None] * e1 + np.sin(ph)[:, None] * e2)
    return idx, d / np.linalg.norm(d, axis=1, keepdims=True)


def _perp_basis(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ref = np.where(np.abs(y[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))
    e1 = np.cross(y, ref)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(y, e1)


def first_contacts(points: np.ndarray, config: CandidateConfig, rng: np.random.Generator) -> np.ndarray:
    """Indices of the first contacts: `top_fraction` of n_contacts drawn from the points
    within `top_band` [m] of the target's highest point (a hand reaching into a cluttered
    shelf finds its free corridor above what stands around the target, and a grasp near
    the top lifts it out without sweeping its neighbours), the rest from all points."""
    n = min(config.n_contacts, len(points))
    top = np.nonzero(points[:, 2] >= points[:, 2].max() - config.top_band)[0]
    n_top = min(int(round(config.top_fraction * n)), len(top))
    a = rng.choice(top, size=n_top, replace=False) if n_top else np.zeros(0, np.int64)
    rest = np.setdiff1d(np.arange(len(points)), a)
    b = rng.choice(rest, size=min(n - n_top, len(rest)), replace=False)
    return np.concatenate([a, b]).astype(np.int64)


def approach_rolls(e1: np.ndarray, e2: np.ndarray, y: np.ndarray, n_rolls: int,
                   toward: np.ndarray | None = None, max_angle: float | None = None) -> np.ndarray:
    """(K, n_rolls) roll angles [rad] of the approach a = cos(r) e1 + sin(r) e2 about each
    closing line y (K,3): all round, or (toward, max_angle given) spread evenly over the arc
    whose approaches lie within max_angle of toward; NaN where no approach does."""
    K = len(y)
    if toward is None or max_angle is None:
        return np.tile(np.arange(n_rolls) * (2 * np.pi / n_rolls), (K, 1))
    t = np.asarray(toward, dtype=np.float64)
    t = t / np.linalg.norm(t)
    c1, c2 = e1 @ t, e2 @ t
    reach = np.hypot(c1, c2)  # cos of the smallest angle to toward on the circle
    r0 = np.arctan2(c2, c1)
    with np.errstate(invalid="ignore", divide="ignore"):
        half = np.arccos(np.clip(np.cos(max_angle) / np.maximum(reach, 1e-12), -1.0, 1.0))
    half = np.where(reach >= np.cos(max_angle), half, np.nan)
    f = (np.arange(n_rolls) + 0.5) / n_rolls * 2.0 - 1.0 if n_rolls > 1 else np.zeros(1)
    return r0[:, None] + half[:, None] * f[None]


def antipodal_candidates(target: TargetModel, config: CandidateConfig | None = None,
                         rng: np.random.Generator | None = None, toward: np.ndarray | None = None,
                         max_angle: float | None = None) -> GraspCandidates:
    """Scored antipodal candidates on the target model (see the module doc). Only
    force-closure pairs (s > 0) within the hand's opening are returned. toward (3,) and
    max_angle [rad]: sample the approach rolls only within max_angle of toward (the
    constrained selection's cone around n), instead of all round the closing line."""
    config = config or CandidateConfig()
    if rng is None:
        raise CompassInputError("antipodal_candidates needs an explicit np.random.Generator (rng)")
    P, N = target.points, target.normals
    first = first_contacts(P, config, rng)
    first, dirs = closing_directions(N, first, config, rng)
    partner, width = contact_pairs(P, N, first, config, dirs)
    ok = (partner >= 0) & (width <= config.max_width)
    i, j, width = first[ok], partner[ok], width[ok]
    if len(i) == 0:
        return GraspCandidates.empty()
    p1, p2, n1, n2 = P[i], P[j], N[i], N[j]
    keep = np.ones(len(p1), dtype=bool)
    if config.top_margin > 0.0:  # contacts on the top face's rim
        below = P[:, 2].max() - config.top_margin
        keep &= (p1[:, 2] <= below) & (p2[:, 2] <= below)
    if config.max_tilt is not None:  # the closing line's rise over its length
        keep &= np.abs(p2[:, 2] - p1[:, 2]) <= np.sin(config.max_tilt) * width
    if not keep.all():
        p1, p2, n1, n2, width, i, j = p1[keep], p2[keep], n1[keep], n2[keep], width[keep], i[keep], j[keep]
        if len(p1) == 0:
            return GraspCandidates.empty()
    if config.edge_angle is None:
        score = graspnet_score(p1, p2, n1, n2)
    else:
        ends = np.unique(np.concatenate([i, j]))
        cones = normal_cones(P, N, ends, config.edge_radius, config.edge_k, config.edge_angle)
        score = graspnet_score_cones(p1, p2, cones[np.searchsorted(ends, i)], cones[np.searchsorted(ends, j)])
    keep = score > 0
    p1, p2, n1, n2, width, score = p1[keep], p2[keep], n1[keep], n2[keep], width[keep], score[keep]
    if len(p1) == 0:
        return GraspCandidates.empty()
    y = (p2 - p1) / width[:, None]
    e1, e2 = _perp_basis(y)
    mid = 0.5 * (p1 + p2)
    rolls = approach_rolls(e1, e2, y, config.n_rolls, toward, max_angle)  # (K, R)
    K, R = rolls.shape
    kk = np.repeat(np.arange(K), R)
    r = rolls.reshape(-1)
    good = np.isfinite(r)
    kk, r = kk[good], r[good]
    a = np.cos(r)[:, None] * e1[kk] + np.sin(r)[:, None] * e2[kk]
    if len(kk) == 0:
        return GraspCandidates.empty()
    Ts, idx, dep, grp = [], [], [], []
    for s_i, sign in enumerate((1.0, -1.0)):  # the hand is symmetric, its wrist camera is not
        yk = sign * y[kk]
        Rm = np.stack([np.cross(yk, a), yk, a], axis=-1)
        for d in config.depths:
            T = np.zeros((len(kk), 4, 4))
            T[:, :3, :3] = Rm
            T[:, :3, 3] = mid[kk] + d * a
            T[:, 3, 3] = 1.0
            Ts.append(T)
            idx.append(kk)
            dep.append(np.full(len(kk), d))
            grp.append(s_i * len(kk) + np.arange(len(kk)))  # one group: a pair's approach, one way round
    T, idx, dep, grp = (np.concatenate(v) for v in (Ts, idx, dep, grp))
    keep = depth_keep(P, T, width[idx], dep, grp, config)
    clear = palm_clear(P, T[keep], width[idx[keep]])
    T, idx = T[keep][clear], idx[keep][clear]
    return GraspCandidates(T, width[idx], score[idx], p1[idx], p2[idx], n1[idx], n2[idx])
