"""Self-filtering: points inside the robot's body spheres are dropped before integration."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.mapping.selffilter import SphereBodyFilter
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model

K = np.array([[50.0, 0.0, 15.5], [0.0, 50.0, 11.5], [0.0, 0.0, 1.0]])  # 32 x 24 px


def test_sphere_filter_matches_definition():
    rng = np.random.default_rng(0)
    c = rng.uniform(-0.5, 0.5, (7, 3))
    r = rng.uniform(0.02, 0.2, 7)
    p = rng.uniform(-0.7, 0.7, (5000, 3))
    expect = (np.linalg.norm(p[:, None] - c[None], axis=-1) <= r + 0.01).any(axis=1)
    mask = SphereBodyFilter(c, r, margin=0.01)(p)
    assert mask.dtype == bool and np.array_equal(mask, expect) and 0 < mask.sum() < len(p)
    assert not SphereBodyFilter(np.zeros((0, 3)), np.zeros(0))(p).any()
    with pytest.raises(CompassInputError, match="radii"):
        SphereBodyFilter(c, r[:3])


def test_integrate_drops_pixels_on_the_body():
    # OctoMap's rule: integrate_points has no depth image, so no surface guard to compare with
    cfg = MapConfig(box_min=(-0.1, -0.4, 0.1), box_max=(0.8, 0.4, 0.9), ray_grouping=0, surface_guard=False)
    T = look_at([0.0, 0.0, 0.5], [1.0, 0.0, 0.5])
    depth = np.full((24, 32), 0.4, np.float32)
    depth[:, :10] = 0.15  # a "gripper finger" in the left third of the image
    v, u = np.mgrid[0:24, 0:32]
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u, float)], -1)
    pts = ((rays * depth[..., None].astype(np.float64)) @ T[:3, :3].T + T[:3, 3]).reshape(-1, 3)
    body = SphereBodyFilter(np.array([[0.15, 0.06, 0.5]]), np.array([0.06]))
    on_body = body(pts)
    assert on_body.sum() == 240  # exactly the finger pixels
    filtered = OccupancyMap(cfg)
    stats = filtered.integrate(depth, K, T, 1.0, point_filter=body)
    assert stats.n_filtered == 240 and stats.n_rays == 24 * 32 - 240
    expect = OccupancyMap(cfg)
    expect.integrate_points(pts[~on_body], T[:3, 3], 1.0)
    assert np.array_equal(filtered.state, expect.state)
    assert not (filtered.state_at(pts[on_body]) == VoxelState.OCCUPIED).any()
    with pytest.raises(CompassInputError, match="point_filter"):
        OccupancyMap(cfg).integrate(depth, K, T, 1.0, point_filter=lambda p: np.ones(3, bool))


def _cell_lists_numpy(a, b, dims):
    """The cell lists built with array operations (the reference for the numba build)."""
    k = int((b - a).max()) + 1
    off = np.stack(np.meshgrid(*[np.arange(k)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    cand = a[:, None, :] + off[None]
    ok = np.all(cand <= b[:, None, :], axis=2)
    sph = np.broadcast_to(np.arange(len(a))[:, None], ok.shape)[ok]
    g = cand[ok]
    cells = (g[:, 0] * dims[1] + g[:, 1]) * dims[2] + g[:, 2]
    order = np.argsort(cells, kind="stable")
    return np.searchsorted(cells[order], np.arange(int(np.prod(dims)) + 1)), sph[order]


def test_cell_lists_equal_the_array_construction():
    rng = np.random.default_rng(4)
    for n in (1, 5, 300):
        f = SphereBodyFilter(rng.uniform(-0.5, 0.5, (n, 3)), rng.uniform(0.0, 0.12, n), margin=0.01)
        a = np.clip(np.floor((f.centers_world - np.sqrt(f._r2)[:, None] - f._lo) / f._cell).astype(np.int64), 0,
                    f._dims - 1)
        b = np.clip(np.floor((f.centers_world + np.sqrt(f._r2)[:, None] - f._lo) / f._cell).astype(np.int64), 0,
                    f._dims - 1)
        start, items = _cell_lists_numpy(a, b, f._dims)
        assert np.array_equal(f._start, start) and np.array_equal(f._items, items)


def test_one_configuration_sphere_centres_equal_the_batch_kernel():
    model = panda_sphere_model()
    rng = np.random.default_rng(2)
    q = Q_HOME + rng.normal(0.0, 0.05, 7)
    one = model.sphere_centers(q[None])
    two = model.sphere_centers(np.stack([q, q]))  # the parallel kernel
    assert np.array_equal(one[0], two[0]) and np.array_equal(one[0], two[1])


def test_invalidate_inside_drops_the_filters_points_of_the_given_kind_only():
    rng = np.random.default_rng(3)
    c, r = rng.uniform(-0.5, 0.5, (9, 3)), rng.uniform(0.02, 0.2, 9)
    body = SphereBodyFilter(c, r, margin=0.01)
    p = rng.uniform(-0.7, 0.7, (6000, 3))
    kind = rng.integers(0, 3, len(p)).astype(np.uint8)
    expect = kind.copy()
    m = np.flatnonzero(kind == 1)
    expect[m[body(p[m])]] = 2
    got = kind.copy()
    n = body.invalidate_inside(p, got, 1, 2)
    assert np.array_equal(got, expect) and n == int(body(p[m]).sum()) > 0


def test_integrate_with_the_compiled_self_filter_equals_the_callable_path():
    """`OccupancyMap.integrate` uses `invalidate_inside` when the filter has it: the same map
    and statistics as through the plain callable (a wrapper without the method)."""
    spheres = panda_sphere_model()
    centers = spheres.sphere_centers(np.asarray(Q_HOME, float)[None])[0]
    body = SphereBodyFilter(centers, spheres.radii, margin=0.01)
    cfg = MapConfig(box_min=(-0.2, -0.6, 0.0), box_max=(1.0, 0.6, 1.2))
    T = look_at(centers.mean(axis=0) + [0.6, 0.0, 0.2], centers.mean(axis=0))
    rng = np.random.default_rng(5)
    depth = rng.uniform(0.3, 1.2, (24, 32)).astype(np.float32)
    depth[0, :4] = np.inf
    fast, slow = OccupancyMap(cfg), OccupancyMap(cfg)
    s_fast = fast.integrate(depth, K, T, 1.0, point_filter=body)
    s_slow = slow.integrate(depth, K, T, 1.0, point_filter=lambda p: body(p))
    assert s_fast == s_slow and s_fast.n_filtered > 0
    assert np.array_equal(fast.logodds, slow.logodds) and np.array_equal(fast.state, slow.state)


def test_inside_where_equals_the_filter_on_the_valid_points_only():
    rng = np.random.default_rng(4)
    c, r = rng.uniform(-0.5, 0.5, (9, 3)), rng.uniform(0.02, 0.2, 9)
    body = SphereBodyFilter(c, r, margin=0.01)
    p = rng.uniform(-0.7, 0.7, (5000, 3))
    valid = rng.random(len(p)) < 0.7
    p[~valid] = np.nan  # never read
    expect = np.zeros(len(p), bool)
    expect[valid] = body(p[valid])
    assert np.array_equal(body.inside_where(p, valid), expect) and expect.sum() > 0
    with pytest.raises(CompassInputError, match="valid"):
        body.inside_where(p, valid[:10])


def test_the_bounding_box_pretest_keeps_points_on_the_outermost_spheres_surfaces():
    # points just inside / outside the extreme spheres along each axis: the box bounds the
    # spheres (with the margin) and every kernel gives the definition's answer there
    rng = np.random.default_rng(4)
    c = rng.uniform(-0.3, 0.3, (40, 3))
    r = rng.uniform(0.01, 0.1, 40)
    f = SphereBodyFilter(c, r, margin=0.01)
    pts = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            s = int(np.argmax(sign * (c[:, axis] + sign * r)))  # the sphere reaching farthest that way
            for eps in (-1e-9, 1e-9, -1e-4, 1e-4):
                p = c[s].copy()
                p[axis] += sign * (r[s] + 0.01 + eps)
                pts.append(p)
    p = np.array(pts + list(rng.uniform(-0.5, 0.5, (3000, 3))))
    expect = ((p[:, None] - c[None]) ** 2).sum(-1) <= ((r + 0.01) ** 2)[None]
    expect = expect.any(axis=1)
    assert expect[:24].sum() == 12  # half of the surface points are inside
    assert np.array_equal(f(p), expect)
    assert np.array_equal(f.inside_where(p, np.ones(len(p), bool)), expect)
    kind = np.ones(len(p), np.uint8)
    assert f.invalidate_inside(p, kind, 1, 0) == expect.sum() and np.array_equal(kind == 0, expect)
