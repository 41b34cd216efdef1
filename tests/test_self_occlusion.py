"""Gain rays the robot's own body blocks (`mapping.self_occlusion`): exact against a brute-force
ray-sphere test, and the information gain without them."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.mapping.infogain import camera_ray_directions, info_gain_batch
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
from compass_manip.mapping.self_occlusion import self_blocked_rays

K = np.array([[80.0, 0.0, 39.5], [0.0, 80.0, 29.5], [0.0, 0.0, 1.0]])
RAYS = (20, 15)


def pose(origin, R=np.eye(3)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, origin
    return T


def brute(T, centres, radii, max_range):
    d = camera_ray_directions(K, RAYS) @ T[:3, :3].T
    o = T[:3, 3]
    out = np.zeros(len(d), bool)
    for c, r in zip(centres, radii):
        oc = c - o
        if oc @ oc <= r * r:
            continue
        t = d @ oc
        h2 = r * r - (oc @ oc - t * t)
        out |= (t > 0) & (h2 > 0) & (t - np.sqrt(np.maximum(h2, 0)) < max_range)
    return out


def test_a_sphere_in_front_blocks_the_rays_through_it_and_nothing_else_does():
    T = pose([0.0, 0.0, 0.0])  # looking along +z
    centres = np.array([[[0.0, 0.0, 0.3],  # in front, on the axis
                         [0.0, 0.0, -0.3],  # behind
                         [0.0, 0.0, 0.0],  # holding the camera
                         [0.0, 0.0, 2.0]]])  # beyond the range
    radii = np.array([0.05, 0.2, 0.1, 0.3])
    blocked = self_blocked_rays(T[None], K, RAYS, centres, radii, 1.0)[0]
    only_front = self_blocked_rays(T[None], K, RAYS, centres[:, :1], radii[:1], 1.0)[0]
    assert blocked.any() and np.array_equal(blocked, only_front)
    d = camera_ray_directions(K, RAYS)
    # exactly the rays whose angle to the axis is below the sphere's angular radius
    np.testing.assert_array_equal(blocked, np.arccos(d[:, 2]) < np.arcsin(0.05 / 0.3))


def test_matches_a_brute_force_ray_sphere_test_on_random_views_and_spheres():
    rng = np.random.default_rng(7)
    from scipy.spatial.transform import Rotation
    Ts = np.stack([pose(rng.uniform(-0.3, 0.3, 3), Rotation.random(random_state=int(rng.integers(1e9))).as_matrix())
                   for _ in range(12)])
    centres = rng.uniform(-0.8, 0.8, (12, 40, 3))
    radii = rng.uniform(0.01, 0.12, 40)
    got = self_blocked_rays(Ts, K, RAYS, centres, radii, 0.7)
    want = np.stack([brute(Ts[m], centres[m], radii, 0.7) for m in range(12)])
    assert want.any() and not want.all()
    np.testing.assert_array_equal(got, want)


def test_skipped_rays_count_nothing_in_the_information_gain():
    occ = OccupancyMap(MapConfig(resolution=0.05, box_min=(-1.0, -1.0, -1.0), box_max=(1.0, 1.0, 1.0)))
    Ts = np.stack([pose([0.0, 0.0, 0.0]), pose([0.1, 0.0, 0.0])])
    n = RAYS[0] * RAYS[1]
    full = info_gain_batch(occ, Ts, K, 0.8, RAYS)
    assert (full > 0).all()
    np.testing.assert_array_equal(info_gain_batch(occ, Ts, K, 0.8, RAYS, skip_rays=np.zeros((2, n), bool)), full)
    none = info_gain_batch(occ, Ts, K, 0.8, RAYS, skip_rays=np.ones((2, n), bool))
    np.testing.assert_array_equal(none, [0, 0])
    half = np.zeros((2, n), bool)
    half[0, : n // 2] = True  # the upper half of view 0's rays
    part = info_gain_batch(occ, Ts, K, 0.8, RAYS, skip_rays=half)
    assert 0 < part[0] < full[0] and part[1] == full[1]
    with pytest.raises(CompassInputError, match="skip_rays has shape"):
        info_gain_batch(occ, Ts, K, 0.8, RAYS, skip_rays=np.zeros((1, n), bool))


def test_bad_shapes_are_refused_with_a_clear_error():
    with pytest.raises(CompassInputError, match="centres"):
        self_blocked_rays(np.eye(4)[None], K, RAYS, np.zeros((2, 3, 3)), np.ones(3), 1.0)
    with pytest.raises(CompassInputError, match="max_range"):
        self_blocked_rays(np.eye(4)[None], K, RAYS, np.zeros((1, 3, 3)), np.ones(3), 0.0)


def test_a_wrist_camera_turned_back_at_its_own_arm_gains_little():
    from compass_manip.exploration.world_model import WorldModel
    from compass_manip.mapping.self_occlusion import robot_blocked_rays
    from compass_manip.robot.model import Q_MAX, Q_MIN, RobotConfig
    q = np.asarray(RobotConfig().q_home, float)
    wm = WorldModel(q)
    rng = np.random.default_rng(0)
    Q = np.tile(q, (200, 1))
    Q[:, 4:] += rng.uniform(-2.0, 2.0, (200, 3))  # wrist turned every way
    Q = np.clip(Q, Q_MIN, Q_MAX)
    T = wm.kin.T_world_cam_batch(Q)
    blocked = robot_blocked_rays(wm, Q, T, K, RAYS, 1.0)
    share = blocked.mean(axis=1)
    # some wrist poses look back at the arm (most of their rays blocked), others out of it
    assert share.max() > 0.3 and share.min() < 0.05
    full = info_gain_batch(wm.occ, T, K, 1.0, RAYS)
    seen = info_gain_batch(wm.occ, T, K, 1.0, RAYS, skip_rays=blocked)
    assert (seen <= full).all()
    worst = int(np.argmax(share))
    assert seen[worst] < (1 - share[worst] / 2) * full[worst]
