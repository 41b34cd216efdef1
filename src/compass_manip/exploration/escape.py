"""Leaving a configuration the map has come to call invalid.

The arm rests where its map allowed it to go; a later frame can reveal an obstacle just
within the checker's conservative margin of where it now stands (e.g. the face of the
confined space next to the start posture, which the start shell assumed free). No tree
can then grow from the current configuration and the method would be stuck. The escape
motion is a short straight joint segment to a nearby valid configuration whose only
invalid states lie within `tolerance` [rad] of the current one (the part the arm already
occupies); its remaining states are checked at the fine resolution like any plan.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..robot.model import Q_MAX, Q_MIN
from .base import Decision, Phase


@dataclass(frozen=True)
class EscapeConfig:
    """samples around the current configuration, spread over radius tiers: within
    +-radius, +-radius/2, ... [rad] per joint, down to the smallest tier above tolerance
    (a uniform draw within +-radius over seven joints almost never lands in the thin valid
    shell next to an obstacle the arm stands beside); axis_step [rad]: moves of one joint at
    a time, in steps of axis_step up to radius, are candidates too (the way out is often
    along one joint, e.g. the shoulder lifting the hand off a face frame); tolerance [rad]:
    the longest stretch next to the current configuration allowed to be invalid;
    resolution [rad] of the segment check; max_approach [m]: along the invalid stretch the
    map clearance may fall at most this much below the current configuration's (the grid's
    lookup is piecewise constant), so the escape never moves into what it stands beside."""

    samples: int = 200
    radius: float = 0.25
    tolerance: float = 0.06
    resolution: float = 0.005
    axis_step: float = 0.03
    max_approach: float = 0.005

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, radius=(0.0, 6.3, "rad"), resolution=(1e-4, 0.5, "rad"), max_approach=(0.0, 0.5, "m"))
        if self.samples < 1 or not 0 < self.tolerance < self.radius:
            raise CompassInputError(f"EscapeConfig needs samples >= 1 and 0 < tolerance {self.tolerance} < "
                                    f"radius {self.radius}")
        if not 0 < self.axis_step <= self.radius:
            raise CompassInputError(f"EscapeConfig.axis_step {self.axis_step} rad must be in (0, radius "
                                    f"{self.radius}]")

    @property
    def tiers(self) -> tuple[float, ...]:
        """Sampling radii [rad]: radius halved while it stays above tolerance."""
        out = [self.radius]
        while out[-1] / 2 > self.tolerance:
            out.append(out[-1] / 2)
        return tuple(out)


def escape_candidates(q: np.ndarray, config: EscapeConfig, rng: np.random.Generator) -> np.ndarray:
    """Candidate goals (n, 7) [rad] around q: config.samples uniform draws split over the
    radius tiers, plus single-joint moves of k * axis_step (both signs), within the limits."""
    q = np.asarray(q, float)
    tiers = config.tiers
    counts = np.full(len(tiers), config.samples // len(tiers))
    counts[: config.samples % len(tiers)] += 1
    parts = [rng.uniform(np.maximum(Q_MIN, q - r), np.minimum(Q_MAX, q + r), (int(n), 7))
             for r, n in zip(tiers, counts)]
    steps = np.arange(1, int(np.floor(config.radius / config.axis_step + 1e-9)) + 1) * config.axis_step
    for j in range(7):
        for sign in (-1.0, 1.0):
            A = np.repeat(q[None], len(steps), axis=0)
            A[:, j] = np.clip(q[j] + sign * steps, Q_MIN[j], Q_MAX[j])
            parts.append(A)
    return np.vstack(parts)


def valid_after_start(checker, path: np.ndarray, tolerance: float, resolution: float,
                      max_approach: float | None = None) -> bool:
    """True if every state of the joint path (m, 7) [rad], checked at resolution [rad], is
    valid except within tolerance [rad] (largest joint change) of its first state; with
    max_approach [m], the states of that invalid stretch must also keep the checker's
    clearance within max_approach of the first state's (the arm leaves the obstacle it
    stands by, never moves into it)."""
    P = np.asarray(path, float)
    q, q1 = P[0], P[1]
    span = float(np.max(np.abs(q1 - q)))
    s = checker.first_invalid(q1, q, resolution)  # scanned from the far end towards the start
    if s is not None and (1.0 - s) * span > tolerance:
        return False
    if s is not None and max_approach is not None:
        n = max(1, int(np.ceil((1.0 - s) * span / resolution)))
        c0 = checker.clearance(q)
        for t in np.linspace(0.0, 1.0 - s, n + 1)[1:]:
            if checker.clearance(q + t * (q1 - q)) < c0 - max_approach:
                return False
    return len(P) == 2 or checker.path_valid(P[1:], resolution)


def escape_path(checker, q: np.ndarray, config: EscapeConfig, rng: np.random.Generator) -> np.ndarray | None:
    """A path (2, 7) [rad] from q to the nearest sampled valid configuration reachable as
    described in the module docstring, or None."""
    q = np.asarray(q, float)
    Q = escape_candidates(q, config, rng)
    Q = Q[checker.are_valid(Q)]
    for qc in Q[np.argsort(np.max(np.abs(Q - q), axis=1), kind="stable")]:
        span = float(np.max(np.abs(qc - q)))
        if span <= config.tolerance:
            continue
        if valid_after_start(checker, np.stack([q, qc]), config.tolerance, config.resolution, config.max_approach):
            return np.stack([q, qc])
    return None


def escape_decision(checker, q: np.ndarray, config: EscapeConfig, rng: np.random.Generator,
                    phase: Phase = Phase.EXPLORE) -> Decision | None:
    """The decision every method takes first: if q is invalid on the map (a new frame saw
    an obstacle within the checker's margin of it), the escape motion out of it (one
    attempted and succeeded plan, stats {"escape": 1}); None when q is valid or no escape
    is found."""
    if checker.is_valid(q):
        return None
    path = escape_path(checker, q, config, rng)
    return None if path is None else Decision(path, None, phase, 1, 1, stats={"escape": 1})
