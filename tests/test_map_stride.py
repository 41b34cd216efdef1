"""Map integration on every 2nd pixel (`MapConfig.pixel_stride=2`, an option of the
exploration map, off by default): the same voxels as every pixel, up to the view's edge.

The wrist camera (320 x 240 px, 58 deg vertical) sees a wall facing it; the exploration
map's settings (2 cm voxels, one traced ray per end cell, OctoMap's rule). Stride 2 uses the
pixels at odd u and v, so the strip between the first pixel row / column and the second is
seen only with every pixel: a voxel labelled differently must reach into that strip (or
lie partly behind the camera).
"""
import math

import numpy as np
import pytest

from compass_manip.exploration.world_model import default_map_config
from compass_manip.geometry import look_at
from compass_manip.mapping import raycast
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import CameraConfig

CAM = CameraConfig()
K = CAM.K
EYE = np.array([0.013, 0.007, 0.3])  # [m], off the voxel grid's planes
T_WORLD_CAM = look_at(EYE, EYE + np.array([1.0, 0.0, 0.0]))


def wall_depth(dist: float, tilt: float = 0.0) -> np.ndarray:
    """(H, W) z-depth [m] of a plane at distance dist [m] along the optical axis, tilted so
    that z = dist / (1 - tilt * x_c) with x_c = (u - cx) / fx."""
    u = np.arange(CAM.width)[None, :].repeat(CAM.height, 0)
    xc = (u - K[0, 2]) / K[0, 0]
    return (dist / (1.0 - tilt * xc)).astype(np.float32)


def scan(stride: int, depth: np.ndarray) -> np.ndarray:
    occ = OccupancyMap(MapConfig(resolution=0.02, surface_guard=False, sticky_hits=0, pixel_stride=stride))
    occ.integrate(depth, K, T_WORLD_CAM, 1.5)
    return occ


def reaches_view_edge(occ: OccupancyMap, idx: np.ndarray) -> np.ndarray:
    """(M,) bool: the voxels idx (M, 3) have a corner behind the camera or projecting
    outside the rectangle of pixel centres u in [1, W - 1], v in [1, H - 1]."""
    res = occ.resolution
    corners = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], float)
    lo = occ.grid_min + idx * res  # (M, 3)
    pts = lo[:, None, :] + res * corners[None]  # (M, 8, 3) world
    T_cam_world = np.linalg.inv(T_WORLD_CAM)
    pc = pts @ T_cam_world[:3, :3].T + T_cam_world[:3, 3]
    behind = np.any(pc[..., 2] <= 0.0, axis=1)
    z = np.where(pc[..., 2] > 0.0, pc[..., 2], 1.0)
    u = K[0, 0] * pc[..., 0] / z + K[0, 2]
    v = K[1, 1] * pc[..., 1] / z + K[1, 2]
    out = (u < 1.0) | (u > CAM.width - 1) | (v < 1.0) | (v > CAM.height - 1)
    return behind | np.any(out, axis=1)


def test_exploration_map_integrates_every_pixel_and_stride_two_is_one_setting_away():
    # stride 2 changed which targets were found on the seed-808 trials (docs/compass_loop.md,
    # "Real time, sixth round"), so the exploration map keeps every pixel
    config = default_map_config()
    assert config.pixel_stride == 1 and config.resolution == 0.02
    assert MapConfig(**{**config.__dict__, "pixel_stride": 2}).pixel_stride == 2


def test_stride_two_uses_the_full_scans_points_at_odd_pixels():
    depth = wall_depth(0.5, tilt=0.3)
    depth[5, 7] = np.inf  # a no-return pixel at odd (u, v) = (7, 5)
    depth[9, 3] = np.nan
    args = (K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.ascontiguousarray(T_WORLD_CAM[:3, :3]),
            np.ascontiguousarray(T_WORLD_CAM[:3, 3]))
    p1, k1 = raycast.backproject(depth, *args, 1)
    p2, k2 = raycast.backproject(depth, *args, 2)
    H, W = depth.shape
    odd = (np.arange(1, H, 2)[:, None] * W + np.arange(1, W, 2)[None, :]).ravel()
    assert len(p2) == (H // 2) * (W // 2)
    np.testing.assert_array_equal(p2, p1[odd])
    np.testing.assert_array_equal(k2, k1[odd])
    assert k2[2 * (W // 2) + 3] == raycast.KIND_NO_RETURN  # (u, v) = (7, 5)
    assert k2[4 * (W // 2) + 1] == raycast.KIND_INVALID  # (u, v) = (3, 9)


@pytest.mark.parametrize("dist", [0.3, 0.5])
def test_flat_wall_same_occupied_voxels_and_free_up_to_the_view_edge(dist):
    full, sub = scan(1, wall_depth(dist)), scan(2, wall_depth(dist))
    occupied = full.state == VoxelState.OCCUPIED
    assert occupied.sum() > 400  # the wall is in the grid
    np.testing.assert_array_equal(sub.state == VoxelState.OCCUPIED, occupied)
    free_full, free_sub = full.state == VoxelState.FREE, sub.state == VoxelState.FREE
    differ = np.argwhere(free_full != free_sub)
    assert len(differ) < 0.01 * free_full.sum()
    assert reaches_view_edge(full, differ).all()
    # and a voxel well inside the view is labelled by both: the cell 10 cm before the wall
    centre = full.world_to_voxel((EYE + np.array([dist - 0.1, 0.0, 0.0]))[None])[0]
    assert full.state[tuple(centre)] == sub.state[tuple(centre)] == VoxelState.FREE


def test_farther_and_tilted_walls_lose_occupied_voxels_only_at_the_view_edge():
    for dist, tilt in ((0.8, 0.0), (1.0, 0.0), (0.5, 0.5)):
        full, sub = scan(1, wall_depth(dist, tilt)), scan(2, wall_depth(dist, tilt))
        occ_full, occ_sub = full.state == VoxelState.OCCUPIED, sub.state == VoxelState.OCCUPIED
        assert not np.any(occ_sub & ~occ_full)  # no occupied voxel that every pixel does not give
        lost = np.argwhere(occ_full & ~occ_sub)
        assert len(lost) < 0.05 * occ_full.sum()
        if dist > 0.6:  # frontal walls: every lost voxel reaches into the left-out strip
            assert reaches_view_edge(full, lost).all()


def test_stride_two_traces_about_a_quarter_of_the_rays():
    depth = wall_depth(0.5)
    a = OccupancyMap(MapConfig(resolution=0.02, surface_guard=False, sticky_hits=0, ray_grouping=0))
    b = OccupancyMap(MapConfig(resolution=0.02, surface_guard=False, sticky_hits=0, ray_grouping=0, pixel_stride=2))
    sa, sb = a.integrate(depth, K, T_WORLD_CAM, 1.5), b.integrate(depth, K, T_WORLD_CAM, 1.5)
    assert sa.n_rays == CAM.width * CAM.height
    assert sb.n_rays == sa.n_rays // 4
    assert math.isclose(sb.n_traced / sa.n_traced, 0.25)
