"""Metrics recorded while a trial runs: executed motion (time, end-effector path length,
manipulability), plans, decision compute time, contacts and the explored fraction."""
from __future__ import annotations

import numpy as np

from ..robot.kinematics import PandaKinematics
from ..types import Trajectory


class MetricsRecorder:
    """Accumulates what a `TrialResult` reports. kin: the robot's kinematics (TCP and
    manipulability); surroundings: world box (min, max) [m] of the explored-fraction metric."""

    def __init__(self, kin: PandaKinematics, surroundings: tuple[np.ndarray, np.ndarray]) -> None:
        self.kin = kin
        self.surroundings = surroundings
        self.plans_attempted = 0
        self.plans_succeeded = 0
        self.decision_s: list[float] = []
        self.decision_phase: list[str] = []
        self.nbv_ms: list[float] = []  # frontiers + tree + utility of EXPLORE decisions [ms]
        self.checker_ms: list[float] = []  # map -> distance field -> checker rebuild [ms]
        self.decisions = 0
        self.collisions = 0
        self.explored: list[tuple[float, float]] = []
        # executed motion, in time order: sample times [s], cumulative TCP path [m], manipulability
        self._t: list[np.ndarray] = []
        self._s: list[np.ndarray] = []
        self._m: list[np.ndarray] = []
        self._s_end = 0.0

    def decision(self, d) -> None:
        self.decisions += 1
        self.plans_attempted += d.plans_attempted
        self.plans_succeeded += d.plans_succeeded
        self.decision_s.append(d.compute_s)
        self.decision_phase.append(d.phase.value)
        if "nbv_ms" in d.stats:
            self.nbv_ms.append(float(d.stats["nbv_ms"]))
            self.checker_ms.append(float(d.stats["checker_ms"]))

    def motion(self, traj: Trajectory, t0: float, t_end: float) -> None:
        """An executed trajectory started at t0 [s] (relative times in traj.t), up to t_end."""
        keep = traj.t - traj.t[0] + t0 <= t_end + 1e-9
        t = traj.t[keep] - traj.t[0] + t0
        Q = traj.q[keep]
        if len(Q) == 0:
            return
        links = self.kin.fk_links_batch(Q)  # once for the TCP path and the manipulability
        p = (links[:, self.kin.hand_index] @ self.kin.T_hand_frame("tcp"))[:, :3, 3]  # = T_world_tcp_batch(Q)
        s = self._s_end + np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        self._s_end = float(s[-1])
        self._t.append(t)
        self._s.append(s)
        self._m.append(self.kin.manipulability_batch(Q, links=links))

    def explored_fraction(self, t: float, occ) -> None:
        self.explored.append((float(t), float(occ.known_fraction(*self.surroundings))))

    # ------------------------------------------------------------ summaries
    def path_length_at(self, t: float) -> float:
        """End-effector path length [m] executed up to time t [s]."""
        if not self._t:
            return 0.0
        T, S = np.concatenate(self._t), np.concatenate(self._s)
        return float(np.interp(t, T, S))

    @property
    def mpsr(self) -> float | None:
        return self.plans_succeeded / self.plans_attempted if self.plans_attempted else None

    @property
    def am(self) -> float | None:
        """Mean manipulability over executed trajectory samples (uniform in time)."""
        return float(np.mean(np.concatenate(self._m))) if self._m else None

    def decision_ms(self) -> tuple[float | None, float | None]:
        if not self.decision_s:
            return None, None
        ms = 1000.0 * np.asarray(self.decision_s)
        return float(np.median(ms)), float(np.percentile(ms, 90))
