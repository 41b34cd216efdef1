"""Grasp hypotheses for active sensing: the voxels a hypothesis needs (hand-counted on a
constructed map), the union weights, and on a shelf whose corridor in front of the target is
unknown: the strict selection fails, the hypotheses exist with unknown space free, and the
voxels they need lie in that unknown corridor (none once it is seen)."""

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.hypotheses import (GraspHypothesis, HypothesisConfig, grasp_hypotheses, needed_voxels,
                                            strict_unsafe_mask)
from compass_manip.grasp.select import GraspSelectConfig, Rejection, base_volume, select_grasp
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.trial.grasp_views import weighted_voxels

from test_grasp_select import shelf_world

# unknown corridor in front of the box (the box spans x 0.53..0.57, the opening is at x = 0.45)
SLAB = (np.array([0.40, -0.2, 0.465]), np.array([0.528, 0.2, 0.75]))


class OneSphere:
    """A 'robot' of one sphere at a fixed point (every configuration)."""

    def __init__(self, centre, radius):
        self.centre, self.radii = np.asarray(centre, float), np.array([radius])

    def sphere_centers(self, Q):
        return np.broadcast_to(self.centre, (len(Q), 1, 3)).copy()


def one_hypothesis(score=1.0):
    q = np.zeros(7)
    return GraspHypothesis(np.eye(4), score, q, q, q, 0.1, 0.1)


def test_needed_voxels_are_the_unknown_unsafe_voxels_inside_the_grown_spheres():
    occ = OccupancyMap(MapConfig())
    ijk = np.array([40, 40, 40])
    centre = occ.voxel_to_world(ijk[None])[0]
    sphere = OneSphere(centre, 0.016)  # + inflate 9 mm = 2.5 voxels: i^2 + j^2 + k^2 <= 6.25
    cfg = HypothesisConfig(inflate=0.009)
    strict = np.ones(occ.shape, bool)
    # lattice points within radius 2.5: 1 + 6 + 12 + 8 (|1,1,1|) + 6 (|2,0,0|) + 24 (|2,1,0|) + 24 (|2,1,1|) = 81
    assert [len(n) for n in needed_voxels(occ, [one_hypothesis()], sphere, strict, cfg)] == [81]
    i, j, k = ijk
    occ.state[i - 3:i + 4, j - 3:j + 4, k] = VoxelState.FREE  # the layer k = 0: 1 + 4 + 4 + 4 + 8 = 21 seen free
    assert len(needed_voxels(occ, [one_hypothesis()], sphere, strict, cfg)[0]) == 60
    occ.state[i - 3:i + 4, j - 3:j + 4, k + 1] = VoxelState.OCCUPIED  # layer k = 1 (i^2+j^2 <= 5.25: 21) is known
    strict[i - 3:i + 4, j - 3:j + 4, k + 2] = False  # layer k = 2 (i^2+j^2 <= 2.25: 9) is safe for the selection
    assert len(needed_voxels(occ, [one_hypothesis()], sphere, strict, cfg)[0]) == 60 - 21 - 9


def test_weighted_voxels_sum_the_weights_of_the_hypotheses_needing_a_voxel():
    occ = OccupancyMap(MapConfig())
    a = np.array([[1, 2, 3], [4, 5, 6]])
    b = np.array([[4, 5, 6], [7, 8, 9], [1, 1, 1]])
    centres, w = weighted_voxels(occ, [a, b], np.array([0.5, 0.25]))
    got = {tuple(occ.world_to_voxel(c[None])[0]): float(x) for c, x in zip(centres, w)}
    assert got == {(1, 2, 3): 0.5, (4, 5, 6): 0.75, (7, 8, 9): 0.25, (1, 1, 1): 0.25}
    assert len(weighted_voxels(occ, [np.zeros((0, 3), int)], np.array([1.0]))[0]) == 0


def test_hypothesis_config_rejects_bad_values():
    with pytest.raises(CompassInputError, match="n_hypotheses"):
        HypothesisConfig(n_hypotheses=0)
    with pytest.raises(CompassInputError, match="inflate"):
        HypothesisConfig(inflate=0.5)


@pytest.fixture(scope="module")
def unknown_corridor():
    occ, task, target = shelf_world(board_above_z=0.74)
    known = occ.copy()
    occ.set_box(*SLAB, VoxelState.UNKNOWN)
    return occ, known, task, target


def _context(occ, target):
    spheres = panda_sphere_model()
    q = np.asarray(Q_HOME, float)
    bc, br = base_volume(spheres, q)
    safe = (np.vstack([spheres.sphere_centers(q[None])[0], bc]), np.r_[spheres.radii + 0.02, br])
    return spheres, q, safe


def test_hypotheses_exist_where_the_strict_selection_fails_and_need_the_unknown_corridor(unknown_corridor):
    occ, known, task, target = unknown_corridor
    spheres, q, safe = _context(occ, target)
    sc = GraspSelectConfig()
    strict_sel = select_grasp(target, occ, task, q, spheres, sc, np.random.default_rng(0), safe_spheres=safe)
    assert strict_sel.failure is not None and strict_sel.rejections[Rejection.HAND_IN_COLLISION] > 0
    cfg = HypothesisConfig(n_hypotheses=4)
    hyps = grasp_hypotheses(target, occ, task, q, spheres, sc, cfg, np.random.default_rng(0), safe)
    assert 1 <= len(hyps) <= 4 and all(h.score > 0 for h in hyps)
    strict = strict_unsafe_mask(occ, target, sc.clearance, safe, None)
    needed = needed_voxels(occ, hyps, spheres, strict, cfg)
    assert all(len(n) > 0 for n in needed)
    c = occ.voxel_to_world(np.vstack(needed))
    assert np.all((c >= SLAB[0] - 1e-9) & (c <= SLAB[1] + 1e-9))  # only voxels of the unknown corridor
    # seen: nothing left to look at, and the strict selection now takes a grasp
    strict_known = strict_unsafe_mask(known, target, sc.clearance, safe, None)
    assert all(len(n) == 0 for n in needed_voxels(known, hyps, spheres, strict_known, cfg))
    assert select_grasp(target, known, task, q, spheres, sc, np.random.default_rng(0), safe_spheres=safe).success


def test_hypotheses_are_not_near_duplicates(unknown_corridor):
    occ, _, task, target = unknown_corridor
    spheres, q, safe = _context(occ, target)
    cfg = HypothesisConfig(n_hypotheses=6, min_separation=0.02, min_turn=0.26)
    hyps = grasp_hypotheses(target, occ, task, q, spheres, GraspSelectConfig(), cfg, np.random.default_rng(1), safe)
    for a in range(len(hyps)):
        for b in range(a):
            A, B = hyps[a].T_world_tcp, hyps[b].T_world_tcp
            assert np.linalg.norm(A[:3, 3] - B[:3, 3]) >= 0.02 or A[:3, 2] @ B[:3, 2] <= np.cos(0.26)
