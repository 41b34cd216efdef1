"""What left COMPASS without a view on the severe scenes (issue 8/9), each on a case whose
answer is known in closed form: the escape's radius tiers and single-joint moves, the
in-space gain map that keeps seen walls as occluders, and the detector's self mask."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.exploration.escape import EscapeConfig, escape_candidates, escape_path
from compass_manip.exploration.nfa import safe_box_map
from compass_manip.mapping.infogain import info_gain_batch
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.perception.self_mask import SelfMaskedDetector, self_pixels
from compass_manip.robot.model import Q_HOME
from compass_manip.types import Observation


class SlabChecker:
    """Valid: joint j moved by lo..hi [rad] from q0 and every other joint within tol of
    q0's (a thin valid set, as beside an obstacle the arm stands next to); invalid elsewhere."""

    def __init__(self, q0, j, lo, hi, tol):
        self.q0, self.j, self.lo, self.hi, self.tol = np.asarray(q0, float), j, lo, hi, tol

    def are_valid(self, Q):
        d = np.asarray(Q, float) - self.q0
        others = np.delete(np.abs(d), self.j, axis=-1).max(axis=-1) <= self.tol
        return others & (d[..., self.j] >= self.lo) & (d[..., self.j] <= self.hi)

    def is_valid(self, q):
        return bool(self.are_valid(np.asarray(q)[None])[0])

    def first_invalid(self, q0, q1, resolution):
        n = max(1, int(np.ceil(np.max(np.abs(q1 - q0)) / resolution)))
        s = np.arange(n + 1) / n
        bad = ~self.are_valid(q0 + s[:, None] * (q1 - q0))
        return float(s[np.argmax(bad)]) if bad.any() else None

    def clearance(self, q):  # grows with joint j's move towards the slab, as a link leaves a wall
        return float(np.asarray(q)[self.j] - self.q0[self.j] - self.lo)

    def path_valid(self, P, resolution):
        return all(self.first_invalid(a, b, resolution) is None for a, b in zip(P[:-1], P[1:]))


def test_escape_finds_a_thin_valid_set_along_one_joint():
    q = np.array(Q_HOME, float)
    checker = SlabChecker(q, j=1, lo=0.05, hi=0.2, tol=0.01)
    assert not checker.is_valid(q)
    config = EscapeConfig(samples=200, radius=0.25, tolerance=0.06, axis_step=0.03)
    path = escape_path(checker, q, config, np.random.default_rng(0))
    assert path is not None and checker.is_valid(path[1])
    moved = np.flatnonzero(np.abs(path[1] - q) > 1e-12)
    np.testing.assert_array_equal(moved, [1])
    assert path[1, 1] - q[1] == pytest.approx(0.06)  # the nearest axis step past 0.05 rad
    # the same slab on the other side: the way out first moves closer (clearance falls), refused
    mirrored = SlabChecker(q, j=1, lo=0.05, hi=0.2, tol=0.01)
    mirrored.clearance = lambda qq: -float(np.asarray(qq)[1] - q[1])
    assert escape_path(mirrored, q, config, np.random.default_rng(0)) is None
    # uniform draws alone (no single-joint moves, one tier) miss a set this thin
    Q = np.random.default_rng(0).uniform(q - 0.25, q + 0.25, (200, 7))
    assert not checker.are_valid(Q).any()


def test_escape_candidates_cover_the_radius_tiers_and_the_axis_moves():
    q = np.array(Q_HOME, float)
    config = EscapeConfig(samples=90, radius=0.25, tolerance=0.06, axis_step=0.05)
    assert config.tiers == pytest.approx((0.25, 0.125, 0.0625 + 0.0))
    C = escape_candidates(q, config, np.random.default_rng(1))
    assert len(C) == 90 + 7 * 2 * 5
    span = np.max(np.abs(C[:90] - q), axis=1)
    assert span[:30].max() <= 0.25 and span[30:60].max() <= 0.125 and span[60:90].max() <= 0.0625
    axis = C[90:] - q
    assert np.all(np.count_nonzero(np.abs(axis) > 1e-12, axis=1) <= 1)
    with pytest.raises(CompassInputError, match="axis_step 0.3"):
        EscapeConfig(radius=0.25, axis_step=0.3)


def test_the_in_space_gain_map_keeps_walls_outside_the_box_as_occluders():
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(1.0, 0.4, 0.4), resolution=0.02))
    c = occ.voxel_centers()
    box_min, box_max = np.array([0.5, 0.0, 0.0]), np.array([1.0, 0.4, 0.4])  # the space, unknown
    occ.state[...] = VoxelState.FREE
    occ.state[c[..., 0] > 0.5] = VoxelState.UNKNOWN
    wall = (c[..., 0] > 0.4) & (c[..., 0] < 0.44)  # a face frame just outside the box, seen
    occ.state[wall] = VoxelState.OCCUPIED
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # optical z along world x
    T[:3, 3] = (0.2, 0.2, 0.2)
    K = np.array([[100.0, 0.0, 40.0], [0.0, 100.0, 30.0], [0.0, 0.0, 1.0]])
    freed = safe_box_map(occ, box_min, box_max)
    kept = safe_box_map(occ, box_min, box_max, keep_occupied=True)
    assert info_gain_batch(freed, T[None], K, 1.0, (8, 6))[0] > 0  # rays pass the wall: a gain no view gives
    assert info_gain_batch(kept, T[None], K, 1.0, (8, 6))[0] == 0
    assert np.all(kept.state[wall] == VoxelState.OCCUPIED) and np.all(freed.state[wall] == VoxelState.FREE)
    inside = c[..., 0] > 0.5
    np.testing.assert_array_equal(kept.state[inside], occ.state[inside])
    assert not np.any(kept.state[~inside & ~wall] == VoxelState.UNKNOWN)


class OneSphere:
    """A robot of one sphere at `centre` [m] (independent of q)."""

    def __init__(self, centre, r):
        self.centre, self.radii = np.asarray(centre, float), np.array([r], float)

    def sphere_centers(self, Q):
        return np.repeat(self.centre[None, None], len(Q), axis=0)


def test_self_mask_blanks_only_the_robots_pixels():
    H, W = 30, 40
    K = np.array([[40.0, 0.0, 20.0], [0.0, 40.0, 15.0], [0.0, 0.0, 1.0]])
    depth = np.full((H, W), 1.0, np.float32)
    depth[10:20, 15:25] = 0.3  # a patch 0.3 m in front of the camera: the robot's sphere sits there
    obs = Observation(depth, np.zeros((H, W, 3), np.uint8), K, np.eye(4), 0.0, np.zeros(7))
    robot = OneSphere((0.0, 0.0, 0.3), 0.06)
    mine = self_pixels(obs, robot, margin=0.0)
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    p = np.stack([(u - 20) / 40 * depth, (v - 15) / 40 * depth, depth], -1)
    expect = np.linalg.norm(p - robot.centre, axis=-1) <= 0.06
    np.testing.assert_array_equal(mine, expect)
    assert mine.any() and not mine[depth == 1.0].any()
    seen = []
    det = SelfMaskedDetector(lambda o, q: seen.append(o) or (), robot, margin=0.0)
    assert det(obs, None) == ()
    np.testing.assert_array_equal(seen[0].depth == 0, mine)
    np.testing.assert_array_equal(seen[0].depth[~mine], depth[~mine])
    assert obs.depth.min() > 0  # the caller's observation is not changed
    with pytest.raises(CompassInputError, match="margin 0.5"):
        SelfMaskedDetector(lambda o, q: (), robot, margin=0.5)
