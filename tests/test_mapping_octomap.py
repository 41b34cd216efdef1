"""OctoMap interop: agreement with insertPointCloud on a frame, .bt round trip."""
import numpy as np
import octomap
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
from compass_manip.mapping.octomap_io import from_octree, read_bt, to_octree, write_bt

K = np.array([[108.0, 0.0, 79.5], [0.0, 108.0, 59.5], [0.0, 0.0, 1.0]])  # 160 x 120 px
BOX = dict(box_min=(-0.05, -0.45, 0.05), box_max=(0.75, 0.45, 0.85))
MAX_RANGE = 0.6


#: OctoMap's own update rule: the map's surface guard and sticky hits off (they depart from it
#: on purpose, tests/test_map_trust.py)
OCTOMAP_RULE = dict(surface_guard=False, sticky_hits=0)

def synthetic_frame():
    """A wavy surface 0.3-0.5 m away, a patch with no return and a patch of invalid pixels."""
    v, u = np.mgrid[0:120, 0:160]
    depth = (0.4 + 0.08 * np.sin(u / 9.0) * np.cos(v / 7.0) + 0.0005 * u).astype(np.float32)
    depth[:20, :30] = np.inf
    depth[100:, 140:] = np.nan
    depth[50:55, 60:70] = 0.0
    depth[60:70, 100:110] = 0.9  # beyond max_range: cleared, no hit
    T = look_at([0.013, 0.021, 0.497], [1.0, -0.2, 0.35])
    return depth, T


def octomap_points(depth, T, max_range):
    v, u = np.nonzero(np.isfinite(depth) & (depth > 0) | np.isposinf(depth))
    d = depth[v, u].astype(np.float64)
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones(len(u))], axis=1)
    inf = np.isinf(d)
    d[inf] = 2.0 * max_range / np.linalg.norm(rays[inf], axis=1)
    return (rays * d[:, None]) @ T[:3, :3].T + T[:3, 3]


def labels_of(tree, occ):
    lab = tree.getLabels(occ.voxel_centers().reshape(-1, 3))
    return np.where(lab == -1, 0, np.where(lab == 0, 1, 2)).reshape(occ.shape)


@pytest.mark.parametrize("grouping, min_known_agreement", [(0, 1.0), (1, 0.99), (2, 0.995)])
def test_labels_agree_with_octomap_insert_point_cloud(grouping, min_known_agreement):
    depth, T = synthetic_frame()
    occ = OccupancyMap(MapConfig(**BOX, ray_grouping=grouping, **OCTOMAP_RULE))
    tree = octomap.OcTree(occ.resolution)
    for k in range(2):  # a second, shifted view of the same surface
        Tk = T.copy()
        Tk[:3, 3] += [0.0, 0.03 * k, -0.02 * k]
        occ.integrate(depth, K, Tk, MAX_RANGE)
        tree.insertPointCloud(octomap_points(depth, Tk, MAX_RANGE), np.ascontiguousarray(Tk[:3, 3]),
                              maxrange=MAX_RANGE)
    ref = labels_of(tree, occ)
    known = (ref != 0) | (occ.state != 0)
    assert known.sum() > 20000
    assert np.mean(ref == occ.state) >= 0.999
    assert np.mean(ref[known] == occ.state[known]) >= min_known_agreement
    assert np.array_equal(ref == 2, occ.state == 2) or grouping > 0
    if grouping == 0:  # identical log-odds too
        idx = np.argwhere(known)[::97]
        lo = [tree.search(occ.voxel_to_world(i[None])[0]).getLogOdds() for i in idx]
        assert np.allclose(lo, occ.logodds[tuple(idx.T)], atol=1e-6)


def test_bt_round_trip_preserves_labels(tmp_path):
    depth, T = synthetic_frame()
    occ = OccupancyMap(MapConfig(**BOX))
    occ.integrate(depth, K, T, MAX_RANGE)
    assert labels_of(to_octree(occ), occ).tolist() == occ.state.tolist()
    path = tmp_path / "map.bt"
    write_bt(occ, path)
    back = read_bt(path, occ.config)
    assert np.array_equal(back.state, occ.state)
    assert set(np.unique(back.logodds).tolist()) <= {0.0, back._logs[2].item(), back._logs[3].item()}
    # a map on a smaller box keeps the labels of the overlap
    sub = read_bt(path, MapConfig(box_min=(0.2, -0.1, 0.3), box_max=(0.5, 0.2, 0.6)))
    i0 = sub.grid_key_min - occ.grid_key_min
    sl = tuple(slice(a, a + n) for a, n in zip(i0, sub.shape))
    assert np.array_equal(sub.state, occ.state[sl])
    tree = octomap.OcTree(0.02)
    with pytest.raises(CompassInputError, match="resolution"):
        from_octree(tree, occ.config)
    with pytest.raises(CompassInputError, match="does not exist"):
        read_bt(tmp_path / "missing.bt")


def test_camera_outside_the_box_agrees_with_octomap():
    # the grid covers only the far half of the view: rays enter it from outside
    depth, T = synthetic_frame()
    occ = OccupancyMap(MapConfig(box_min=(0.25, -0.45, 0.05), box_max=(0.75, 0.45, 0.85), ray_grouping=0,
                                 **OCTOMAP_RULE))
    occ.integrate(depth, K, T, MAX_RANGE)
    tree = octomap.OcTree(occ.resolution)
    tree.insertPointCloud(octomap_points(depth, T, MAX_RANGE), np.ascontiguousarray(T[:3, 3]), maxrange=MAX_RANGE)
    ref = labels_of(tree, occ)
    assert (occ.state != 0).sum() > 5000
    assert np.array_equal(ref, occ.state)
