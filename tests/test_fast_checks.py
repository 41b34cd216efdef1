"""The fast paths of check_q and is_rigid decide exactly as the plain tests."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import is_rigid
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN, check_q
from _rigid_reference import is_rigid_reference


def test_is_rigid_agrees_with_allclose_near_its_tolerance():
    rng = np.random.default_rng(0)
    agree = 0
    for _ in range(2000):
        A = rng.normal(size=(3, 3))
        Qm, _ = np.linalg.qr(A)
        if np.linalg.det(Qm) < 0:
            Qm[:, 0] *= -1
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = Qm, rng.normal(size=3)
        noise = rng.choice([0.0, 1e-8, 3e-7, 1e-6, 3e-6, 1e-4])
        T = T + noise * rng.normal(size=(4, 4)) * (rng.random((4, 4)) < 0.5)
        for tol in (1e-6, 1e-5):
            assert is_rigid(T, tol) == is_rigid_reference(T, tol)
            agree += is_rigid(T, tol)
    assert 0 < agree < 4000  # both verdicts occurred
    assert not is_rigid(np.full((4, 4), np.nan)) and not is_rigid(np.eye(3))


def test_check_q_fast_path_keeps_every_verdict():
    q = np.array(Q_HOME, dtype=np.float64)
    assert check_q(q) is q
    assert np.array_equal(check_q(list(Q_HOME)), q)
    assert check_q(Q_MAX + 5e-10).dtype == np.float64  # within the tolerance
    for bad, match in ((np.where(np.arange(7) == 2, np.nan, q), "NaN"), (Q_MIN - 1e-6, "outside joint 1"),
                       (np.where(np.arange(7) == 3, np.inf, q), "NaN or inf"), (np.zeros(6), "shape")):
        with pytest.raises(CompassInputError, match=match):
            check_q(bad)
    assert np.array_equal(check_q(np.array(Q_HOME, dtype=np.float32)), np.array(Q_HOME, dtype=np.float32))
