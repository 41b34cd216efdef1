"""One-pass RGB + depth rendering equals the renderer's separate RGB and depth passes; leaving
geoms outside the view out of a render changes no image."""
import numpy as np
import pytest

from compass_manip.robot.model import Q_HOME
from compass_manip.sim.rgbd import cull_outside_view, view_planes, zbuffer_to_depth
from compass_manip.sim.world import LABEL_ROBOT


@pytest.fixture(scope="module")
def world(level4_world):
    return level4_world


def test_one_pass_equals_two_passes(world):
    rng = np.random.default_rng(3)
    lo, hi = world.model.jnt_range[:7, 0], world.model.jnt_range[:7, 1]
    for q in [Q_HOME] + [np.clip(Q_HOME + rng.normal(0.0, 0.3, 7), lo, hi) for _ in range(5)]:
        world.set_q(q)
        rgb, depth = world.render_rgbd()
        assert rgb.dtype == np.uint8 and depth.dtype == np.float32
        assert np.array_equal(rgb, world.render_rgb())
        assert np.array_equal(depth, world.render_depth())
        assert np.isfinite(depth).any()
    frame = world.render(Q_HOME, rgb=True)
    world.set_q(Q_HOME)
    assert np.array_equal(frame.depth, world.render_depth()) and np.array_equal(frame.rgb, world.render_rgb())


def test_zbuffer_conversion_hits_the_clip_planes():
    # reversed Z: 1 at the near plane, 0 at the far plane; half way in window depth is
    # the harmonic mean of the planes (perspective depth is 1/z-linear)
    extent, znear, zfar = 2.0, 0.005, 5.0
    near, far = znear * extent, zfar * extent
    d = zbuffer_to_depth(np.array([1.0, 0.0, 0.5], np.float32), extent, znear, zfar)
    assert d[0] == pytest.approx(near, rel=1e-5)
    assert d[1] == pytest.approx(far, rel=1e-4)
    assert d[2] == pytest.approx(2.0 / (1.0 / near + 1.0 / far), rel=1e-4)


def test_culling_keeps_every_image_the_same(world):
    rng = np.random.default_rng(5)
    lo, hi = world.model.jnt_range[:7, 0], world.model.jnt_range[:7, 1]
    robot_seen, dropped = 0, []
    try:
        for i in range(24):  # anywhere in the joint limits: about one pose in five sees the arm
            q = rng.uniform(lo, hi)
            world.cull_outside_view = True
            culled = world.render(q, rgb=True, seg=True)
            world.cull_outside_view = False
            full = world.render(q, rgb=True, seg=True)
            dropped.append(cull_outside_view(world._update_scene().scene, world.T_world_cam(), world._view_planes,
                                             world.model.vis.map.znear * world.model.stat.extent))
            assert np.array_equal(culled.rgb, full.rgb), i
            assert np.array_equal(culled.depth, full.depth), i
            assert np.array_equal(culled.seg, full.seg), i
            robot_seen += bool(np.any(full.seg == LABEL_ROBOT))
    finally:
        world.cull_outside_view = True
    assert robot_seen >= 3  # poses with the arm in view were compared
    assert min(dropped) >= 1 and np.mean(dropped) >= 10  # and culling left geoms out


def test_view_planes_bound_the_image():
    K = np.array([[300.0, 0.0, 159.5], [0.0, 300.0, 119.5], [0.0, 0.0, 1.0]])
    planes = view_planes(K, 320, 240, pad_px=0.0)
    corners = [(-0.5, -0.5), (319.5, -0.5), (-0.5, 239.5), (319.5, 239.5), (159.5, 119.5)]
    for u, v in corners:  # rays through the image's corners and centre are inside or on the planes
        p = np.array([(u - 159.5) / 300.0, (v - 119.5) / 300.0, 1.0])
        assert np.all(planes @ p >= -1e-12)
    outside = np.array([(330.0 - 159.5) / 300.0, 0.0, 1.0])  # 10 px beyond the right edge
    assert np.any(planes @ outside < 0)


def _cull_reference(scene, T_world_cam, planes, near_m, margin_m=0.01):
    """The culling test one geom at a time (as first written): indices it drops."""
    import mujoco

    cullable = {int(t) for t in (mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_SPHERE,
                                 mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER,
                                 mujoco.mjtGeom.mjGEOM_ELLIPSOID)}
    R, t = T_world_cam[:3, :3], T_world_cam[:3, 3]
    out = []
    for i in range(scene.ngeom):
        g = scene.geoms[i]
        if int(g.type) not in cullable or not g.modelrbound > 0:
            continue
        p = (np.asarray(g.pos) - t) @ R
        r = g.modelrbound + margin_m
        if p[2] + r < near_m or np.any(planes @ p < -r):
            out.append(i)
    return out


def test_array_culling_drops_the_geoms_the_per_geom_test_drops(world):
    import mujoco

    rng = np.random.default_rng(8)
    lo, hi = world.model.jnt_range[:7, 0], world.model.jnt_range[:7, 1]
    near = world.model.vis.map.znear * world.model.stat.extent
    try:
        world.cull_outside_view = False
        for _ in range(20):
            world.set_q(rng.uniform(lo, hi))
            scene = world._update_scene().scene
            T = world.T_world_cam()
            expected = _cull_reference(scene, T, world._view_planes, near)
            n = cull_outside_view(scene, T, world._view_planes, near)
            dropped = [i for i in range(scene.ngeom) if scene.geoms[i].type == mujoco.mjtGeom.mjGEOM_NONE]
            assert n == len(expected) and dropped == expected
    finally:
        world.cull_outside_view = True


def test_box_culling_drops_the_camera_links_and_keeps_the_images(world):
    """Near the home posture the boxes leave out the hand, whose sphere reaches into the
    view, and every image stays the same (poses with the arm in view: the test above)."""
    import mujoco

    m = world.model
    rng = np.random.default_rng(9)
    lo, hi = m.jnt_range[:7, 0] + 0.01, m.jnt_range[:7, 1] - 0.01
    try:
        for i in range(12):
            q = np.clip(Q_HOME + rng.normal(0.0, 0.3, 7), lo, hi)
            world.cull_outside_view = True
            culled = world.render(q, rgb=True, seg=True)
            scene = world._update_scene().scene
            kept = {int(scene.geoms[j].objid) for j in range(scene.ngeom)
                    if scene.geoms[j].type != mujoco.mjtGeom.mjGEOM_NONE}
            assert m.geom("hand/hand").id not in kept, i
            world.cull_outside_view = False
            full = world.render(q, rgb=True, seg=True)
            assert np.array_equal(culled.rgb, full.rgb), i
            assert np.array_equal(culled.depth, full.depth), i
            assert np.array_equal(culled.seg, full.seg), i
    finally:
        world.cull_outside_view = True


_RENDER_SNIPPET = """
import hashlib, os, sys
import numpy as np
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World
assert os.environ["LP_NUM_THREADS"] == sys.argv[1]
w = World(certified_scene(4, 0, 0).scene)
rng = np.random.default_rng(5)
lo, hi = w.model.jnt_range[:7, 0], w.model.jnt_range[:7, 1]
h = hashlib.sha1()
for q in [Q_HOME] + [np.clip(Q_HOME + rng.normal(0.0, 0.3, 7), lo, hi) for _ in range(3)]:
    w.set_q(q)
    rgb, depth = w.render_rgbd()
    h.update(rgb.tobytes()); h.update(depth.tobytes())
print(h.hexdigest())
"""


def test_llvmpipe_threads_default_and_same_images(tmp_path):
    """Importing sim.rgbd makes llvmpipe rasterise on the calling thread (LP_NUM_THREADS=0)
    unless the environment names a value, and the images do not depend on it."""
    import os
    import subprocess
    import sys

    assert os.environ.get("LP_NUM_THREADS") is not None  # set (by default to "0") by the import above
    digests = []
    for threads in ("0", "2"):
        env = dict(os.environ, LP_NUM_THREADS=threads)
        out = subprocess.run([sys.executable, "-c", _RENDER_SNIPPET, threads], env=env, capture_output=True,
                             text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        digests.append(out.stdout.strip().splitlines()[-1])
    assert digests[0] == digests[1]
    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", "import os, compass_manip.sim.rgbd; print(os.environ['LP_NUM_THREADS'])"],
                         env=env, capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "0", out.stderr[-2000:]
