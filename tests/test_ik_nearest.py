"""`PandaIK.nearest` (the grasp checks' `near`): the nearest valid solution, checked nearest
first, equals `solve(..., retry=False).best` with the same validity, and None where the old
joint-step rule gave None."""

import numpy as np

from compass_manip.robot.ik import PandaIK
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.robot.spheres import panda_sphere_model


class HalfSpace:
    """A validity stand-in: valid where joint `j` is above `limit`."""

    def __init__(self, j, limit):
        self.j, self.limit = j, limit

    def are_valid(self, Q):
        Q = np.asarray(Q).reshape(-1, 7)
        return Q[:, self.j] > self.limit


def test_nearest_equals_the_best_of_solve_with_and_without_validity():
    kin = panda_sphere_model().kinematics
    ik, rng = PandaIK(kin), np.random.default_rng(5)
    q_home, n_some, n_none = np.asarray(Q_HOME, float), 0, 0
    for _ in range(40):
        q_ref = np.clip(q_home + rng.normal(0.0, 0.3, 7), Q_MIN, Q_MAX)
        T = kin.T_world_tcp(np.clip(q_home + rng.normal(0.0, 0.4, 7), Q_MIN, Q_MAX))
        for validity in (None, HalfSpace(int(rng.integers(7)), float(rng.normal(0.0, 0.5)))):
            for max_step in (None, 0.3, 2.0):
                r = ik.solve(T, "tcp", q_ref, 16, validity, retry=False)
                want = r.best if r.success else None
                if want is not None and max_step is not None and np.max(np.abs(want - q_ref)) > max_step:
                    want = None
                got = ik.nearest(T, "tcp", q_ref, 16, validity, max_step=max_step)
                if want is None:
                    assert got is None
                    n_none += 1
                else:
                    np.testing.assert_array_equal(got, want)
                    n_some += 1
    assert n_some > 20 and n_none > 5  # both outcomes were compared


def test_nearest_reads_and_fills_the_same_sweep_cache_as_solve():
    kin = panda_sphere_model().kinematics
    ik, q = PandaIK(kin), np.asarray(Q_HOME, float)
    T = kin.T_world_tcp(q + 0.1)
    cache: dict = {}
    got = ik.nearest(T, "tcp", q, 16, None, cache=cache)
    assert len(cache) == 2  # the sweep and its q7 grid's part
    np.testing.assert_array_equal(ik.solve(T, "tcp", q, 16, None, retry=False, cache=cache).best, got)
    assert len(cache) == 2


def test_a_cached_sweep_from_another_q_ref_equals_a_fresh_sweep():
    """The cache keeps the q7 grid's part of a pose's sweep for any q_ref: frankik's ik_full
    must not read q_ref beyond q7 (checked here), and the solutions, errors and candidate
    count then equal an uncached solve bit for bit."""
    import frankik
    kin = panda_sphere_model().kinematics
    ik, rng = PandaIK(kin), np.random.default_rng(8)
    q_home = np.asarray(Q_HOME, float)
    cache: dict = {}
    for _ in range(25):
        T = kin.T_world_tcp(np.clip(q_home + rng.normal(0.0, 0.4, 7), Q_MIN, Q_MAX))
        T_flange = ik.T_base_world @ T @ ik._T_frame_hand["tcp"] @ ik.T_hand_link8
        for q_ref in (np.clip(q_home + rng.normal(0.0, 0.3, 7), Q_MIN, Q_MAX) for _ in range(3)):
            other = np.clip(q_ref + rng.normal(0.0, 0.3, 7), Q_MIN, Q_MAX)
            np.testing.assert_array_equal(frankik.ik_full(T_flange, q_ref, 0.3), frankik.ik_full(T_flange, other, 0.3))
            fresh = ik.solve(T, "tcp", q_ref, 16, None, retry=False)
            cached = ik.solve(T, "tcp", q_ref, 16, None, retry=False, cache=cache)
            np.testing.assert_array_equal(cached.solutions, fresh.solutions)
            np.testing.assert_array_equal(cached.pos_err, fresh.pos_err)
            assert cached.failure == fresh.failure
    assert sum(isinstance(k[0], str) for k in cache) == 25  # one grid part per pose
