"""One-pass RGB + depth rendering equals the renderer's separate RGB and depth passes."""
import numpy as np
import pytest

from compass_manip.robot.model import Q_HOME
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.rgbd import zbuffer_to_depth
from compass_manip.sim.world import World


@pytest.fixture(scope="module")
def world():
    w = World(certified_scene(4, 0, 0).scene)
    yield w
    w.close()


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
