"""A validity checker whose invalid set is known in closed form: a ball in joint space
(max-norm), so the expected answers of escape, candidate and planning tests are exact."""
import numpy as np


class BallChecker:
    """Configurations within `radius` [rad] (max-norm) of `centre` are invalid."""

    def __init__(self, centre, radius):
        self.centre, self.radius = np.asarray(centre, float), radius

    def are_valid(self, Q):
        return np.max(np.abs(np.asarray(Q) - self.centre), axis=-1) > self.radius

    def is_valid(self, q):
        return bool(self.are_valid(np.asarray(q)[None])[0])

    def clearance(self, q):  # [rad] here, the max-norm distance outside the ball
        return float(np.max(np.abs(np.asarray(q) - self.centre)) - self.radius)

    def _states(self, q0, q1, resolution):
        n = max(1, int(np.ceil(np.max(np.abs(q1 - q0)) / resolution)))
        s = np.arange(n + 1) / n
        return s, q0 + s[:, None] * (q1 - q0)

    def first_invalid(self, q0, q1, resolution):
        s, Q = self._states(q0, q1, resolution)
        bad = ~self.are_valid(Q)
        return float(s[np.argmax(bad)]) if bad.any() else None

    def edge_valid(self, q0, q1, resolution):
        return bool(self.are_valid(self._states(q0, q1, resolution)[1]).all())
