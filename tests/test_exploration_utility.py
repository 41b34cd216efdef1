"""The MUE-RRT utility terms against hand-computed cases."""
import numpy as np
import pytest

from compass_manip.exploration.utility import heuristic, momentum, motion_cost, normalise, utility
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME


def test_momentum_rewards_keeping_the_direction_of_travel():
    t_prev, t_root = np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.0, 0.0])
    t_x = np.array([[0.3, 0.0, 0.0], [0.0, 0.0, 0.0], [0.1, 0.2, 0.0]])
    # (t_root - t_prev) . (t_x - t_root) = 0.1 * 0.2, 0.1 * -0.1, 0
    np.testing.assert_allclose(momentum(t_prev, t_root, t_x), [0.02, -0.01, 0.0])


def test_heuristic_is_the_best_cosine_towards_any_point():
    axes = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    t_v = np.zeros((2, 3))
    points = np.array([[2.0, 0.0, 0.0], [0.0, 3.0, 3.0]])
    # view 0 looks straight at point 0 (cos 1); view 1 sees point 1 at 45 deg (cos 1/sqrt 2)
    np.testing.assert_allclose(heuristic(axes, t_v, points), [1.0, 1 / np.sqrt(2)])
    np.testing.assert_allclose(heuristic(axes, t_v, np.zeros((0, 3))), [0.0, 0.0])


def test_motion_cost_is_the_joint_path_length():
    p = np.zeros((3, 7))
    p[1, 0] = 0.3
    p[2, 0], p[2, 1] = 0.3, 0.4
    assert motion_cost([p, p[:1]]) == pytest.approx([0.7, 0.0])


def test_utility_combines_normalised_terms_over_cost():
    G, D, M, H, C = np.array([10.0, 5.0]), np.array([-0.5, 1.0]), np.array([0.1, 0.05]), np.array([1.0, 0.0]), \
        np.array([0.5, 1.5])
    U = utility(G, D, M, H, C, (1.0, 0.2, 0.3, 0.5), 0.5)
    # node 0: (1 + 0.2 * -0.5 + 0.3 * 1 + 0.5 * 1) / 1.0; node 1: (0.5 + 0.2 + 0.15 + 0) / 2.0
    np.testing.assert_allclose(U, [1.7, 0.425])
    np.testing.assert_allclose(normalise(np.zeros(3)), 0.0)


def test_manipulability_term_is_yoshikawa():
    kin = PandaKinematics()
    J = kin.jacobian(Q_HOME)
    assert kin.manipulability(Q_HOME) == pytest.approx(np.sqrt(np.linalg.det(J @ J.T)), rel=1e-9)
    assert kin.manipulability_batch(Q_HOME[None])[0] == pytest.approx(kin.manipulability(Q_HOME), rel=1e-9)


def test_view_pose_matches_look_at_with_roll():
    from compass_manip.exploration.viewpoints import view_pose
    from compass_manip.geometry import look_at, make_T, rot_z

    p, d = np.array([0.7, -0.1, 0.5]), np.array([0.8, 0.3, -0.5])
    d /= np.linalg.norm(d)
    T = view_pose(p, d, 0.4, 0.7)
    np.testing.assert_allclose(T, look_at(p - 0.4 * d, p) @ make_T(rot_z(0.7)), atol=1e-12)


def test_tree_path_costs_equal_motion_cost_bit_for_bit():
    """GSE's node costs from the tree equal `motion_cost` of every root path exactly, for
    shallow nodes (summed in order) and deep ones (numpy's pairwise sum)."""
    from compass_manip.exploration.utility import motion_cost, tree_path_costs

    rng = np.random.default_rng(0)
    for deep in (False, True):
        n = 120
        Q = rng.uniform(-2.0, 2.0, (n, 7))
        parent = np.full(n, -1)
        for k in range(1, n):
            parent[k] = k - 1 if deep and k < 40 else rng.integers(0, k)

        def path_to(k):
            idx = []
            while k >= 0:
                idx.append(k)
                k = int(parent[k])
            return Q[idx[::-1]]

        expected = motion_cost([path_to(k) for k in range(n)])
        assert np.array_equal(tree_path_costs(Q, parent), expected)
    assert np.array_equal(tree_path_costs(Q[:1], parent[:1]), [0.0])
