"""The home-clearance gate (`sim.home_clearance`, certification step 1b) at its threshold, and
the per-kind base-obstacle gate (step 6) at its threshold."""
from dataclasses import replace

import numpy as np
import pytest

from compass_manip.exploration.world_model import WorldModelConfig
from compass_manip.robot.model import GRIPPER_MAX_WIDTH, RobotConfig
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.certify import CertFailure, _removes_enough, certify
from compass_manip.sim.home_clearance import home_clearance, required_clearances
from compass_manip.sim.scenes import Primitive

from test_sim_certify import CABINET, _scene

HALF = 0.01  # half size [m] of the test block


def _top_sphere():
    """Centre and radius of the robot's sphere reaching highest at home."""
    spheres = panda_sphere_model(RobotConfig(), GRIPPER_MAX_WIDTH)
    c = spheres.sphere_centers(np.asarray(RobotConfig().q_home)[None])[0]
    i = int(np.argmax(c[:, 2] + spheres.radii))
    return c[i], float(spheres.radii[i])


def _block_above(gap: float) -> Primitive:
    """A small block right above the highest home sphere, `gap` [m] from its surface."""
    c, r = _top_sphere()
    return Primitive("block", "box", (HALF, HALF, HALF), (float(c[0]), float(c[1]), float(c[2] + r + gap + HALF)))


def test_required_clearance_is_the_methods_start_margins_plus_half_a_voxel_diagonal():
    cfg = WorldModelConfig()
    inside, outside = required_clearances(cfg)
    half_diag = 0.5 * np.sqrt(3.0) * cfg.map.resolution
    assert inside == pytest.approx(cfg.start_body_margin + half_diag)
    assert outside == pytest.approx(cfg.start_free_margin + half_diag)
    other = replace(cfg, start_body_margin=0.02, start_free_margin=0.03)
    assert required_clearances(other) == pytest.approx((0.02 + half_diag, 0.03 + half_diag))


@pytest.mark.parametrize("delta, ok", [(0.002, True), (-0.002, False)])
def test_a_base_obstacle_at_the_outside_margin(delta, ok):
    need = required_clearances()[1]
    scene = _scene(level=3, obstacles=(_block_above(need + delta),))
    h = home_clearance(scene)
    assert h.obstacles_m == pytest.approx(need + delta, abs=1e-6)
    assert h.ok is ok and h.nearest == "block"


@pytest.mark.parametrize("delta, ok", [(0.002, True), (-0.002, False)])
def test_a_cabinet_board_at_the_body_margin(delta, ok):
    need = required_clearances()[0]
    cab = replace(CABINET, inner=(_block_above(need + delta),))
    scene = replace(_scene(), cabinet=cab)
    h = home_clearance(scene)
    assert h.cabinet_m == pytest.approx(need + delta, abs=1e-6)
    assert h.ok is ok
    # the same board as a base obstacle is held to the larger outside margin
    assert not home_clearance(replace(_scene(level=3), base_obstacles=cab.inner)).ok


def test_certification_rejects_a_scene_inside_the_start_shell_and_names_the_gate():
    need = required_clearances()[1]
    scene = _scene(level=3, obstacles=(_block_above(need - 0.002),))
    assert certify(scene).failure is CertFailure.HOME_CLEARANCE
    # the gate switched off, the same scene passes step 1b (and fails later or certifies)
    from compass_manip.sim.certify import CertifyConfig
    assert certify(scene, CertifyConfig(check_home_clearance=False, physics=False)).failure is not CertFailure.HOME_CLEARANCE


@pytest.mark.parametrize("views, grasps, ok", [
    (0.30, 0.30, True), (0.29, 0.90, False), (0.90, 0.29, False), (1.0, 1.0, True)])
def test_obstacle_gate_is_per_kind_at_its_threshold(views, grasps, ok):
    assert _removes_enough(views, grasps, 10, 10, 0.3) is ok


def test_obstacle_gate_needs_views_and_grasps_without_the_obstacles():
    assert not _removes_enough(0.0, 0.5, 0, 4, 0.3)
    assert not _removes_enough(0.5, 0.0, 4, 0, 0.3)


def test_obstacle_draws_share_one_layout_per_group_of_sub_seeds():
    from compass_manip.sim.certify import OBSTACLE_DRAWS, regenerate
    a, b = regenerate((3, 3, 1, 0)), regenerate((3, 3, 1, 1))
    c = regenerate((3, 3, 1, OBSTACLE_DRAWS))
    assert a.cabinet == b.cabinet and a.clutter == b.clutter and a.target == b.target
    assert a.base_obstacles != b.base_obstacles
    assert a.cabinet != c.cabinet
    assert regenerate((3, 3, 1, 1)) == b  # same sub-seed, same scene


def test_a_layout_is_left_when_no_obstacle_draw_can_pass():
    from compass_manip.sim.certify import Certificate, _other_obstacles_may_pass
    scene = _scene(level=3)
    per_kind = (3,)
    assert not _other_obstacles_may_pass(scene, Certificate(CertFailure.TARGET_VISIBLE_AT_START), per_kind)
    assert not _other_obstacles_may_pass(scene, Certificate(CertFailure.NO_GRASP, n_grasps_without=1), per_kind)
    assert _other_obstacles_may_pass(scene, Certificate(CertFailure.NO_GRASP, n_grasps_without=2), per_kind)
    assert _other_obstacles_may_pass(scene, Certificate(CertFailure.NO_GRASP, n_grasps_without=1), ())
    # home clearance: the cabinet in the shell is the layout's fault, a base obstacle is not
    need = required_clearances()[1]
    blocked = _scene(level=3, obstacles=(_block_above(need - 0.01),))
    assert _other_obstacles_may_pass(blocked, Certificate(CertFailure.HOME_CLEARANCE), per_kind)
    cab = replace(CABINET, inner=(_block_above(0.01),))
    assert not _other_obstacles_may_pass(replace(scene, cabinet=cab), Certificate(CertFailure.HOME_CLEARANCE), per_kind)
