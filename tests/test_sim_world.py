"""Rendering, ray casting, geometry of frames, contacts."""
from pathlib import Path

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.certify import regenerate
from compass_manip.sim.scenes import SceneSpec
from compass_manip.sim.world import World

#: a Level-4 scene of the previous generator (many small parts), kept as data
SCENE4 = Path(__file__).parent / "data" / "level4_scene0_seed0_v2.json"


@pytest.fixture(scope="module")
def world4():
    w = World(SceneSpec.from_json(SCENE4.read_text()))
    yield w
    w.close()


def _poses():
    rng = np.random.default_rng(3)
    return [Q_HOME] + [Q_HOME + rng.uniform(-0.25, 0.25, 7) for _ in range(3)]


def test_rendered_depth_equals_raycast_depth(world4):
    for q in _poses():
        world4.set_q(q)
        gl = world4.render_depth()
        rc = world4.raycast_depth()
        hit = np.isfinite(gl) & np.isfinite(rc) & (gl > 0) & (rc > 0)
        assert hit.mean() > 0.3
        close = np.abs(gl[hit] - rc[hit]) <= 1e-3
        assert close.mean() >= 0.998  # silhouette pixels of many small parts differ
        assert np.array_equal(np.isfinite(gl), np.isfinite(rc))


def test_back_projected_wall_lies_on_its_plane(world4):
    """Pixels seeing the cabinet's back board back-project onto the plane x = interior_max.x."""
    f = world4.render(Q_HOME, seg=True)
    back = f.seg == world4.labels["cab_back"]
    assert back.sum() > 1000
    v, u = np.nonzero(back)
    z = f.depth[v, u].astype(float)
    K = f.K
    pts_cam = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z], axis=1)
    pts = pts_cam @ f.T_world_cam[:3, :3].T + f.T_world_cam[:3, 3]
    x_plane = world4.scene.cabinet.interior_max[0]
    assert np.abs(pts[:, 0] - x_plane).max() < 1e-3


def test_same_seed_same_depth():
    a, b = World(regenerate((9, 3, 2, 0))), World(regenerate((9, 3, 2, 0)))
    try:
        assert np.array_equal(a.render(Q_HOME).depth, b.render(Q_HOME).depth)
    finally:
        a.close()
        b.close()


def test_segmentation_only_when_asked_and_one_label_per_object(world4):
    f = world4.render(Q_HOME)
    assert f.seg is None and f.rgb is not None
    g = world4.render(Q_HOME, seg=True)
    assert g.seg is not None and np.array_equal(g.depth, f.depth)
    m = world4.model
    for obj in world4.scene.objects:
        labels = {int(world4.geom_label[m.geom(p.name).id]) for p in obj.parts}
        assert labels == {world4.labels[obj.name]}
    assert world4.target_label == world4.labels["target"]
    assert set(world4.target_geoms) == {m.geom(p.name).id for p in world4.scene.target.parts}


def test_an_object_is_one_free_body_with_its_parts(world4):
    m = world4.model
    for obj in world4.scene.objects:
        body = m.body(obj.name)
        assert body.geomnum[0] == len(obj.parts)
        assert m.jnt_type[body.jntadr[0]] == 0  # mjJNT_FREE
        assert m.body_mass[body.id] == pytest.approx(obj.mass)


def test_visibility_from_a_pose_and_from_the_wrist_agree(world4):
    world4.set_q(Q_HOME)
    assert world4.visibility_from(world4.T_world_cam(), with_robot=False) == pytest.approx(
        world4.target_visibility(Q_HOME), abs=1e-9)


def _visibility_casting_every_box_pixel(world, T, stride, with_robot):
    """`World.visibility_from` as it was before it cast the scene only along the rays that
    reach the target alone: both casts over every pixel of the target's box."""
    from compass_manip.sim.world import _RAY_GROUPS, _SCENE_GROUPS, _TARGET_ONLY
    px = world._target_pixels(T, stride)
    if px is None:
        return 0.0
    dirs = world._pixel_dirs_cam().reshape(world.camera.height, world.camera.width, 3)[px[1], px[0]] @ T[:3, :3].T
    dist_all, gid_all = world.cast_rays(T[:3, 3], dirs, _RAY_GROUPS if with_robot else _SCENE_GROUPS)
    dist_t, gid_t = world.cast_rays(T[:3, 3], dirs, _TARGET_ONLY)
    in_range = (dist_t > world.camera.depth_min) & (dist_t <= world.camera.depth_max)
    alone = np.count_nonzero((gid_t >= 0) & in_range)
    if alone == 0:
        return 0.0
    hit_t = np.zeros(len(gid_all), bool)
    hit_t[gid_all >= 0] = world.is_target_geom[gid_all[gid_all >= 0]]
    return np.count_nonzero(hit_t & in_range) / alone


def test_visibility_casts_the_scene_only_where_the_target_is_and_gives_the_same_fraction(world4):
    from compass_manip.sim.view_search import inside_view_poses, sample_view_poses
    scene = world4.scene
    rng = np.random.default_rng(11)
    poses = sample_view_poses(scene, 30, rng) + inside_view_poses(scene, 10, rng)
    world4.set_q(Q_HOME)
    got, want = [], []
    for k, T in enumerate(poses):
        stride, robot = (1, 3)[k % 2], k % 3 == 0
        got.append(world4.visibility_from(T, stride=stride, with_robot=robot))
        want.append(_visibility_casting_every_box_pixel(world4, T, stride, robot))
    assert got == want  # exactly
    assert any(0.0 < v < 1.0 for v in want) and any(v == 0.0 for v in want)


def test_frame_contents(world4):
    f = world4.render(Q_HOME, t=1.5, seg=True)
    H, W = world4.camera.height, world4.camera.width
    assert f.depth.shape == (H, W) and f.depth.dtype == np.float32
    assert f.rgb.shape == (H, W, 3) and f.rgb.dtype == np.uint8
    assert f.seg.shape == (H, W)
    assert f.t == 1.5 and np.allclose(f.q, Q_HOME)
    valid = np.isfinite(f.depth) & (f.depth > 0)
    assert np.all(f.depth[valid] >= world4.camera.depth_min) and np.all(f.depth[valid] <= world4.camera.depth_max)
    # camera pose: optical axis level and pointing into the cabinet (+x) at home
    assert f.T_world_cam[0, 2] > 0.99
    # the mount transform chain: T_world_cam = T_world_hand @ T_hand_cam
    hid = world4.model.body("hand/panda_hand").id
    T_world_hand = np.eye(4)
    T_world_hand[:3, :3] = world4.data.xmat[hid].reshape(3, 3)
    T_world_hand[:3, 3] = world4.data.xpos[hid]
    assert np.allclose(T_world_hand @ world4.camera.T_hand_cam, f.T_world_cam, atol=1e-6)


def test_intrinsics_match_the_field_of_view(world4):
    K = world4.camera.K
    assert 2 * np.degrees(np.arctan(world4.camera.height / 2 / K[1, 1])) == pytest.approx(58.0)


def test_home_is_collision_free(world4):
    assert world4.contacts(Q_HOME, include_self=True) == []


def test_set_q_rejects_bad_joints(world4):
    with pytest.raises(CompassInputError, match="NaN"):
        world4.set_q(np.full(7, np.nan))
    with pytest.raises(CompassInputError, match="outside joint 4"):
        world4.set_q(np.array([0, 0, 0, 0.5, 0, 1, 0]))
    with pytest.raises(CompassInputError, match="7 joint angles"):
        world4.set_q(np.zeros(6))


def test_scene_objects_do_not_interpenetrate():
    import mujoco

    for k in range(6):
        for level in (2, 4):
            w = World(regenerate((k, level, 0, 0)))
            try:
                mujoco.mj_collision(w.model, w.data)
                for i in range(w.data.ncon):
                    c = w.data.contact[i]
                    if w.is_robot_geom[c.geom1] or w.is_robot_geom[c.geom2]:
                        continue
                    assert c.dist > -1e-4, (w._geom_name(c.geom1), w._geom_name(c.geom2), c.dist)
            finally:
                w.close()


def test_camera_is_configurable():
    from compass_manip.robot.model import CameraConfig, RobotConfig

    cam = CameraConfig(width=160, height=120, fovy_deg=45.0, depth_min=0.2, depth_max=1.0)
    w = World(regenerate((0, 1, 0, 0)), RobotConfig(camera=cam))
    try:
        f = w.render(Q_HOME)
        assert f.depth.shape == (120, 160) and np.allclose(f.K, cam.K)
        valid = np.isfinite(f.depth) & (f.depth > 0)
        assert np.all(f.depth[valid] <= 1.0) and np.all(f.depth[valid] >= 0.2)
        rc = w.raycast_depth()
        hit = valid & np.isfinite(rc)
        assert (np.abs(f.depth[hit] - rc[hit]) <= 1e-3).mean() >= 0.999
    finally:
        w.close()


def test_generator_start_camera_matches_the_home_pose(world4):
    from compass_manip.sim.levels import START_CAMERA_POS

    world4.set_q(Q_HOME)
    assert np.linalg.norm(world4.T_world_cam()[:3, 3] - START_CAMERA_POS) < 0.005
