"""Edge cones (a contact on a rim scores with the normals of the faces meeting there) and the
depth samples (the hand placed deeper, within its opening and its pads' reach)."""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.candidates import DEEP_EDGE, CandidateConfig, antipodal_candidates
from compass_manip.grasp.hand_volume import PAD_BACK, PAD_TIP, depth_keep, pad_section
from compass_manip.grasp.quality import graspnet_score, graspnet_score_cones, required_mu_cones
from compass_manip.grasp.target import TargetModel, normal_cones, pca_normals, principal_axes, thin
from compass_manip.robot.model import GRIPPER_MAX_WIDTH

EDGE = CandidateConfig(**DEEP_EDGE)


def solid_box(half, centre=(0.6, 0.0, 0.4), step=0.004):
    """A box's surface points thinned to `step`, with PCA normals oriented away from its
    centre (as the target model estimates them: blended across its edges)."""
    half, centre = np.asarray(half, float), np.asarray(centre, float)
    g = [np.arange(-h, h + 1e-9, step / 2) for h in half]
    X, Y, Z = np.meshgrid(*g, indexing="ij")
    p = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)
    on = np.any(np.isclose(np.abs(p), half, atol=1e-9), axis=1)
    P = thin(p[on] + centre, step)
    n = pca_normals(P, 10)
    n[np.sum(n * (P - centre), axis=1) < 0] *= -1
    return P, n


def cones_of(P, N, idx):
    return normal_cones(P, N, np.asarray(idx), EDGE.edge_radius, EDGE.edge_k, EDGE.edge_angle)


def nearest(P, q):
    return int(np.argmin(np.linalg.norm(P - np.asarray(q), axis=1)))


def test_a_rim_contact_scores_lower_than_a_face_contact():
    """A 5 cm box: the pair from the top rim of one side face down across to the other side
    (closing line tilted ~30 deg, as on level 3 scene 0 of seed 0) is force-closure at mu 0.6
    on the rim's blended PCA normal, not at all with the rim's cone (the top face's normal is
    60 deg off the line); a pair across the faces' middles keeps its score."""
    c, h = np.array([0.6, 0.0, 0.4]), 0.025
    P, N = solid_box((h, h, h), c)
    i_rim = nearest(P, c + [-h, 0.0, h])
    j_low = nearest(P, c + [h, 0.0, h - 2 * h * math.tan(math.radians(30.0))])
    i_face, j_face = nearest(P, c + [-h, 0.0, 0.0]), nearest(P, c + [h, 0.0, 0.0])
    i, j = np.array([i_rim, i_face]), np.array([j_low, j_face])
    plain = graspnet_score(P[i], P[j], N[i], N[j])
    cone = graspnet_score_cones(P[i], P[j], cones_of(P, N, i), cones_of(P, N, j))
    assert plain[0] >= 0.3  # the blended normal makes the rim pair look force-closure
    assert cone[0] < plain[0] and cone[0] < cone[1]
    assert cone[0] == 0.0
    assert cone[1] == pytest.approx(plain[1]) and cone[1] >= 0.9  # a face contact is not an edge


def test_candidates_on_a_box_keep_rim_contacts_only_where_the_cone_allows():
    P, N = solid_box((0.02, 0.025, 0.05))
    axes, ext = principal_axes(P)
    model = TargetModel(P, N, np.ones(len(P), bool), P.mean(0), axes, ext, np.array([1.0, 0, 0]))
    top = P[:, 2].max()
    off = antipodal_candidates(model, CandidateConfig(n_contacts=300, edge_angle=None), np.random.default_rng(2))
    on = antipodal_candidates(model, CandidateConfig(n_contacts=300, **DEEP_EDGE), np.random.default_rng(2))
    rim = lambda c: np.maximum(c.p1[:, 2], c.p2[:, 2]) > top - 0.002  # noqa: E731
    tilted = lambda c: np.abs(c.p2[:, 2] - c.p1[:, 2]) / c.width > math.sin(math.radians(20.0))  # noqa: E731
    assert np.count_nonzero(rim(off) & tilted(off)) > 0
    assert np.count_nonzero(rim(on) & tilted(on)) < np.count_nonzero(rim(off) & tilted(off))
    assert np.all(on.score > 0)


def test_cone_score_matches_the_known_mu_thresholds():
    """Hand-built pairs on the x axis: a cone of one normal is the plain score; a cone whose
    worst normal is at arctan(mu) from the line needs exactly mu."""
    p1, p2 = np.zeros((1, 3)), np.array([[0.04, 0.0, 0.0]])
    out = np.array([[-1.0, 0.0, 0.0]])
    for mu in (0.1, 0.3, 0.5, 0.8, 1.0):
        t = math.atan(mu)
        tilted = np.array([[-math.cos(t), 0.0, math.sin(t)]])
        c1 = np.stack([out, tilted], axis=1)  # (1,2,3)
        c2 = np.stack([-out, -out], axis=1)
        assert required_mu_cones(p1, p2, c1, c2)[0] == pytest.approx(mu)
        assert graspnet_score_cones(p1, p2, c1, c2)[0] == pytest.approx(round(1.1 - mu, 1))
        one = np.stack([tilted, tilted], axis=1)
        assert graspnet_score_cones(p1, p2, one, c2)[0] == graspnet_score(p1, p2, tilted, -out)[0]
    past = np.array([[[-1.0, 0.0, 0.0], [-math.cos(1.0), 0.0, math.sin(1.0)]]])  # 57 deg: mu 1.56
    assert graspnet_score_cones(p1, p2, past, np.stack([-out, -out], axis=1))[0] == 0.0
    with pytest.raises(CompassInputError):
        required_mu_cones(p1, p2, np.zeros((1, 2, 3)), np.zeros((2, 2, 3)))


def cylinder(radius=0.03, height=0.1, centre=(0.6, 0.0, 0.3), step=0.004):
    c = np.asarray(centre, float)
    ang = np.arange(0.0, 2 * np.pi, step / radius)
    zs = np.arange(-height / 2, height / 2 + 1e-9, step)
    A, Zs = np.meshgrid(ang, zs)
    return np.stack([radius * np.cos(A.ravel()), radius * np.sin(A.ravel()), Zs.ravel()], 1) + c


def hands(mid, depths, approach=(1.0, 0.0, 0.0), close=(0.0, 1.0, 0.0)):
    a, y = np.asarray(approach, float), np.asarray(close, float)
    T = np.tile(np.eye(4), (len(depths), 1, 1))
    T[:, :3, :3] = np.stack([np.cross(y, a), y, a], axis=-1)
    T[:, :3, 3] = np.asarray(mid, float) + np.asarray(depths, float)[:, None] * a
    return T


def test_a_front_chord_whose_axis_lies_beyond_the_fingertips_is_taken_deeper():
    """A 6 cm cylinder approached along +x, the contacts on a chord 8 mm in front of its axis:
    at depth 0 the axis lies 8 mm beyond the TCP (1 mm inside the 9 mm fingertips, less than
    the 5 mm margin), so only the deeper samples of that approach are kept; with depth 0 alone
    (the former candidates) it is kept."""
    c = np.array([0.6, 0.0, 0.3])
    P = cylinder(centre=c)
    mid = c + [-0.008, 0.0, 0.0]
    w = 2 * math.sqrt(0.03 ** 2 - 0.008 ** 2)
    depths = np.array([0.0, 0.01, 0.02])
    T = hands(mid, depths)
    _, centre = pad_section(P, T, np.full(3, w))
    assert centre == pytest.approx(0.008 - depths, abs=1.5e-3)
    keep = depth_keep(P, T, np.full(3, w), depths, np.zeros(3, int), EDGE)
    assert keep.tolist() == [False, True, True]
    keep0 = depth_keep(P, T[:1], np.full(1, w), depths[:1], np.zeros(1, int), CandidateConfig(depths=(0.0,)))
    assert keep0.tolist() == [True]
    # an approach whose centre no depth brings inside keeps all its samples
    far = hands(c + [-0.025, 0.0, 0.0], depths)  # a chord near the front: the axis 25 mm beyond the TCP
    w_far = 2 * math.sqrt(0.03 ** 2 - 0.025 ** 2)
    assert depth_keep(P, far, np.full(3, w_far), depths, np.zeros(3, int), EDGE).all()


def test_depth_samples_stay_within_the_opening_and_the_pads():
    """A deeper hand is dropped where the target between its pads would need more than the
    hand's opening (a 4 cm cylinder in front of a 9 cm plate), and every candidate
    of a cylinder keeps its contacts on the pads and its pads' section within the opening."""
    c = np.array([0.6, 0.0, 0.3])
    P = cylinder(radius=0.02, centre=c)
    plate = np.stack(np.meshgrid(np.arange(-0.045, 0.0451, 0.004), np.arange(-0.02, 0.0201, 0.004)), -1).reshape(-1, 2)
    P2 = np.vstack([P, np.c_[np.full(len(plate), c[0] + 0.026), plate[:, 0], c[2] + plate[:, 1]]])
    depths = np.array([0.0, 0.01, 0.02])
    T = hands(c, depths)
    span, _ = pad_section(P2, T, np.full(3, 0.04))
    assert span[0] < 0.021 and span[2] > 0.04  # the plate, 2.6 cm beyond the axis, is between the pads at 2 cm
    keep = depth_keep(P2, T, np.full(3, 0.04), depths, np.arange(3), EDGE)
    assert keep.tolist() == [True, True, False]
    assert keep.dtype == bool
    # the opening test at depth 0 too (opening_all): a hand whose pads would land on the plate
    T0 = hands(c + [0.02, 0.0, 0.0], [0.0])  # the plate 6 mm beyond the TCP, between the pads
    assert depth_keep(P2, T0, np.full(1, 0.03), np.zeros(1), np.zeros(1, int), EDGE).tolist() == [True]
    assert depth_keep(P2, T0, np.full(1, 0.03), np.zeros(1), np.zeros(1, int),
                      CandidateConfig(opening_all=True, **DEEP_EDGE)).tolist() == [False]
    N = P - c
    N[:, 2] = 0.0
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    axes, ext = principal_axes(P)
    model = TargetModel(P, N, np.ones(len(P), bool), c, axes, ext, np.array([1.0, 0, 0]))
    cands = antipodal_candidates(model, CandidateConfig(n_contacts=150, **DEEP_EDGE), np.random.default_rng(4))
    assert len(cands) > 0
    mid = 0.5 * (cands.p1 + cands.p2)
    z_contacts = np.sum((mid - cands.T_world_tcp[:, :3, 3]) * cands.approach, axis=1)
    assert np.all(z_contacts <= PAD_TIP) and np.all(z_contacts >= -PAD_BACK)
    assert np.any(z_contacts < -0.005)  # deeper samples are among them
    span, _ = pad_section(P, cands.T_world_tcp, cands.width)
    assert np.all(span[z_contacts < 0] <= 0.5 * GRIPPER_MAX_WIDTH - EDGE.width_clearance + 1e-12)
    assert np.all(antipodal_candidates(model, CandidateConfig(n_contacts=150), np.random.default_rng(4)).score > 0)


def test_depth_and_edge_settings_are_checked():
    with pytest.raises(CompassInputError):
        CandidateConfig(depths=(0.0, 0.04))  # the contacts would be behind the pads
    with pytest.raises(CompassInputError):
        CandidateConfig(depths=())
    with pytest.raises(CompassInputError):
        CandidateConfig(edge_angle=2.0)
    with pytest.raises(CompassInputError):
        CandidateConfig(edge_radius=0.0)
