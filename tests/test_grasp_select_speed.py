"""The grasp selection's speed-ups (branch gfast): the exact ones give the same answers (tree
edges from a known-valid node, sequential checks of IK solutions, the EDT's float32 scratch),
and the field exact around the robot's tight links is sound and gives the start more of the
plan's margin than the map-grid bound."""
import math

import numpy as np

from compass_manip.grasp.checks import GraspChecks, SequentialValidity, tight_link_boxes
from compass_manip.grasp.select import GraspSelectConfig
from compass_manip.mapping.distance import _distances, _distances_into
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.motion.primitives import DistanceGrid
from compass_manip.motion.tree import JointTree, TRAPPED, edge_ok, edge_ok_from, extend
from compass_manip.motion.validity import ValidityChecker
from compass_manip.robot.ik import PandaIK
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN
from compass_manip.robot.spheres import panda_sphere_model

from test_grasp_select import shelf_world

HOME = np.asarray(Q_HOME, dtype=np.float64)


def _checker():
    occ, _, _ = shelf_world(board_above_z=0.74)
    from compass_manip.mapping.distance import DistanceField
    field = DistanceField.from_unsafe(occ.state == VoxelState.OCCUPIED, occ.grid_min, occ.resolution)
    return ValidityChecker(panda_sphere_model(), grid=DistanceGrid.from_distance_field(field))


def test_an_edge_from_a_valid_node_gets_the_same_answer_without_checking_the_node():
    chk = _checker()
    args = chk.kernel_args()
    rng = np.random.default_rng(0)
    verdicts = []
    for _ in range(300):
        q0 = np.clip(HOME + rng.normal(0.0, 0.4, 7), Q_MIN, Q_MAX)
        if not chk.is_valid(q0):
            continue
        q1 = np.clip(q0 + rng.normal(0.0, 0.4, 7), Q_MIN, Q_MAX)
        for res in (0.04, 0.005):
            full, skip = bool(edge_ok(q0, q1, res, args)), bool(edge_ok_from(q0, q1, res, args))
            assert full == skip
            verdicts.append(full)
    assert 50 < len(verdicts) and any(verdicts) and not all(verdicts)


def test_tree_growth_is_the_same_with_and_without_the_skip_and_an_invalid_root_never_grows():
    chk = _checker()
    args = chk.kernel_args()
    rng = np.random.default_rng(1)
    targets = Q_MIN + (Q_MAX - Q_MIN) * rng.random((200, 7))
    trees = []
    for valid in (False, True):
        nodes, parent, count = np.empty((2000, 7)), np.full(2000, -1), 1
        nodes[0] = HOME
        for t in targets:
            _, _, count, _ = extend(args, nodes, parent, count, t, 0.5, 0.04, True, valid)
        trees.append(nodes[:count].copy())
    assert len(trees[0]) > 20 and np.array_equal(trees[0], trees[1])
    bad = next(q for q in targets if not chk.is_valid(q))  # a configuration in collision
    tree = JointTree(bad, chk)
    assert not tree.root_valid
    for t in targets[:20]:
        assert tree.extend(t, connect=True)[0] == TRAPPED
    assert tree.count == 1


def test_edt_float32_scratch_equals_float64():
    rng = np.random.default_rng(2)
    for shape, p in (((23, 17, 31), 0.01), ((40, 9, 12), 0.001), ((5, 5, 5), 0.5)):
        unsafe = rng.random(shape) < p
        unsafe[0, 0, 0] = True
        ref = _distances_into(unsafe, 0.005, np.empty(shape, np.float64))
        got = _distances(unsafe, 0.005)
        assert got.dtype == np.float32 and np.array_equal(got, ref)


def test_sequential_validity_equals_the_parallel_batch():
    chk = _checker()
    Q = np.clip(HOME + np.random.default_rng(3).normal(0.0, 0.5, (300, 7)), Q_MIN, Q_MAX)
    want = chk.are_valid(Q)
    assert 0 < want.sum() < len(Q)
    assert np.array_equal(SequentialValidity(chk).are_valid(Q), want)


def test_the_field_exact_around_a_tight_link_is_sound_and_gives_the_start_more_margin():
    occ, _, target = shelf_world(board_above_z=0.74)
    # a wall 2-3 cm behind the elbow (link 4) at home, outside the target's and the wrist's boxes
    occ.set_box((-0.345, -0.15, 0.45), (-0.335, 0.10, 0.70), VoxelState.OCCUPIED)
    spheres = panda_sphere_model()
    ik, config = PandaIK(spheres.kinematics), GraspSelectConfig()
    cur = spheres.sphere_centers(HOME[None])[0]
    safe = (cur, spheres.radii + config.robot_clearance)
    bound = GraspChecks(occ, target, spheres, ik, config, safe, None, HOME, tight_margin=None)
    tight = GraspChecks(occ, target, spheres, ik, config, safe, None, HOME, tight_margin=0.02)
    exact = GraspChecks(occ, target, spheres, ik, config, safe, None, HOME, exact_everywhere=True, reuse=bound)
    a, b = bound._parts["a"], bound._parts["b"]
    boxes = tight_link_boxes(bound._parts["coarse"], a, b, occ, spheres, cur, 0.02, 0.05)
    link4 = spheres.link_names.index("panda_link4")
    assert len(boxes) >= 1
    lo = occ.grid_min + (a + np.min([bx[0] for bx in boxes], axis=0)) * occ.resolution
    assert lo[0] < -0.314  # a box reaches behind the elbow
    f_bound, f_tight, f_exact = bound.fine.distances, tight.fine.distances, exact.fine.distances
    assert np.all(f_tight >= f_bound - 1e-6)  # never looser than the bound it refines ...
    assert np.all(f_tight <= f_exact + 1e-6)  # ... and never above the exact distances (sound)
    assert np.count_nonzero(f_tight > f_bound + 1e-6) > 1000
    # the elbow's clearance: the bound's, raised towards the exact one
    e = spheres.body_index == link4
    c_bound = bound.fine.distance_at(cur[e]) - spheres.radii[e]
    c_tight = tight.fine.distance_at(cur[e]) - spheres.radii[e]
    assert c_tight.min() > c_bound.min() + 0.002
    assert tight.plan.clearance(HOME) >= bound.plan.clearance(HOME)
    assert math.isfinite(tight.plan_margin)
