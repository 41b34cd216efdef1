"""The target model's fused region grows upwards over occupied layers of the map (a top part
the detection missed, e.g. a bottle's neck), stops at the first layer without one (a board
above a gap stays out) and never above the lowest point plus the query's height."""
import numpy as np

from compass_manip.grasp.target import TargetConfig, build_target_model, grow_top
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
