"""The obstacle halo kept between checker rebuilds equals the whole dilation every time."""
import numpy as np

from compass_manip.exploration.halo import ObstacleHalo, manhattan_dilate, mark_l1_balls, occupied_change


def test_l1_balls_equal_the_dilation_of_their_centres_also_at_the_grid_border():
    mask = np.zeros((9, 8, 7), bool)
    pts = np.array([[0, 0, 0], [4, 3, 3], [8, 7, 6], [8, 0, 3]])
    ref = np.zeros_like(mask)
    ref[tuple(pts.T)] = True
    mark_l1_balls(mask, pts, 3)
    assert np.array_equal(mask, manhattan_dilate(ref, 3))


def test_occupied_change_reports_removals_and_the_added_voxels():
    a = np.zeros((4, 4, 4), bool)
    a[1, 1, 1] = True
    b = a.copy()
    b[2, 3, 0] = b[0, 0, 3] = True
    removed, added = occupied_change(a, b)
    assert not removed and sorted(map(tuple, added)) == [(0, 0, 3), (2, 3, 0)]
    removed, _ = occupied_change(b, a)
    assert removed


def test_kept_halo_equals_manhattan_dilate_through_additions_and_removals():
    rng = np.random.default_rng(11)
    shape = (30, 25, 20)
    occ = rng.random(shape) < 0.002
    halo = ObstacleHalo(4)
    for step in range(12):
        if step % 4 == 3:  # a voxel stops being occupied: the whole dilation again
            occ[tuple(np.argwhere(occ)[0])] = False
        else:
            occ |= rng.random(shape) < 0.0005
        got = halo.near(occ)
        assert np.array_equal(got, manhattan_dilate(occ, 4)), step
    assert halo.full_updates == 1 + 3  # the first call and the three removals
