"""GraspNet's force-closure score on hand-built contact pairs with known friction thresholds."""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.quality import MU_GRID, graspnet_mu, graspnet_score, required_mu


def pair(theta1: float, theta2: float = 0.0, width: float = 0.04):
    """Contacts on the x axis, outward normals tilted from the closing line by theta [rad]."""
    p1, p2 = np.array([[0.0, 0.0, 0.0]]), np.array([[width, 0.0, 0.0]])
    n1 = np.array([[-math.cos(theta1), math.sin(theta1), 0.0]])  # inward normal at theta1 from +x
    n2 = np.array([[math.cos(theta2), 0.0, math.sin(theta2)]])
    return p1, p2, n1, n2


def test_perfect_antipodal_pair_scores_one():
    assert graspnet_mu(*pair(0.0))[0] == pytest.approx(0.1)
    assert graspnet_score(*pair(0.0))[0] == pytest.approx(1.0)


@pytest.mark.parametrize("mu", [0.1, 0.3, 0.5, 0.8, 1.0])
def test_threshold_exactly_on_the_grid_keeps_its_mu(mu):
    theta = math.atan(mu)
    assert required_mu(*pair(theta))[0] == pytest.approx(mu)
    assert graspnet_mu(*pair(theta))[0] == pytest.approx(mu)
    assert graspnet_score(*pair(theta))[0] == pytest.approx(round(1.1 - mu, 1))


def test_just_above_a_threshold_needs_the_next_mu():
    theta = math.atan(0.3) + 1e-4
    assert graspnet_mu(*pair(theta))[0] == pytest.approx(0.4)
    assert graspnet_score(*pair(theta))[0] == pytest.approx(0.7)


def test_worst_contact_decides():
    s = graspnet_score(*pair(math.atan(0.15), math.atan(0.62)))[0]
    assert s == pytest.approx(1.1 - 0.7)


def test_outside_every_friction_cone_scores_zero():
    assert np.isnan(graspnet_mu(*pair(math.atan(1.2)))[0])
    assert graspnet_score(*pair(math.atan(1.2)))[0] == 0.0
    p1, p2, n1, n2 = pair(0.0)
    assert graspnet_score(p1, p2, -n1, n2)[0] == 0.0  # a normal facing the wrong way


def test_score_is_symmetric_in_the_contacts_and_vectorised():
    thetas = np.linspace(0.0, 0.9, 7)
    P = [pair(t, t / 2) for t in thetas]
    p1, p2, n1, n2 = (np.vstack([p[i] for p in P]) for i in range(4))
    s = graspnet_score(p1, p2, n1, n2)
    assert np.allclose(s, graspnet_score(p2, p1, n2, n1))
    assert np.all(np.diff(s) <= 0) and set(np.round(s, 1)) <= set(np.round(1.1 - MU_GRID, 1)) | {0.0}


def test_bad_input_is_named():
    p1, p2, n1, n2 = pair(0.0)
    with pytest.raises(CompassInputError, match="coincident"):
        required_mu(p1, p1, n1, n2)
    with pytest.raises(CompassInputError, match="must all be"):
        required_mu(p1, p2[:, :2], n1, n2)
