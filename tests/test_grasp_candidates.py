"""Antipodal candidates and the target model on synthetic objects."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.candidates import AntipodalProposer, CandidateConfig, antipodal_candidates
from compass_manip.grasp.target import TargetModel, build_target_model, principal_axes
from compass_manip.robot.model import GRIPPER_MAX_WIDTH
from compass_manip.task import TargetQuery


def box_surface(half, centre=(0.6, 0.0, 0.4), step=0.004):
    """Points and outward normals on all six faces of an axis-aligned box."""
    half, centre = np.asarray(half, float), np.asarray(centre, float)
    pts, nrm = [], []
    for ax in range(3):
        u, v = [a for a in range(3) if a != ax]
        gu = np.arange(-half[u], half[u] + 1e-9, step)
        gv = np.arange(-half[v], half[v] + 1e-9, step)
        U, V = np.meshgrid(gu, gv)
        for sign in (-1.0, 1.0):
            p = np.zeros((U.size, 3))
            p[:, u], p[:, v], p[:, ax] = U.ravel(), V.ravel(), sign * half[ax]
            n = np.zeros_like(p)
            n[:, ax] = sign
            pts.append(p + centre)
            nrm.append(n)
    return np.vstack(pts), np.vstack(nrm)


def model(points, normals):
    axes, ext = principal_axes(points)
    return TargetModel(points, normals, np.ones(len(points), bool), points.mean(0), axes, ext, np.array([1.0, 0, 0]))


def test_candidates_are_force_closure_within_the_hand_and_well_formed():
    P, N = box_surface((0.02, 0.025, 0.06))
    c = antipodal_candidates(model(P, N), CandidateConfig(n_contacts=80), np.random.default_rng(0))
    assert len(c) > 100
    assert np.all(c.width <= CandidateConfig().max_width + 1e-9) and np.all(c.width <= GRIPPER_MAX_WIDTH)
    assert np.all(c.score > 0) and np.all(c.score <= 1.0)
    R = c.T_world_tcp[:, :3, :3]
    assert np.allclose(np.einsum("mji,mjk->mik", R, R), np.eye(3), atol=1e-9)
    assert np.allclose(np.linalg.det(R), 1.0)
    line = (c.p2 - c.p1) / np.linalg.norm(c.p2 - c.p1, axis=1, keepdims=True)
    assert np.allclose(np.abs(np.sum(R[:, :, 1] * line, axis=1)), 1.0, atol=1e-9)  # y = closing line
    # the TCP at one of the depths past the contacts' midpoint, along the approach
    off = c.T_world_tcp[:, :3, 3] - 0.5 * (c.p1 + c.p2)
    d = np.sum(off * c.approach, axis=1)
    assert np.allclose(off, d[:, None] * c.approach, atol=1e-12)
    assert np.all(np.min(np.abs(d[:, None] - np.array(CandidateConfig().depths)), axis=1) < 1e-12)
    # face-to-face pairs across the 4 and 5 cm sides score 1.0
    best = c.score == 1.0
    assert best.any()
    assert np.all(np.min(np.abs(c.width[best][:, None] - [0.04, 0.05]), axis=1) < 0.005)


def test_candidates_never_wider_than_the_hand():
    P, N = box_surface((0.05, 0.05, 0.05))  # a 10 cm cube: nothing fits
    c = antipodal_candidates(model(P, N), CandidateConfig(n_contacts=200), np.random.default_rng(1))
    assert len(c) == 0
    P, N = box_surface((0.02, 0.06, 0.06))  # only across the 4 cm side
    c = antipodal_candidates(model(P, N), CandidateConfig(n_contacts=200), np.random.default_rng(1))
    assert len(c) > 0 and np.all(c.width <= CandidateConfig().max_width)
    assert np.allclose(np.abs(c.p2[:, 0] - c.p1[:, 0]), 0.04, atol=1e-6)  # always across the 4 cm side


def test_same_seed_same_candidates_and_rng_required():
    P, N = box_surface((0.02, 0.025, 0.06))
    m = model(P, N)
    a = AntipodalProposer().propose(m, np.random.default_rng(3))
    b = AntipodalProposer().propose(m, np.random.default_rng(3))
    assert np.array_equal(a.T_world_tcp, b.T_world_tcp) and np.array_equal(a.score, b.score)
    with pytest.raises(CompassInputError):
        antipodal_candidates(m, None, None)


def test_target_model_completes_a_half_seen_cylinder():
    rng = np.random.default_rng(0)
    r, c = 0.025, np.array([0.6, 0.1, 0.45])
    cam = np.array([0.2, 0.1, 0.6])
    phi = rng.uniform(np.pi / 2, 3 * np.pi / 2, 3000)  # the half facing the camera (-x)
    z = rng.uniform(-0.06, 0.06, 3000)
    pts = np.stack([c[0] + r * np.cos(phi), c[1] + r * np.sin(phi), c[2] + z], 1)
    q = TargetQuery("cylinder", "red", (0.05, 0.05, 0.12))
    m = build_target_model(pts, cam, q)
    assert np.linalg.norm(m.centre[:2] - c[:2]) < 0.004  # the axis, not the seen surface's centroid
    assert (~m.observed).sum() > 0.5 * m.observed.sum()  # the far side is completed
    radial = m.points[:, :2] - c[:2]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    side = np.abs(m.points[:, 2] - c[2]) < 0.05
    assert np.median(np.sum(m.normals[side, :2] * radial[side], axis=1)) > 0.95  # outward normals
    assert abs(m.axes[2, 0]) > 0.95  # long axis vertical
    cands = antipodal_candidates(m, CandidateConfig(n_contacts=100), rng)
    best = cands.score == 1.0  # diameters
    assert best.any() and np.all(np.abs(cands.width[best] - 0.05) < 0.006)
    with pytest.raises(CompassInputError):
        build_target_model(pts[:5], cam)


def test_approaches_sampled_in_the_cone_stay_in_it_and_cover_it():
    import math

    P, N = box_surface((0.02, 0.025, 0.06))
    toward = np.array([math.cos(0.35), 0.0, -math.sin(0.35)])
    delta = math.radians(50.0)
    m = model(P, N)
    cone = antipodal_candidates(m, CandidateConfig(n_contacts=80), np.random.default_rng(0), toward, delta)
    ang = np.arccos(np.clip(cone.approach @ toward, -1.0, 1.0))
    assert len(cone) > 100 and np.all(ang <= delta + 1e-9)
    assert ang.max() > 0.8 * delta  # the rolls spread over the arc, not only its middle
    every = antipodal_candidates(m, CandidateConfig(n_contacts=80), np.random.default_rng(0))
    in_cone = np.arccos(np.clip(every.approach @ toward, -1.0, 1.0)) <= delta
    assert np.count_nonzero(in_cone) < 0.5 * len(cone)  # all round, most rolls are wasted outside the cone
    # a closing line along toward leaves no approach within a small cone
    P2, N2 = box_surface((0.06, 0.02, 0.02))
    none = antipodal_candidates(model(P2, N2), CandidateConfig(n_contacts=40, n_directions=1),
                                np.random.default_rng(0), np.array([0.0, 1.0, 0.0]), math.radians(10.0))
    assert len(none) == 0 or np.all(np.arccos(np.clip(none.approach[:, 1], -1, 1)) <= math.radians(10.0) + 1e-9)


def test_first_contacts_favour_the_top_band():
    from compass_manip.grasp.candidates import first_contacts

    P, N = box_surface((0.02, 0.02, 0.10))
    cfg = CandidateConfig(n_contacts=100, top_fraction=0.5, top_band=0.03)
    idx = first_contacts(P, cfg, np.random.default_rng(0))
    assert len(idx) == 100 and len(np.unique(idx)) == 100
    top = P[idx, 2] >= P[:, 2].max() - 0.03
    share = np.mean(P[:, 2] >= P[:, 2].max() - 0.03)
    assert top.mean() >= 0.5 and share < 0.4  # at least half from the band, which holds far fewer points
    with pytest.raises(CompassInputError, match="top_fraction"):
        CandidateConfig(top_fraction=1.5)


def _reference_pairs(P, N, first, dirs, config):
    """The contact-pair rule written with whole-array numpy, line by line as documented."""
    out = np.full(len(first), -1)
    for k, i in enumerate(first):
        c = dirs[k]
        d = P - P[i]
        t = d @ c
        on_line = np.linalg.norm(d - t[:, None] * c, axis=1) <= config.line_radius
        if np.any(on_line & (t < -config.line_radius)):
            continue  # p1 is not outermost on its closing line
        far = on_line & (N @ c > 0.0) & (t >= config.min_width)
        if not far.any():
            continue
        j = int(np.argmax(np.where(far, t, -np.inf)))
        if not np.any(on_line & (t > t[j] + config.line_radius)):
            out[k] = j
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_contact_pairs_equal_the_whole_array_rule(seed):
    """The compiled pass finds the same partner for every first contact and closing direction
    as the rule evaluated over all points at once (boxes: partners on the opposite face;
    noisy points: lines with points behind p1 and beyond the partner)."""
    from compass_manip.grasp.candidates import closing_directions, contact_pairs, first_contacts

    rng = np.random.default_rng(seed)
    P, N = box_surface((0.02, 0.03, 0.05))
    P = P + rng.normal(0.0, 0.002, P.shape)
    cfg = CandidateConfig(n_contacts=150)
    first = first_contacts(P, cfg, rng)
    first, dirs = closing_directions(N, first, cfg, rng)
    j, width = contact_pairs(P, N, first, cfg, dirs)
    ref = _reference_pairs(P, N, first, dirs, cfg)
    assert np.array_equal(j, ref)
    assert 0.2 * len(first) < np.count_nonzero(j >= 0) < len(first)  # both outcomes occur
    ok = j >= 0
    assert np.allclose(width[ok], np.linalg.norm(P[j[ok]] - P[first[ok]], axis=1)) and np.all(width[~ok] == 0)
    j0, _ = contact_pairs(P, N, first[:20], cfg)  # default directions: the inward normals
    assert np.array_equal(j0, _reference_pairs(P, N, first[:20], -N[first[:20]], cfg))


def test_top_margin_and_max_tilt_drop_rim_contacts_and_tilted_closing_lines():
    """Off by default; on, no contact in the top layer of points and no closing line tilted
    past max_tilt (levels 1 + 3: the grasps that dropped or slipped had a contact on the top
    rim and lines tilted 31-57 deg)."""
    P, N = box_surface((0.025, 0.025, 0.06))
    top = P[:, 2].max()
    base = antipodal_candidates(model(P, N), CandidateConfig(n_contacts=200), np.random.default_rng(3))
    rise = np.abs(base.p2[:, 2] - base.p1[:, 2]) / base.width
    assert np.any(np.maximum(base.p1[:, 2], base.p2[:, 2]) > top - 0.004)  # the default keeps rim contacts
    assert np.any(rise > np.sin(np.radians(20.0)))  # and tilted lines
    rim = antipodal_candidates(model(P, N), CandidateConfig(n_contacts=200, top_margin=0.004),
                               np.random.default_rng(3))
    assert len(rim) > 0 and np.all(np.maximum(rim.p1[:, 2], rim.p2[:, 2]) <= top - 0.004)
    flat = antipodal_candidates(model(P, N), CandidateConfig(n_contacts=200, max_tilt=np.radians(20.0)),
                                np.random.default_rng(3))
    assert len(flat) > 0
    assert np.all(np.abs(flat.p2[:, 2] - flat.p1[:, 2]) <= np.sin(np.radians(20.0)) * flat.width + 1e-12)
    with pytest.raises(CompassInputError):
        CandidateConfig(top_margin=-0.001)
    with pytest.raises(CompassInputError):
        CandidateConfig(max_tilt=2.0)
