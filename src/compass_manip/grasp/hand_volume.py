"""The Panda hand's volume against the target's points: what the palm would push and what
lies between the finger pads.

Hand frame (the TCP at the pad centre): z the approach, from the palm towards the fingertips;
y the closing line; x = y x z. The finger pads span z = -PAD_BACK..+PAD_TIP and |x| <=
PAD_HALF_X; the palm starts PALM_DEPTH behind the TCP. Each test is one numba pass over
(hands x points); the candidate sampler (`grasp.candidates`) uses them to keep only hands whose
palm stays clear and (with depth samples) whose pads hold the target's section.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange

from ..robot.model import GRIPPER_MAX_WIDTH
from .target import thin

if TYPE_CHECKING:  # pragma: no cover
    from .candidates import CandidateConfig

#: Length [m] of the Panda fingers from the TCP (pad centre) back to the palm, less a margin.
PALM_DEPTH = 0.035
#: Half the width [m] of the fingers across the closing line (x of the hand frame).
FINGER_HALF_WIDTH = 0.01
#: Spacing [m] of the target points checked against the palm.
PALM_POINT_SPACING = 0.008
#: How far [m] the finger pads reach beyond the TCP (the Panda's finger collision boxes span
#: z = -0.035..+0.009 m in the TCP frame, 24 mm across the closing line).
PAD_TIP = 0.009
#: How far [m] the pads reach behind the TCP (their back end, at the palm side).
PAD_BACK = 0.035
#: Half the pads' extent [m] across the closing line (x of the hand frame).
PAD_HALF_X = 0.012


def palm_clear(points: np.ndarray, T_world_tcp: np.ndarray, width: np.ndarray) -> np.ndarray:
    """(M,) True where no target point lies between the fingers deeper than PALM_DEPTH
    behind the TCP (it would be pushed by the palm, which the map cannot stop: the
    target's own voxels are carved for the fingers). The points are thinned to
    PALM_POINT_SPACING (the region has 1 cm margins); one numba pass, a candidate stops at
    its first such point."""
    P = np.ascontiguousarray(thin(np.asarray(points, dtype=np.float64), PALM_POINT_SPACING))
    T = np.ascontiguousarray(np.asarray(T_world_tcp, dtype=np.float64).reshape(-1, 4, 4))
    return _palm_clear(P, T, np.ascontiguousarray(width, dtype=np.float64), FINGER_HALF_WIDTH + 0.01, PALM_DEPTH)


@njit(cache=True, parallel=True)
def _palm_clear(P, T, width, half_finger, depth):
    out = np.ones(T.shape[0], dtype=np.bool_)
    for m in prange(T.shape[0]):
        t0 = T[m, 0, 3] * T[m, 0, 0] + T[m, 1, 3] * T[m, 1, 0] + T[m, 2, 3] * T[m, 2, 0]
        t1 = T[m, 0, 3] * T[m, 0, 1] + T[m, 1, 3] * T[m, 1, 1] + T[m, 2, 3] * T[m, 2, 1]
        t2 = T[m, 0, 3] * T[m, 0, 2] + T[m, 1, 3] * T[m, 1, 2] + T[m, 2, 3] * T[m, 2, 2]
        half_w = 0.5 * width[m] + 0.01
        for n in range(P.shape[0]):
            z = P[n, 0] * T[m, 0, 2] + P[n, 1] * T[m, 1, 2] + P[n, 2] * T[m, 2, 2] - t2
            if z >= -depth:
                continue
            x = P[n, 0] * T[m, 0, 0] + P[n, 1] * T[m, 1, 0] + P[n, 2] * T[m, 2, 0] - t0
            if abs(x) > half_finger:
                continue
            y = P[n, 0] * T[m, 0, 1] + P[n, 1] * T[m, 1, 1] + P[n, 2] * T[m, 2, 1] - t1
            if abs(y) <= half_w:
                out[m] = False
                break
    return out




def pad_section(points: np.ndarray, T_world_tcp: np.ndarray, width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each hand (M,4,4) with contact width (M,) [m]: the largest |y| [m] (across the
    closing line, from the TCP) of the target points (N,3) [m] that lie within the pads'
    extent (|x| <= PAD_HALF_X, -PAD_BACK <= z <= PAD_TIP) - the opening they need - and the
    section's centre [m]: the mean z of the points within |x| <= PAD_HALF_X and |y| <= w/2 +
    1 cm (any z: the whole section across the pads, beyond the fingertips too; NaN without
    one). One numba pass."""
    P = np.ascontiguousarray(points, dtype=np.float64)
    T = np.ascontiguousarray(np.asarray(T_world_tcp, dtype=np.float64).reshape(-1, 4, 4))
    return _pad_section(P, T, np.ascontiguousarray(width, dtype=np.float64), PAD_HALF_X, PAD_BACK, PAD_TIP)


@njit(cache=True, parallel=True)
def _pad_section(P, T, width, half_x, back, tip):
    span = np.zeros(T.shape[0])
    centre = np.full(T.shape[0], np.nan)
    for m in prange(T.shape[0]):
        t0 = T[m, 0, 3] * T[m, 0, 0] + T[m, 1, 3] * T[m, 1, 0] + T[m, 2, 3] * T[m, 2, 0]
        t1 = T[m, 0, 3] * T[m, 0, 1] + T[m, 1, 3] * T[m, 1, 1] + T[m, 2, 3] * T[m, 2, 1]
        t2 = T[m, 0, 3] * T[m, 0, 2] + T[m, 1, 3] * T[m, 1, 2] + T[m, 2, 3] * T[m, 2, 2]
        half_w = 0.5 * width[m] + 0.01
        zs, nz, sp = 0.0, 0, 0.0
        for n in range(P.shape[0]):
            x = P[n, 0] * T[m, 0, 0] + P[n, 1] * T[m, 1, 0] + P[n, 2] * T[m, 2, 0] - t0
            if abs(x) > half_x:
                continue
            y = P[n, 0] * T[m, 0, 1] + P[n, 1] * T[m, 1, 1] + P[n, 2] * T[m, 2, 1] - t1
            z = P[n, 0] * T[m, 0, 2] + P[n, 1] * T[m, 1, 2] + P[n, 2] * T[m, 2, 2] - t2
            if -back <= z <= tip and abs(y) > sp:
                sp = abs(y)
            if abs(y) <= half_w:
                zs += z
                nz += 1
        span[m] = sp
        if nz > 0:
            centre[m] = zs / nz
    return span, centre


def depth_keep(points: np.ndarray, T_world_tcp: np.ndarray, width: np.ndarray, depth: np.ndarray,
               group: np.ndarray, config: CandidateConfig) -> np.ndarray:
    """(M,) which depth samples to keep (`CandidateConfig`'s doc): hands (M,4,4) at depth
    (M,) [m] of pairs of width (M,) [m]; group (M,) labels the samples of one approach. A
    sample deeper than 0 is kept only when the points within the pads' extent need no more
    than the hand's opening less the width clearance on each side; then, per group, when
    some kept sample has the section's centre at most PAD_TIP - centre_margin beyond the TCP,
    only those are kept."""
    depth, group = np.asarray(depth, dtype=np.float64), np.asarray(group, dtype=np.int64)
    if len(depth) == 0 or (len(config.depths) == 1 and config.depths[0] == 0.0 and not config.opening_all):
        return np.ones(len(depth), dtype=bool)
    span, centre = pad_section(points, T_world_tcp, width)
    ok = (span <= 0.5 * GRIPPER_MAX_WIDTH - config.width_clearance)
    if not config.opening_all:
        ok |= depth <= 0.0
    inside = ok & (centre <= PAD_TIP - config.centre_margin)  # NaN: not inside
    has = np.zeros(int(group.max()) + 1, dtype=bool)
    has[group[inside]] = True
    return ok & (inside | ~has[group])
