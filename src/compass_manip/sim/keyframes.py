"""Keyframes: which camera poses along a motion are rendered.

A fixed frame rate renders the same number of frames per second whether the camera sweeps
across the cabinet or barely moves. The keyframe rule renders a frame when the camera has
moved at least `min_move_m` [m] or turned at least `min_turn_rad` [rad] since the last
rendered frame, and at most `max_interval_s` [s] of simulated time after it (a still or
slowly moving camera still gives a frame that often). The trial machine also renders a frame
at the end of every motion, so the first reference of a motion is the pose it starts from.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, real_number, check_field_types


@dataclass(frozen=True)
class KeyframeRule:
    """min_move_m [m], min_turn_rad [rad], max_interval_s [s] (see the module docstring)."""

    min_move_m: float = 0.10
    min_turn_rad: float = 0.5
    max_interval_s: float = 1.5

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        for name, lo, hi, unit in (("min_move_m", 1e-4, 10.0, "m"), ("min_turn_rad", 1e-4, math.pi, "rad"),
                                   ("max_interval_s", 1e-3, 3600.0, "s")):
            v = real_number(getattr(self, name), f"KeyframeRule.{name}", f"{lo}..{hi} {unit}")
            if not lo <= v <= hi:
                raise CompassInputError(f"KeyframeRule.{name} = {v} is not allowed; use {lo}..{hi} {unit}")


def turn_angle(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Angle [rad] of the rotation between two rotation matrices (3, 3)."""
    c = (float(np.trace(np.asarray(R_a).T @ np.asarray(R_b))) - 1.0) / 2.0
    return math.acos(min(1.0, max(-1.0, c)))


class KeyframeTracker:
    """The rule's state along one motion: `due(t, T_world_cam)` says whether a frame is due
    at time t [s] and pose T_world_cam (4, 4), and if so makes that pose the new reference."""

    def __init__(self, rule: KeyframeRule, t_ref: float, T_ref: np.ndarray) -> None:
        self.rule = rule
        self.t_ref, self.T_ref = float(t_ref), np.array(T_ref, dtype=float)

    def due(self, t: float, T_world_cam: np.ndarray) -> bool:
        rule, T = self.rule, np.asarray(T_world_cam, dtype=float)
        if (np.linalg.norm(T[:3, 3] - self.T_ref[:3, 3]) >= rule.min_move_m
                or t - self.t_ref >= rule.max_interval_s - 1e-9
                or turn_angle(self.T_ref[:3, :3], T[:3, :3]) >= rule.min_turn_rad):
            self.t_ref, self.T_ref = float(t), T.copy()
            return True
        return False


def select_keyframes(t: np.ndarray, T_world_cam: np.ndarray, rule: KeyframeRule) -> np.ndarray:
    """Indices of the samples (times t (n,) [s], poses (n, 4, 4)) rendered by the rule, with
    sample 0 as the first reference (not itself returned)."""
    t, T = np.asarray(t, dtype=float), np.asarray(T_world_cam, dtype=float)
    if len(t) == 0:
        return np.zeros(0, dtype=int)
    tracker = KeyframeTracker(rule, t[0], T[0])
    return np.array([i for i in range(1, len(t)) if tracker.due(t[i], T[i])], dtype=int)
