"""The video's map panel on a constructed map: per-column unknown fraction, occupancy and
frontiers of the slab; the top view's orientation (world +x up, +y left) and colours."""
import numpy as np
import pytest

from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.viz.panels import TopView, TopViewRegion, caption, fit, map_columns, tile

RES = 0.01


@pytest.fixture(scope="module")
def occ():
    """20 x 20 x 10 voxels over x, y in 0..0.2 m, z in 0..0.1 m: x < 0.1 m free, the rest
    unknown but for one occupied voxel at column (15, 5), height index 2."""
    m = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.2, 0.2, 0.1), resolution=RES))
    free = np.argwhere(np.ones((10, 20, 10), bool))
    m.set_voxels(free, VoxelState.FREE)
    m.set_voxels(np.array([[15, 5, 2]]), VoxelState.OCCUPIED)
    return m


REGION = TopViewRegion(0.0, 0.2 - 1e-6, 0.0, 0.2 - 1e-6, 0.0, 0.1 - 1e-6)


def test_map_columns_count_the_slab(occ):
    unknown, occupied, frontier, origin = map_columns(occ, REGION, 0.0, 0.1 - 1e-6)
    assert unknown.shape == occupied.shape == frontier.shape == (20, 20)
    assert np.allclose(origin, [0.005, 0.005])  # the centre of voxel column [0, 0]
    assert np.all(unknown[:10] == 0.0)
    expected = np.ones((10, 20))
    expected[5, 5] = 0.9  # one of the 10 voxels of column (15, 5) is occupied
    assert np.allclose(unknown[10:], expected)
    assert occupied.sum() == 1 and occupied[15, 5]
    assert np.all(frontier[9]) and frontier.sum() == 20  # free voxels next to the unknown half
    # a slab above the occupied voxel does not see it
    _, occupied_high, _, _ = map_columns(occ, REGION, 0.05, 0.1 - 1e-6)
    assert not occupied_high.any()


def test_top_view_puts_x_up_and_y_left():
    view = TopView(TopViewRegion(0.0, 1.0, -0.5, 0.5, 0.0, 1.0), 400, 300)
    u_far, v_far = view.px([1.0, 0.0])
    u_near, v_near = view.px([0.0, 0.0])
    u_left, _ = view.px([0.5, 0.5])
    u_right, _ = view.px([0.5, -0.5])
    assert v_far < v_near and u_far == pytest.approx(u_near)
    assert u_left < u_right and u_right - u_left == pytest.approx(view.scale * 1.0)
    assert view.scale == pytest.approx(300.0)  # 1 m of x fills the 300 px height
    corners = view.px(np.array([[0.0, -0.5], [1.0, 0.5]]))
    assert np.all(corners >= -1e-9) and np.all(corners[:, 0] <= 400) and np.all(corners[:, 1] <= 300)


def test_top_view_colours(occ):
    view = TopView(REGION, 400, 300)
    img = view.draw(occ, np.zeros((0, 3)), slab=(0.0, 0.1 - 1e-6))
    assert img.shape == (300, 400, 3) and img.dtype == np.uint8

    def colour(i, j):
        u, v = view.px([(i + 0.5) * RES, (j + 0.5) * RES])
        return img[int(v), int(u)].astype(int)

    assert np.array_equal(colour(15, 5), [40, 60, 140])      # occupied
    assert np.array_equal(colour(9, 12), [255, 150, 30])     # frontier
    assert np.array_equal(colour(3, 12), [255, 255, 255])    # free
    assert np.array_equal(colour(17, 15), [105, 105, 105])   # unknown: 255 - 150
    assert np.array_equal(colour(15, 6), [105, 105, 105])


def test_fit_and_tile_keep_sizes():
    rgb = np.full((240, 320, 3), 200, np.uint8)
    panel = fit(rgb, 400, 300)
    assert panel.shape == (300, 400, 3) and panel[150, 200].tolist() == [200, 200, 200]
    tall = fit(np.zeros((100, 50, 3), np.uint8) + 255, 400, 300)
    assert tall[150, 10].tolist() != [255, 255, 255] and tall[150, 200].tolist() == [255, 255, 255]
    frame = tile([panel, panel, panel], caption("t = 1.0 s", 1200, 36))
    assert frame.shape == (336, 1200, 3)
