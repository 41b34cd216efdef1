"""Normals of an image window equal the whole image's normals on that window."""
import numpy as np

from compass_manip.perception.target import backproject_image, region_normals, surface_normals


def _points(rng):
    H, W = 40, 50
    v, u = np.mgrid[0:H, 0:W]
    depth = 0.6 + 0.001 * u + 0.01 * np.sin(v / 5.0)
    depth[10:20, 30:38] -= 0.2  # a box in front: depth jumps at its rim
    depth[rng.random((H, W)) < 0.05] = np.nan  # missing measurements
    depth[0, :] = np.inf
    K = np.array([[300.0, 0, W / 2], [0, 300.0, H / 2], [0, 0, 1]])
    T = np.eye(4)
    T[:3, 3] = [0.1, -0.2, 0.5]
    return backproject_image(depth, K, T)[0]


def test_window_normals_equal_whole_image_normals():
    rng = np.random.default_rng(0)
    pts = _points(rng)
    n_all, ok_all = surface_normals(pts)
    H, W, _ = pts.shape
    windows = [(slice(0, 5), slice(0, 7)), (slice(35, 40), slice(44, 50)), (slice(9, 21), slice(29, 39)),
               (slice(0, H), slice(0, W)), (slice(20, 21), slice(3, 4)), (slice(1, 3), slice(48, 50))]
    for _ in range(20):
        r0, c0 = rng.integers(0, H - 1), rng.integers(0, W - 1)
        windows.append((slice(r0, rng.integers(r0 + 1, H + 1)), slice(c0, rng.integers(c0 + 1, W + 1))))
    for sl in windows:
        n, ok = region_normals(pts, sl)
        assert n.shape == n_all[sl].shape and ok.shape == ok_all[sl].shape
        assert np.array_equal(ok, ok_all[sl])
        assert np.array_equal(n, n_all[sl], equal_nan=True)
    assert ok_all.sum() > 500  # the case has valid normals to compare


def test_backprojection_equals_the_broadcast_formula_bit_for_bit():
    rng = np.random.default_rng(7)
    H, W = 24, 32
    depth = rng.uniform(0.1, 2.0, (H, W)).astype(np.float32)
    depth[rng.random((H, W)) < 0.1] = np.inf
    depth[0, :4] = 0.0
    K = np.array([[40.0, 0, 15.5], [0, 41.0, 11.5], [0, 0, 1]])
    a = rng.normal(size=3)
    c, s = np.cos(0.7), np.sin(0.7)
    T = np.eye(4)
    T[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]])
    T[:3, 3] = a
    pw, valid = backproject_image(depth, K, T)
    z = depth.astype(np.float64)
    ok = np.isfinite(z) & (z > 0)
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    zz = np.where(ok, z, np.nan)
    pc = np.stack([(u - K[0, 2]) / K[0, 0] * zz, (v - K[1, 2]) / K[1, 1] * zz, zz], axis=-1)
    assert np.array_equal(valid, ok) and np.array_equal(pw, pc @ T[:3, :3].T + T[:3, 3], equal_nan=True)
    assert np.isnan(pw[~ok]).all() and np.isfinite(pw[ok]).all()


def _surface_normals_reference(points, step=2, max_jump=0.01):
    """`surface_normals` as it was written before (norms and division broadcast over the last axis)."""
    H, W, _ = points.shape
    n = np.full_like(points, np.nan)
    ok = np.zeros((H, W), bool)
    s = step
    c = points[s:-s, s:-s]
    du = points[s:-s, 2 * s:] - points[s:-s, :-2 * s]
    dv = points[2 * s:, s:-s] - points[:-2 * s, s:-s]
    cr = np.cross(du, dv)
    norm = np.linalg.norm(cr, axis=-1)
    with np.errstate(invalid="ignore"):
        jump = np.maximum(np.linalg.norm(du, axis=-1), np.linalg.norm(dv, axis=-1))
        good = np.isfinite(norm) & (norm > 1e-12) & (jump < 2 * max_jump) & np.all(np.isfinite(c), axis=-1)
    inner = np.full_like(cr, np.nan)
    inner[good] = cr[good] / norm[good, None]
    n[s:-s, s:-s] = inner
    ok[s:-s, s:-s] = good
    return n, ok


def test_surface_normals_equal_the_broadcast_formulation_bit_for_bit():
    rng = np.random.default_rng(11)
    pts = _points(rng)
    pts = pts + rng.normal(0.0, 0.002, pts.shape)  # noisy: normals in every direction, some jumps
    for step, jump in ((2, 0.01), (1, 0.005), (3, 0.05)):
        n, ok = surface_normals(pts, step, jump)
        n0, ok0 = _surface_normals_reference(pts, step, jump)
        assert np.array_equal(ok, ok0) and np.array_equal(n, n0, equal_nan=True)
        assert 0 < ok.sum() < ok.size
