"""`perception.cut.cut_kinds`: what cuts a region off, on hand-built depth images."""
import numpy as np

from compass_manip.perception.cut import cut_kinds
from compass_manip.perception.target import backproject_image

H, W = 120, 160
K = np.array([[300.0, 0, (W - 1) / 2], [0, 300.0, (H - 1) / 2], [0, 0, 1]])
SL = (slice(40, 80), slice(60, 100))  # the region's window: 40 x 40 px in the middle


def _kinds(depth, region=None):
    pts, _ = backproject_image(depth, K, np.eye(4))
    region = np.ones((40, 40), bool) if region is None else region
    return cut_kinds(depth, pts, region, SL)


def test_a_patch_of_a_larger_wall_is_continued_all_round():
    c = _kinds(np.full((H, W), 1.0))
    assert c.continued > 0.95 and c.occluded == 0.0 and c.n > 100
    assert abs(c.occluded + c.open + c.continued - 1.0) < 1e-12


def test_an_object_in_front_of_a_far_background_is_open_all_round():
    depth = np.full((H, W), 1.5)
    depth[SL] = 0.6
    c = _kinds(depth)
    assert c.open == 1.0 and c.continued == 0.0 and c.occluded == 0.0


def test_missing_depth_outside_counts_as_open():
    depth = np.full((H, W), np.inf)
    depth[SL] = 0.6
    assert _kinds(depth).open == 1.0


def test_an_occluder_in_front_of_one_side_is_seen_as_occluded():
    depth = np.full((H, W), 1.5)
    depth[SL] = 0.8
    depth[:, :60] = 0.5  # a board nearer the camera along the region's left edge
    c = _kinds(depth)
    assert 0.15 < c.occluded < 0.35, c  # about one side of four
    assert c.continued == 0.0


def test_a_surface_turning_away_at_the_same_depth_is_open_not_continued():
    """Below the region the surface bends away (a floor under a standing face): within the
    depth jump 3 px out, but its normal turns and it leaves the region's plane."""
    depth = np.full((H, W), 1.0)
    v = np.arange(H, dtype=float)[:, None]
    depth = np.where(v >= 80, 1.0 + 0.004 * (v - 79) * 30, depth) * np.ones((1, W))
    region = np.ones((40, 40), bool)
    c = _kinds(depth, region)
    below = _kinds(np.full((H, W), 1.0), region)
    assert c.continued < below.continued - 0.15, (c, below)
    assert c.occluded == 0.0
