"""The severe levels' hiding layout (a tall bottle behind a low wide box, grasped by its neck):
its geometry, the oracle's neck grasps, and a generated scene hidden from the reference
fixed-view set yet certified by path and physics."""
import numpy as np
import pytest

from compass_manip.sim import oracle, outside_views, severe
from compass_manip.sim.certify import certify, regenerate
from compass_manip.sim.levels import generate_scene
from compass_manip.sim.objects import build_object
from compass_manip.sim.scenes import CabinetSpec, SceneSpec
from compass_manip.sim.world import World

CABINET = CabinetSpec((0.42, -0.3, 0.25), (0.78, 0.3, 0.85), frame=(0.03, 0.03, 0.03, 0.0), shelves=(0.55,))


@pytest.mark.parametrize("level", [2, 4])
def test_severe_layout_puts_a_long_necked_bottle_close_behind_a_lower_wide_box(level):
    for index in range(6):
        s = generate_scene(level, index, np.random.default_rng([3, level, index]))
        t, occ = s.target, next(o for o in s.clutter if o.role == "occluder")
        (tx0, ty0, tz0), (_, ty1, tz1) = t.aabb()
        (ox0, oy0, _), (ox1, oy1, oz1) = occ.aabb()
        neck_h = 2 * t.parts[1].half_extents[2]
        assert t.category == "bottle" and severe.NECK_HEIGHT[0] <= neck_h <= severe.NECK_HEIGHT[1]
        assert severe.TARGET_HEIGHT[0] <= tz1 - tz0 <= severe.TARGET_HEIGHT[1] + 1e-9
        assert severe.GAP[0] - 1e-9 <= tx0 - ox1 <= severe.GAP[1] + 1e-9  # close in front
        assert t.pos[0] - ox0 <= severe.MAX_FRONT + 1e-9  # the wrist passes in front of it
        assert oy0 < ty0 - 0.05 and oy1 > ty1 + 0.05  # wider than the bottle on both sides
        assert severe.DROP[0] - 1e-9 <= tz1 - oz1 <= severe.DROP[1] + 1e-9  # only the neck shows
        assert oz1 > tz1 - neck_h  # the shoulder is below the box's top
        row = s.cabinet.rows()[0]
        assert abs(tz0 - row[0]) < 1e-9 and row[1] - tz1 >= severe.HEADROOM - 1e-9  # bottom storey, room to lift
        assert s.cabinet.rail > 0.0


def test_neck_grasps_only_for_long_necks():
    def bottle(neck):
        return build_object("target", "bottle", "red", (0.032, 0.14, 0.015, neck), 0.1, 0.7, 0.0, 0.25, 0.0, "target")

    for neck, expect in ((0.045, False), (0.085, True)):
        t = bottle(neck)
        s = SceneSpec(2, 0, (0, 2, 0, 0), CABINET, t)
        z_neck = 0.25 + 0.14 + neck - oracle.NECK_TCP_DEPTH
        zs = [T[2, 3] for T, _ in oracle.grasp_candidates(s)]
        on_neck = [z for z in zs if abs(z - z_neck) < 1e-9]
        assert bool(on_neck) is expect
        if expect:  # near-horizontal only, right after the body candidate of the same direction
            degs = [d for T, d in oracle.grasp_candidates(s) if abs(T[2, 3] - z_neck) < 1e-9]
            assert set(degs) == set(oracle.NECK_PITCH_DEG)
            assert abs(zs[0] - (0.25 + 0.14 - 0.025)) < 1e-9 and abs(zs[1] - z_neck) < 1e-9


def test_a_generated_severe_scene_is_hidden_from_every_reference_view_and_certified():
    scene = regenerate((7, 2, 1, 4))  # the first candidate of (seed 7, level 2, index 1) that certifies
    world = World(scene)
    try:
        fv = oracle.fixed_view_visibilities(world)
        assert len(fv) == 24 and max(fv) < 0.3
        c = certify(scene, world=world)
    finally:
        world.close()
    assert c.certified, c.failure
    assert not c.fv_solvable and c.best_fixed_view_visibility == pytest.approx(max(fv))
    assert c.best_view_visibility >= 0.3 and c.lift_height >= 0.03 and c.grasp_approach_deg <= 15.0
    # no camera outside the opening sees enough; the certified view's camera is inside or at it
    assert c.best_outside_view_visibility is not None and c.best_outside_view_visibility < 0.3
    assert c.view_camera_outside_m is not None and c.view_camera_outside_m <= outside_views.AT_OPENING
