"""The capped distance field updated in place equals the full transform capped, bit for bit,
and a checker on it gives the same verdicts as on the uncapped field."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.mapping.distance import DistanceField, DistanceFieldConfig
from compass_manip.exploration.world_model import capped_field
from compass_manip.mapping.distance_incremental import CappedDistance
from compass_manip.motion.primitives import DistanceGrid
from compass_manip.motion.validity import ValidityChecker, ValidityConfig
from compass_manip.robot.model import RobotConfig
from compass_manip.robot.spheres import panda_sphere_model

RES = 0.02


def _full_capped(unsafe, cap_voxels, outside_is_unsafe=True):
    d = DistanceField.from_unsafe(unsafe, np.zeros(3), RES, DistanceFieldConfig(outside_is_unsafe=outside_is_unsafe))
    return np.minimum(d.distances.astype(np.float64), cap_voxels * RES).astype(np.float32)


@pytest.mark.parametrize("outside_is_unsafe", [True, False])
def test_updates_equal_the_full_transform_capped(outside_is_unsafe):
    rng = np.random.default_rng(3)
    shape, cap = (30, 26, 22), 5
    u = rng.random(shape) < 0.2
    cd = CappedDistance(RES, cap, outside_is_unsafe)
    assert np.array_equal(cd.update(u), _full_capped(u, cap, outside_is_unsafe))
    for _ in range(25):
        lo, size = rng.integers(0, 20, 3), rng.integers(1, 9, 3)
        u = u.copy()
        sl = tuple(slice(int(a), int(a + s)) for a, s in zip(lo, size))
        u[sl] = rng.random(u[sl].shape) < rng.choice([0.0, 0.3, 1.0])  # clear, scatter or fill a box
        got = cd.update(u)
        assert np.array_equal(got, _full_capped(u, cap, outside_is_unsafe))
    assert cd.lines_last < 3 * 30 * 26  # a small change recomputes part of the lines only


def test_no_change_and_earlier_results_kept():
    u = np.zeros((12, 12, 12), bool)
    u[6, 6, 6] = True
    cd = CappedDistance(RES, 4)
    first = cd.update(u)
    again = cd.update(u.copy())
    assert np.array_equal(first, again) and cd.lines_last == 0
    u2 = u.copy()
    u2[6, 6, 6] = False
    snapshot = first.copy()
    second = cd.update(u2)
    assert np.array_equal(first, snapshot)  # the array returned before is not modified
    assert second[6, 6, 6] > 0 and first[6, 6, 6] == 0
    assert np.isclose(second.max(), 4 * RES)


def test_empty_mask_reads_the_cap_everywhere():
    cd = CappedDistance(RES, 3, outside_is_unsafe=False)
    d = cd.update(np.zeros((5, 6, 7), bool))
    assert np.all(d == np.float32(3 * RES))


@pytest.mark.parametrize("cap", [0, -2, 1.5, None])
def test_bad_cap_is_one_clear_error(cap):
    with pytest.raises(CompassInputError, match="cap_voxels"):
        CappedDistance(RES, cap)


def test_bad_mask_shape_is_one_clear_error():
    with pytest.raises(CompassInputError, match="unsafe mask"):
        CappedDistance(RES, 3).update(np.zeros((4, 4), bool))


def test_checker_verdicts_equal_on_the_capped_field():
    """Configurations near obstacles: the same verdicts on the capped and the full field, and
    a cap below grid_cap_m changes some (the bound is not vacuous)."""
    rng = np.random.default_rng(0)
    spheres = panda_sphere_model(RobotConfig())
    cfg = ValidityConfig(margin=0.005, edge_resolution=0.02)
    grid_min = np.array([-0.6, -0.8, -0.05])
    shape = (85, 80, 68)
    unsafe = np.zeros(shape, bool)
    unsafe[:, :, :3] = True  # floor
    for _ in range(12):  # boxes in the arm's reach
        c = rng.integers((40, 15, 3), (75, 65, 50))
        s = rng.integers(2, 10, 3)
        unsafe[c[0]:c[0] + s[0], c[1]:c[1] + s[1], c[2]:c[2] + s[2]] = True
    full = DistanceField.from_unsafe(unsafe, grid_min, RES).distances
    capped = capped_field(ValidityChecker(spheres, config=cfg), RES).update(unsafe)
    q_home = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    Q = q_home + rng.normal(0.0, 0.6, (3000, 7))
    Q = np.clip(Q, [-2.8, -1.7, -2.8, -3.0, -2.8, 0.0, -2.8], [2.8, 1.7, 2.8, -0.1, 2.8, 3.7, 2.8])
    a = ValidityChecker(spheres, DistanceGrid(full, grid_min, RES), config=cfg).are_valid(Q)
    b = ValidityChecker(spheres, DistanceGrid(capped, grid_min, RES), config=cfg).are_valid(Q)
    assert 0.1 < a.mean() < 0.9
    assert np.array_equal(a, b)
    small = CappedDistance(RES, 2).update(unsafe)
    c = ValidityChecker(spheres, DistanceGrid(small, grid_min, RES), config=cfg).are_valid(Q)
    assert not np.array_equal(a, c)
