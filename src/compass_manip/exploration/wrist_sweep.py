"""A fixed wrist sweep: joints 1-4 held, joints 5 and 6 around a circle (the simplest
near-field look around the start posture, used by the demo's scan and the pipeline test)."""
from __future__ import annotations

import numpy as np

from ..robot.model import Q_MAX, Q_MIN


def wrist_sweep(q_start: np.ndarray, n: int = 6, amplitude: float = 0.45) -> np.ndarray:
    """Waypoints (n + 2, 7) [rad]: q_start, n points with joints 5 and 6 displaced by
    `amplitude` [rad] around a circle (clipped to the joint limits), back to q_start."""
    q_start = np.asarray(q_start, dtype=np.float64)
    way = [q_start]
    for a in np.linspace(0.0, 2 * np.pi, n, endpoint=False):
        q = q_start.copy()
        q[4] += amplitude * np.cos(a)
        q[5] += amplitude * np.sin(a)
        way.append(np.clip(q, Q_MIN, Q_MAX))
    way.append(q_start)
    return np.array(way)
