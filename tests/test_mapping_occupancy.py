"""OccupancyMap: hand-computed ray updates, OctoMap's update rule, depth images, bad input."""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at, make_T, rot_z
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState

HIT = np.float32(math.log(0.7 / 0.3))
MISS = np.float32(math.log(0.4 / 0.6))
CLAMP_MAX = np.float32(math.log(0.97 / 0.03))
CLAMP_MIN = np.float32(math.log(0.12 / 0.88))
K = np.array([[50.0, 0.0, 15.5], [0.0, 50.0, 11.5], [0.0, 0.0, 1.0]])  # 32 x 24 px


def small_map(**kw) -> OccupancyMap:
    """OctoMap's rule (the surface guard and sticky hits, tests/test_map_trust.py, off)."""
    kw = {"surface_guard": False, "sticky_hits": 0, **kw}
    return OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.1, 0.1, 0.1), **kw))


def test_single_ray_updates_hand_computed_voxels():
    # In voxel units: origin (0.52, 0.47, 0.55), end (4.31, 2.12, 0.80); delta (3.79, 1.65, 0.25).
    # Crossings (segment parameter): x=1 at 0.1266, y=1 at 0.3212, x=2 at 0.3905, x=3 at
    # 0.6544, x=4 at 0.9182, y=2 at 0.9273 (end voxel); z stays in layer 0.
    occ = small_map()
    res = occ.resolution
    stats = occ.integrate_points(np.array([[4.31, 2.12, 0.80]]) * res, np.array([0.52, 0.47, 0.55]) * res)
    free = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (2, 1, 0), (3, 1, 0), (4, 1, 0)]
    assert sorted(map(tuple, np.argwhere(occ.state == VoxelState.FREE).tolist())) == free
    assert np.argwhere(occ.state == VoxelState.OCCUPIED).tolist() == [[4, 2, 0]]
    assert (stats.n_free_updates, stats.n_hit_updates) == (6, 1)
    for v in free:
        assert occ.logodds[v] == MISS
    assert occ.logodds[4, 2, 0] == HIT
    assert np.count_nonzero(occ.logodds) == 7


def test_log_odds_accumulate_and_clamp_like_octomap():
    occ = small_map()
    p, o = np.array([[0.045, 0.005, 0.005]]), np.array([0.005, 0.005, 0.005])
    occ.integrate_points(p, o)
    occ.integrate_points(p, o)
    assert occ.logodds[0, 0, 0] == np.float32(MISS + MISS)
    assert occ.logodds[4, 0, 0] == np.float32(HIT + HIT)
    for _ in range(10):
        occ.integrate_points(p, o)
    assert occ.logodds[4, 0, 0] == CLAMP_MAX
    assert occ.logodds[2, 0, 0] == CLAMP_MIN
    # a free voxel later hit once turns occupied only when the log-odds reach 0.5
    q = np.array([[0.025, 0.005, 0.005]])
    occ.integrate_points(q, o)
    assert occ.logodds[2, 0, 0] == np.float32(CLAMP_MIN + HIT)
    assert occ.state[2, 0, 0] == VoxelState.FREE


def test_each_voxel_updated_once_per_scan_and_hits_win():
    occ = small_map()
    o = np.array([0.005, 0.005, 0.005])
    # two rays along +x: the near point's voxel (3) is crossed by the far ray
    occ.integrate_points(np.array([[0.035, 0.005, 0.005], [0.075, 0.005, 0.005]]), o)
    assert occ.logodds[3, 0, 0] == HIT  # hit, not hit + miss
    assert occ.logodds[7, 0, 0] == HIT
    assert occ.logodds[1, 0, 0] == MISS  # crossed by two rays, updated once
    assert occ.logodds[5, 0, 0] == MISS


def test_wall_image_occupied_on_plane_free_in_front_unknown_behind():
    occ = OccupancyMap(MapConfig(box_min=(-0.1, -0.4, 0.1), box_max=(0.8, 0.4, 0.9), ray_grouping=0))
    T = look_at([0.0, 0.0, 0.5], [1.0, 0.0, 0.5])
    depth = np.full((24, 32), 0.505, np.float32)
    d = float(depth[0, 0])
    occ.integrate(depth, K, T, max_range=2.0)
    occupied = np.argwhere(occ.state == VoxelState.OCCUPIED)
    free = np.argwhere(occ.state == VoxelState.FREE)
    wall_i = int(np.floor(d / occ.resolution)) - occ.grid_key_min[0]
    assert np.all(occupied[:, 0] == wall_i)
    # the wall's voxels are exactly those of the back-projected pixels
    v, u = np.mgrid[0:24, 0:32]
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u, float)], -1).reshape(-1, 3)
    pts = (rays * d) @ T[:3, :3].T + T[:3, 3]
    expect = {tuple(x) for x in occ.world_to_voxel(pts).tolist()}
    assert {tuple(x) for x in occupied.tolist()} == expect
    assert free[:, 0].max() < wall_i
    assert np.all(occ.state[wall_i + 1:] == VoxelState.UNKNOWN)
    axis = occ.state_at(np.array([[x, 0.0, 0.5] for x in np.arange(0.005, 0.5, 0.01)]))
    assert np.all(axis == VoxelState.FREE)


def test_invalid_pixels_ignored_and_inf_clears_to_range():
    T = look_at([0.0, 0.0, 0.5], [1.0, 0.0, 0.5])
    depth = np.full((24, 32), np.nan, np.float32)
    depth[0, :4] = [0.0, -1.0, -np.inf, np.nan]
    occ = OccupancyMap(MapConfig(box_min=(-0.1, -0.4, 0.1), box_max=(0.8, 0.4, 0.9)))
    stats = occ.integrate(depth, K, T, max_range=1.0)
    assert stats.n_rays == 0 and occ.counts().unknown == occ.state.size
    # a valid point mixed with invalid pixels gives what the point alone gives
    depth[5, 7] = 0.3125
    a = OccupancyMap(occ.config)
    a.integrate(depth, K, T, max_range=1.0)
    b = OccupancyMap(occ.config)
    ray = np.array([(7 - K[0, 2]) / K[0, 0], (5 - K[1, 2]) / K[1, 1], 1.0])
    b.integrate_points((T[:3, :3] @ (0.3125 * ray) + T[:3, 3])[None], T[:3, 3], max_range=1.0)
    assert np.array_equal(a.state, b.state) and np.array_equal(a.logodds, b.logodds)
    # +inf (no return) and a point beyond range clear free space up to max_range, no hit
    depth = np.full((24, 32), np.nan, np.float32)
    depth[11, 15] = np.inf
    depth[12, 16] = 5.0
    c = OccupancyMap(occ.config)
    c.integrate(depth, K, T, max_range=0.4)
    assert c.counts().occupied == 0
    free_x = occ.voxel_to_world(np.argwhere(c.state == VoxelState.FREE))[:, 0]
    assert 0.37 < free_x.max() < 0.41


@pytest.mark.parametrize(
    "T_bad",
    [
        np.full((4, 4), np.nan),
        make_T(rot_z(0.3) * 1.01, [0.1, 0.0, 0.5]),
        np.eye(3),
        make_T(np.diag([1.0, 1.0, -1.0])),
    ],
)
def test_bad_pose_rejected_and_map_untouched(T_bad):
    occ = OccupancyMap(MapConfig(box_min=(-0.1, -0.4, 0.1), box_max=(0.8, 0.4, 0.9)))
    T = look_at([0.0, 0.0, 0.5], [1.0, 0.0, 0.5])
    depth = np.full((24, 32), 0.4, np.float32)
    occ.integrate(depth, K, T, max_range=1.0)
    lo, st = occ.logodds.copy(), occ.state.copy()
    with pytest.raises(CompassInputError, match="T_world_cam"):
        occ.integrate(depth, K, T_bad, max_range=1.0)
    assert np.array_equal(occ.logodds, lo) and np.array_equal(occ.state, st)


def test_bad_inputs_raise_clear_errors():
    occ = small_map()
    T = np.eye(4)
    with pytest.raises(CompassInputError, match="max_range"):
        occ.integrate(np.ones((4, 4), np.float32), K, T, max_range=-1.0)
    with pytest.raises(CompassInputError, match="depth"):
        occ.integrate(np.ones(4, np.float32), K, T, max_range=1.0)
    with pytest.raises(CompassInputError, match="K"):
        occ.integrate(np.ones((4, 4), np.float32), np.eye(2), T, max_range=1.0)
    with pytest.raises(CompassInputError, match="box_max"):
        MapConfig(box_min=(0, 0, 0), box_max=(0, 1, 1))
    with pytest.raises(CompassInputError, match="ray_grouping"):
        MapConfig(ray_grouping=5)


def test_queries_conversions_and_known_fraction():
    occ = OccupancyMap(MapConfig(box_min=(-0.023, 0.0, 0.0), box_max=(0.1, 0.05, 0.04)))
    assert occ.grid_key_min.tolist() == [-3, 0, 0] and occ.shape == (13, 5, 4)
    p = np.array([[-0.0299, 0.001, 0.039], [0.0999, 0.0499, 0.0]])
    idx = occ.world_to_voxel(p)
    assert idx.tolist() == [[0, 0, 3], [12, 4, 0]]
    assert np.allclose(occ.voxel_to_world(idx), [[-0.025, 0.005, 0.035], [0.095, 0.045, 0.005]])
    assert occ.in_grid(np.array([[0, 0, 0], [13, 0, 0], [-1, 2, 2]])).tolist() == [True, False, False]
    occ.set_box([0.0, 0.0, 0.0], [0.0199, 0.05, 0.04], VoxelState.FREE)  # x voxels 3, 4
    occ.set_voxels(np.array([[5, 0, 0]]), VoxelState.OCCUPIED)
    c = occ.counts()
    assert (c.free, c.occupied, c.unknown) == (40, 1, 13 * 20 - 41)
    assert occ.free_mask().sum() == 40 and occ.occupied_mask().sum() == 1
    assert occ.unknown_mask().sum() == c.unknown
    # box over x voxels 3..4 (keys 0, 1) is fully known; adding keys 2..3 halves it
    assert occ.known_fraction([0.001, 0.001, 0.001], [0.019, 0.049, 0.039]) == 1.0
    assert occ.known_fraction([0.001, 0.001, 0.001], [0.039, 0.049, 0.039]) == pytest.approx(41 / 80)
    # part of the box outside the grid counts as unknown
    assert occ.known_fraction([0.001, 0.001, 0.001], [0.019, 0.099, 0.039]) == pytest.approx(0.5)
    assert occ.state_at(np.array([[0.005, 0.005, 0.005], [5.0, 0.0, 0.0]])).tolist() == [1, 0]


@pytest.mark.parametrize("grouping", [0, 1])
def test_integration_is_deterministic(grouping):
    # 160 x 120 px: enough rays for the parallel tracing path
    K2 = np.array([[100.0, 0.0, 79.5], [0.0, 100.0, 59.5], [0.0, 0.0, 1.0]])
    T = look_at([0.0, 0.05, 0.5], [1.0, -0.1, 0.3])
    v, u = np.mgrid[0:120, 0:160]
    depth = (0.3 + 0.1 * np.sin(u / 9.0) * np.cos(v / 7.0)).astype(np.float32)
    depth[:10] = np.inf
    maps = []
    for _ in range(2):
        occ = OccupancyMap(MapConfig(box_min=(-0.1, -0.4, 0.1), box_max=(0.8, 0.4, 0.9), ray_grouping=grouping))
        occ.integrate(depth, K2, T, 1.0)
        occ.integrate(depth[::-1], K2, T, 1.0)
        maps.append(occ)
    assert np.array_equal(maps[0].logodds, maps[1].logodds)
    assert np.array_equal(maps[0].state, maps[1].state)
    assert maps[0].counts().free > 1000
