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
    scene = regenerate((7, 2, 1, 12))  # the first candidate of (seed 7, level 2, index 1) that certifies
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


def _occluder_raised(scene, dz):
    """The scene with its occluder box dz [m] taller (its bottom, footprint and yaw kept)."""
    from dataclasses import replace

    occ = next(o for o in scene.clutter if o.role == "occluder")
    (x0, y0, z0), (x1, y1, z1) = occ.aabb()
    taller = build_object(occ.name, occ.category, occ.colour, (x1 - x0, y1 - y0, z1 - z0 + dz), occ.mass,
                          0.5 * (x0 + x1), 0.5 * (y0 + y1), z0, 0.0, occ.role)
    return replace(scene, clutter=tuple(taller if o is occ else o for o in scene.clutter))


def test_severe_grasps_keep_the_clearance_margin_and_a_closer_box_leaves_none():
    """The certified severe grasp clears everything but the target by severe_grasp_margin
    (sphere model: grasp, lift and the straight pre-grasp -> grasp -> lift); the same scene
    with the box raised to leave the hand only a few millimetres still has grasps without the
    margin, none with it."""
    from compass_manip.motion.primitives import PrimitiveSet
    from compass_manip.robot.model import GRIPPER_MAX_WIDTH, RobotConfig
    from compass_manip.robot.spheres import panda_sphere_model
    from compass_manip.sim.certify import CertifyConfig, _grasps, certified_scene

    cs = certified_scene(2, 0, 0)
    scene, c = cs.scene, cs.certificate
    margin = CertifyConfig().severe_grasp_margin
    assert margin == pytest.approx(0.01)
    P = np.asarray(c.path)
    _, i_pre, i_grasp, i_lift = c.path_marks
    chk = oracle.ground_truth_checker(scene, exclude_target=True, margin=margin)
    assert chk.is_valid(P[i_grasp]) and chk.is_valid(P[i_lift])
    assert chk.edge_valid(P[i_pre], P[i_grasp]) and chk.edge_valid(P[i_grasp], P[i_lift])
    # the hand's clearance to the box at the grasp, then the box raised to leave it 4 mm
    sm = panda_sphere_model(RobotConfig(base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw),
                            GRIPPER_MAX_WIDTH)
    occ = next(o for o in scene.clutter if o.role == "occluder")
    C = sm.sphere_centers(P[i_grasp][None])[0]
    gap = float(np.min(PrimitiveSet.from_shapes(list(occ.parts)).distance(C) - sm.radii))
    assert margin - 1e-6 <= gap < 0.03
    raised = _occluder_raised(scene, gap - 0.004)
    world = World(raised)
    try:
        ik = oracle.robot_ik(world.robot)
        with_margin, _, _ = _grasps(world, CertifyConfig(), ik, False, margin)
        without, _, _ = _grasps(world, CertifyConfig(), ik, False, 0.0)
    finally:
        world.close()
    assert not with_margin and without


def test_severe_grasp_margin_must_be_a_small_clearance():
    from compass_manip.errors import CompassInputError
    from compass_manip.sim.certify import CertifyConfig

    for bad in (-0.001, 0.2):
        with pytest.raises(CompassInputError, match="severe_grasp_margin"):
            CertifyConfig(severe_grasp_margin=bad)
