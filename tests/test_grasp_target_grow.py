"""The target model's fused region grows upwards over occupied layers of the map (a top part
the detection missed, e.g. a bottle's neck), stops at the first layer without one (a board
above a gap stays out) and never above the lowest point plus the query's height."""
import numpy as np

from compass_manip.grasp.target import TargetConfig, build_target_model, grow_top, round_axis
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.task import TargetQuery


def _map_with(boxes):
    occ = OccupancyMap(MapConfig(box_min=(0.0, -0.2, 0.0), box_max=(0.4, 0.2, 0.6), resolution=0.01))
    occ.state[...] = VoxelState.FREE
    for lo, hi in boxes:
        a = occ.world_to_voxel(np.asarray(lo, float)[None])[0]
        b = occ.world_to_voxel(np.asarray(hi, float)[None])[0]
        occ.state[a[0]:b[0] + 1, a[1]:b[1] + 1, a[2]:b[2] + 1] = VoxelState.OCCUPIED
    return occ


def _body_points():
    """The seen half of a body of radius 3 cm around (0.20, 0), z 0.10..0.20 m (facing -x)."""
    a, z = np.meshgrid(np.linspace(0.5 * np.pi, 1.5 * np.pi, 19), np.linspace(0.10, 0.20, 21))
    return np.c_[0.20 + 0.03 * np.cos(a.ravel()), 0.03 * np.sin(a.ravel()), z.ravel()]


def test_the_region_grows_over_a_neck_and_stops_below_a_board_above_a_gap():
    neck = ((0.19, -0.01, 0.20), (0.21, 0.01, 0.285))  # a neck 2 cm wide up to 0.285 m
    board = ((0.0, -0.2, 0.30), (0.4, 0.2, 0.32))  # a board 1.5 cm above the neck, free between
    occ = _map_with([neck, board])
    pts = _body_points()
    lo, hi = pts.min(0) - 0.01, pts.max(0) + 0.01
    top = grow_top(occ, lo, hi, z_max=0.10 + 0.5)
    assert 0.28 <= top < 0.30  # the neck's layers, not the board's
    assert grow_top(occ, lo, hi, z_max=0.25) <= 0.25  # never above the cap
    q = TargetQuery("bottle", "green", (0.06, 0.06, 0.19))
    m = build_target_model(pts, np.array([-0.3, 0.0, 0.3]), q, occ)
    assert 0.27 < m.points[:, 2].max() < 0.30 and not np.any(m.points[:, 2] >= 0.30)
    off = build_target_model(pts, np.array([-0.3, 0.0, 0.3]), q, occ, TargetConfig(grow_up=False))
    assert off.points[:, 2].max() < 0.22  # without growing, the neck is not the target's


def test_a_board_touching_the_top_is_capped_at_the_querys_height():
    board = ((0.0, -0.2, 0.20), (0.4, 0.2, 0.40))  # occupied all the way up from the body's top
    occ = _map_with([board])
    pts = _body_points()
    q = TargetQuery("box", "red", (0.06, 0.06, 0.12))
    m = build_target_model(pts, np.array([-0.3, 0.0, 0.3]), q, occ)
    assert m.points[:, 2].max() <= 0.10 + 0.12 + 0.01 + 1e-9


def test_an_unknown_band_is_passed_over_but_a_free_layer_ends_the_growth():
    neck = ((0.19, -0.01, 0.24), (0.21, 0.01, 0.285))  # the neck's voxels seen above a hidden band
    occ = _map_with([neck])
    a = occ.world_to_voxel(np.array([[0.0, -0.2, 0.205]]))[0]
    b = occ.world_to_voxel(np.array([[0.4, 0.2, 0.235]]))[0]
    occ.state[a[0]:b[0] + 1, a[1]:b[1] + 1, a[2]:b[2] + 1] = VoxelState.UNKNOWN  # the shoulder, never seen
    pts = _body_points()
    lo, hi = pts.min(0) - 0.01, pts.max(0) + 0.01
    assert 0.28 <= grow_top(occ, lo, hi, z_max=0.5, shrink=0.01) < 0.30  # over the band to the neck's top
    k = occ.world_to_voxel(np.array([[0.2, 0.0, 0.225]]))[0][2]
    front = occ.world_to_voxel(np.array([[0.175, 0.0, 0.225]]))[0][0]
    occ.state[a[0]:front + 1, a[1]:b[1] + 1, k] = VoxelState.FREE  # in front of the neck, seen free
    assert 0.28 <= grow_top(occ, lo, hi, z_max=0.5, shrink=0.01) < 0.30  # the neck's column is still unknown
    occ.state[a[0]:b[0] + 1, a[1]:b[1] + 1, k] = VoxelState.FREE  # the whole layer of the band seen free
    assert grow_top(occ, lo, hi, z_max=0.5, shrink=0.01) < 0.225  # the neck is something else


def test_the_layer_holding_the_box_top_counts_by_its_centre():
    """hi[2] inside a layer whose centre lies above it: that layer's occupied voxels are
    not yet in the region (`map_points_in_region` takes centres), so growth must test it."""
    cap = ((0.19, -0.01, 0.20), (0.21, 0.01, 0.219))  # the top 2 cm of the body, seen only in the map
    occ = OccupancyMap(MapConfig(box_min=(0.0, -0.2, 0.0), box_max=(0.4, 0.2, 0.6), resolution=0.02))
    occ.state[...] = VoxelState.FREE
    a, b = occ.world_to_voxel(np.asarray(cap[0])[None])[0], occ.world_to_voxel(np.asarray(cap[1])[None])[0]
    occ.state[a[0]:b[0] + 1, a[1]:b[1] + 1, a[2]:b[2] + 1] = VoxelState.OCCUPIED  # layer 0.20..0.22, centre 0.21
    pts = _body_points()
    pts = pts[pts[:, 2] <= 0.195]
    lo, hi = pts.min(0) - 0.01, pts.max(0) + 0.01  # hi[2] = 0.205: inside that layer, below its centre
    assert grow_top(occ, lo, hi, z_max=0.5) >= 0.22 - 1e-9


def _arc(cx, radius, z0, z1):
    """The seen (-x) half of a vertical cylinder around (cx, 0) between z0 and z1 [m]."""
    a, z = np.meshgrid(np.linspace(0.5 * np.pi, 1.5 * np.pi, 25), np.arange(z0, z1, 0.004))
    return np.c_[cx + radius * np.cos(a.ravel()), radius * np.sin(a.ravel()), z.ravel()]


def test_a_bottle_seen_only_by_its_neck_is_mirrored_through_the_necks_axis():
    neck = _arc(0.20, 0.013, 0.30, 0.38)  # the body (3 cm radius, same axis) hidden below
    q = TargetQuery("bottle", "green", (0.06, 0.06, 0.22))
    cam = np.array([-0.3, 0.0, 0.5])
    m = build_target_model(neck, cam, q)
    assert m.points[:, 0].max() < 0.20 + 0.013 + 0.005  # the far side of the neck, not 6 cm deep
    box = build_target_model(neck, cam, TargetQuery("box", "green", (0.06, 0.06, 0.22)))
    assert box.points[:, 0].max() > 0.20 + 0.03  # a box keeps the query's depth
    off = build_target_model(neck, cam, q, config=TargetConfig(round_axis=False))
    assert off.points[:, 0].max() > 0.20 + 0.03


def test_a_bottle_seen_whole_keeps_the_bodys_axis_for_its_neck():
    pts = np.vstack([_arc(0.20, 0.03, 0.10, 0.25), _arc(0.20, 0.013, 0.25, 0.33)])
    m = build_target_model(pts, np.array([-0.3, 0.0, 0.4]), TargetQuery("bottle", "red", (0.06, 0.06, 0.23)))
    body = m.points[~m.observed & (m.points[:, 2] < 0.24)]
    neck = m.points[~m.observed & (m.points[:, 2] > 0.26)]
    assert abs(body[:, 0].max() - 0.23) < 0.006 and abs(neck[:, 0].max() - 0.213) < 0.006


def _disc_behind(cx, radius, z, front_cut):
    """The top face (z [m]) of a vertical cylinder around (cx, 0), only its part behind
    x = front_cut [m] (a box in front hides the rest, as at the severe levels)."""
    g = np.arange(-radius, radius + 1e-9, 0.003)
    x, y = np.meshgrid(cx + g, g)
    keep = (np.hypot(x - cx, y) <= radius) & (x >= front_cut)
    return np.c_[x[keep], y[keep], np.full(int(keep.sum()), z)]


def test_a_body_top_seen_behind_a_box_does_not_move_the_axis_back():
    """The body's top face, its front hidden, is as wide as the body but starts 2 cm behind
    its front: the axis comes from the neck's slices (the foremost estimate), within 2 mm."""
    pts = np.vstack([_disc_behind(0.20, 0.03, 0.30, 0.19), _arc(0.20, 0.012, 0.30, 0.38)])
    q = TargetQuery("bottle", "green", (0.06, 0.06, 0.22))
    view = np.array([1.0, 0.0, 0.0])
    depth, across, widest = round_axis(pts, view, 0.01)
    assert abs(depth - 0.20) < 0.002 and abs(across) < 0.002 and widest > 0.05
    m = build_target_model(pts, np.array([-0.3, 0.0, 0.5]), q)
    assert m.points[:, 0].max() < 0.20 + 0.03 + 0.006  # mirrored through the true axis

