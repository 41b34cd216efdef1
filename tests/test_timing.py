"""Time parameterisation: limits respected (finite differences), waypoints hit, straight segments."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.motion.timing import (TimingConfig, densify, ee_path_length, joint_path_length,
                                         segment_durations, time_parameterize)
from compass_manip.types import Trajectory
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN, QD_MAX, QDD_MAX


def _random_path(seed: int, n: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(Q_MIN, Q_MAX, size=(n, 7))


def _fd(tr: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference velocity (n-1,7) and acceleration (n-2,7) of a sampled trajectory."""
    qd = np.diff(tr.q, axis=0) / np.diff(tr.t)[:, None]
    tm = 0.5 * (tr.t[1:] + tr.t[:-1])
    return qd, np.diff(qd, axis=0) / np.diff(tm)[:, None]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_limits_hold_by_finite_differences(seed):
    path = _random_path(seed)
    tr = time_parameterize(path, TimingConfig(dt=0.002))
    assert isinstance(tr, Trajectory) and np.all(np.diff(tr.t) > 0)
    qd_fd, qdd_fd = _fd(tr)
    assert np.all(np.abs(qd_fd) <= QD_MAX * (1 + 1e-6))
    assert np.all(np.abs(qdd_fd) <= QDD_MAX * (1 + 1e-3))
    # time-optimal: some joint reaches (nearly) its velocity and acceleration limits
    assert np.max(np.abs(qd_fd) / QD_MAX) > 0.98
    assert np.max(np.abs(qdd_fd) / QDD_MAX) > 0.9


def test_scaled_limits_and_slower():
    path = _random_path(3, 3)
    full = time_parameterize(path)
    half = time_parameterize(path, TimingConfig(velocity_scale=0.5, acceleration_scale=0.5, dt=0.002))
    qd_fd, qdd_fd = _fd(half)
    assert np.all(np.abs(qd_fd) <= 0.5 * QD_MAX * (1 + 1e-6))
    assert np.all(np.abs(qdd_fd) <= 0.5 * QDD_MAX * (1 + 1e-3))
    assert half.duration > full.duration


def test_passes_through_waypoints_at_rest_on_straight_segments():
    path = _random_path(4, 4)
    tr = time_parameterize(path, TimingConfig(dt=0.001))
    t_wp = np.r_[0.0, np.cumsum(segment_durations(path))]
    assert tr.t[0] == 0.0 and tr.duration == pytest.approx(t_wp[-1])
    qd_fd, _ = _fd(tr)
    for k, tk in enumerate(t_wp):
        i = int(np.argmin(np.abs(tr.t - tk)))
        assert abs(tr.t[i] - tk) < 1e-9
        np.testing.assert_allclose(tr.q[i], path[k], atol=1e-9)
        # at rest: the velocity next to the waypoint is tiny (jerk-limited start/stop)
        for j in (i - 1, i):
            if 0 <= j < len(qd_fd):
                assert np.all(np.abs(qd_fd[j]) < 0.02 * QD_MAX)
    for k in range(len(path) - 1):  # every sample lies on its segment, in order
        a, b = path[k], path[k + 1]
        m = (tr.t >= t_wp[k] - 1e-12) & (tr.t <= t_wp[k + 1] + 1e-12)
        s = (tr.q[m] - a) @ (b - a) / ((b - a) @ (b - a))
        np.testing.assert_allclose(tr.q[m], a + s[:, None] * (b - a), atol=1e-9)
        assert np.all(np.diff(s) >= -1e-12) and s[0] == pytest.approx(0) and s[-1] == pytest.approx(1)


def test_single_joint_rest_to_rest_duration_matches_hand_computation():
    # joint 1 moves 2 rad: jerk-limited profile is dominated by v: T ~ d/v + v/a + a/j
    q0 = Q_HOME.copy()
    q1 = q0.copy()
    q1[0] += 2.0
    tr = time_parameterize(np.stack([q0, q1]))
    v, a, j = 2.175, 15.0, 7500.0
    assert tr.duration == pytest.approx(2.0 / v + v / a + a / j, rel=1e-6)


def test_duplicate_waypoints_and_single_point():
    tr = time_parameterize(np.stack([Q_HOME, Q_HOME]))
    assert tr.duration == 0.0 and tr.q.shape == (1, 7)


def test_path_lengths():
    a = Q_HOME.copy()
    b = a.copy()
    b[1] += 0.3
    c = b.copy()
    c[2] += 0.4
    assert joint_path_length(np.stack([a, b, c])) == pytest.approx(0.7)
    d = densify(np.stack([a, c]), 0.01)
    assert np.max(np.abs(np.diff(d, axis=0))) <= 0.01 + 1e-12
    np.testing.assert_allclose(d[[0, -1]], np.stack([a, c]))


class _Circle:
    """Stand-in kinematics: the TCP on a circle of radius 0.5 m driven by joint 1."""

    def T_world_tcp_batch(self, Q):
        T = np.tile(np.eye(4), (len(Q), 1, 1))
        T[:, 0, 3] = 0.5 * np.cos(Q[:, 0])
        T[:, 1, 3] = 0.5 * np.sin(Q[:, 0])
        return T


def test_ee_path_length_follows_the_arc():
    a = Q_HOME.copy()
    b = a.copy()
    b[0] += np.pi / 2
    L = ee_path_length(np.stack([a, b]), _Circle(), max_step=0.001)
    assert L == pytest.approx(0.5 * np.pi / 2, rel=1e-5)  # arc, not the chord 0.707 m


def test_bad_inputs_raise():
    with pytest.raises(CompassInputError):
        time_parameterize(np.zeros((3, 6)))
    with pytest.raises(CompassInputError):
        time_parameterize(np.full((2, 7), np.nan))
    with pytest.raises(CompassInputError):
        TimingConfig(velocity_scale=0.0)
