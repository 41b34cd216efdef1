"""Collision spheres: cover the collision geometry, follow FK, sensible self-collision pairs."""
import mujoco
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from compass_manip.errors import CompassInputError
from compass_manip.robot import spheres as S
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN, build_robot_spec


@pytest.fixture(scope="module")
def sm():
    return S.panda_sphere_model()


def _local_hulls(sm):
    m = build_robot_spec(sm.kinematics.robot_config, actuators=False).compile()
    return m, S.collision_hulls(m, sm.link_names)


@pytest.fixture(scope="module")
def sm_fine():
    from compass_manip.robot.sphere_fit import FINE_FIT

    return S.panda_sphere_model(finger_width=0.13, fit=FINE_FIT)


@pytest.mark.parametrize("model", ["sm", "sm_fine"])
def test_every_collision_vertex_and_hull_surface_point_is_covered(model, request):
    sm = request.getfixturevalue(model)
    m, hulls = _local_hulls(sm)
    rng = np.random.default_rng(0)
    colliding = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    names = {m.body(int(m.geom_bodyid[g])).name for g in colliding}
    assert {"hand/panda_leftfinger", "hand/panda_rightfinger", "hand/panda_hand", "panda_link7"} <= names
    for i, link in enumerate(hulls):
        sel = sm.body_index == i
        assert sel.any() == bool(link), sm.link_names[i]
        for P in link:
            h = ConvexHull(P)
            # vertices + random points on the hull faces (MuJoCo collides the convex hull)
            tri = P[h.simplices]
            w = rng.dirichlet(np.ones(3), size=len(tri))
            pts = np.vstack([P, np.einsum("tk,tkd->td", w, tri)])
            d = np.linalg.norm(pts[:, None, :] - sm.centers_local[sel][None], axis=2) - sm.radii[sel]
            assert np.all(d.min(axis=1) <= 1e-12), sm.link_names[i]
    # camera housing: box corners on the hand
    hand = sm.link_names.index("hand/panda_hand")
    g = m.geom("camera_housing").id
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * m.geom_size[g]
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, m.geom_quat[g])
    corners = corners @ R.reshape(3, 3).T + m.geom_pos[g]
    sel = sm.body_index == hand
    d = np.linalg.norm(corners[:, None] - sm.centers_local[sel][None], axis=2) - sm.radii[sel]
    assert np.all(d.min(axis=1) < 0)


def test_world_centres_follow_fk(sm):
    rng = np.random.default_rng(1)
    Q = rng.uniform(Q_MIN, Q_MAX, (5, 7))
    W = sm.sphere_centers(Q)
    assert W.shape == (5, sm.n_spheres, 3)
    for n, q in enumerate(Q):
        L = sm.kinematics.fk_links(q)
        ref = np.einsum("sij,sj->si", L[sm.body_index][:, :3, :3], sm.centers_local) + L[sm.body_index][:, :3, 3]
        np.testing.assert_allclose(W[n], ref, atol=1e-12)
        np.testing.assert_allclose(S.sphere_centers_world(sm, q), ref, atol=1e-12)


def test_self_collision_pairs(sm):
    P = sm.self_collision_pairs
    assert P.ndim == 2 and P.shape[1] == 2 and len(P) > 0
    g = S.weld_groups(sm.kinematics)
    ga, gb = g[sm.body_index[P[:, 0]]], g[sm.body_index[P[:, 1]]]
    assert np.all(ga != gb)
    parent = sm.kinematics.tree.parent
    names = sm.link_names
    # adjacent links (joint between them) never appear
    for i in range(1, 8):
        a, b = names.index(f"panda_link{i - 1}"), names.index(f"panda_link{i}")
        pair_links = {(sm.body_index[u], sm.body_index[v]) for u, v in P}
        assert (a, b) not in pair_links and (b, a) not in pair_links
    assert parent[names.index("panda_link1")] == names.index("panda_link0")
    # none overlaps at Q_HOME, and hand vs. base spheres are tested
    W = S.sphere_centers_world(sm, Q_HOME)
    gap = np.linalg.norm(W[P[:, 0]] - W[P[:, 1]], axis=1) - sm.radii[P[:, 0]] - sm.radii[P[:, 1]]
    assert np.all(gap >= 0)
    hand, base = names.index("hand/panda_hand"), names.index("panda_link0")
    assert any({sm.body_index[u], sm.body_index[v]} == {hand, base} for u, v in P)


def test_fit_of_a_box_is_tight_conservative_and_deterministic():
    box = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.02, 0.02) for z in (-0.01, 0.01)])
    fit = S.SphereFitConfig(protrusion=0.01)
    c1, r1 = S._fit_link([box], fit)
    c2, r2 = S._fit_link([box], fit)
    np.testing.assert_array_equal(c1, c2)
    np.testing.assert_array_equal(r1, r2)
    # corners covered, spheres centred inside the box and no bigger than needed
    d = np.linalg.norm(box[:, None] - c1[None], axis=2) - r1
    assert np.all(d.min(axis=1) <= 1e-12)
    assert np.all(np.abs(c1) <= [0.05, 0.02, 0.01])
    assert r1.max() < 0.04
    with pytest.raises(CompassInputError, match="protrusion"):
        S.SphereFitConfig(protrusion=0.5)


def test_cache_round_trip(tmp_path, monkeypatch, sm):
    monkeypatch.setenv("COMPASS_CACHE_DIR", str(tmp_path))
    fit = S.SphereFitConfig(protrusion=0.05, fine_protrusion=0.05, edge_max=0.04, grid=0.04, n_pair_samples=50)
    a = S.fit_spheres(sm.kinematics, fit)
    assert len(list(tmp_path.glob("panda_spheres_*.npz"))) == 1
    b = S.fit_spheres(sm.kinematics, fit)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def _box_overshoot(lo, hi, centers, radii, n=2000):
    """Largest distance [m] from the box [lo, hi] of a point of the spheres (sampled surfaces)."""
    u = np.random.default_rng(0).normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    X = centers[:, None, :] + radii[:, None, None] * u[None]
    return float(np.linalg.norm(np.maximum(np.maximum(lo - X, X - hi), 0.0), axis=2).max())


def test_shorter_surface_edges_bulge_less_beyond_a_finger_box():
    lo, hi = np.array([-0.012, 0.0, 0.01]), np.array([0.012, 0.03, 0.054])  # Panda finger collision box
    box = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    out = {}
    for edge in (0.01, 0.004):
        fit = S.SphereFitConfig(fine_protrusion=0.002, fine_edge_max=edge, padding=0.0)
        c, r = S._fit_link([box], fit, fit.fine_protrusion, fit.fine_edge_max)
        d = np.linalg.norm(box[:, None] - c[None], axis=2) - r
        assert np.all(d.min(axis=1) <= 1e-12)  # corners covered
        out[edge] = _box_overshoot(lo, hi, c, r)
    assert out[0.004] < 0.75 * out[0.01] and out[0.004] < 0.004
    assert "fine_edge_max" not in S.SphereFitConfig().key()  # cache names of older fits unchanged
    assert "fine_edge_max=0.004" in S.SphereFitConfig(fine_edge_max=0.004).key()
    with pytest.raises(CompassInputError, match="fine_edge_max"):
        S.SphereFitConfig(fine_edge_max=0.0)


def test_fine_model_bulges_less_on_the_fingers(sm, sm_fine):
    m, hulls = _local_hulls(sm)
    i = sm.link_names.index("hand/panda_rightfinger")
    (P,) = hulls[i]
    lo, hi = P.min(0), P.max(0)
    ov = [_box_overshoot(lo, hi, x.centers_local[x.body_index == i], x.radii[x.body_index == i]) for x in (sm, sm_fine)]
    assert ov[1] < 0.6 * ov[0]
