"""Level 4's aimed base obstacles: the dense neck family, the removal prediction, the aimed draw."""
from dataclasses import replace

import numpy as np
import pytest

from compass_manip.motion.primitives import PrimitiveSet
from compass_manip.sim import oracle
from compass_manip.sim.aimed_obstacles import ArmSamples, _home_shell_free, aim, layout_samples, predicted_removal
from compass_manip.sim.certify import OBSTACLE_DRAWS, regenerate
from compass_manip.sim.home_clearance import home_clearance, required_clearances
from compass_manip.sim.levels import draw_base_obstacles
from compass_manip.sim.scenes import Primitive


def _box(name, half, pos):
    return Primitive(name, "box", half, pos)


def _samples(views, grasps, home=((0.0, 0.0, 0.5),)):
    """Samples of spheres of radius 0.05 m: views (pose, solution, sphere) and grasps (candidate,
    solution, grasp/pre-grasp/lift, sphere) centres [m]."""
    return ArmSamples(tuple(np.asarray(v, float) for v in views), tuple(np.asarray(g, float) for g in grasps),
                      np.array([0.05]), 0.01, np.asarray(home, float))


def test_dense_neck_family_holds_the_sparse_neck_grasps_and_nothing_for_a_can():
    scene = regenerate((0, 2, 0, 0))  # a severe layout: the long-necked bottle
    dense = oracle.dense_neck_candidates(scene)
    assert len(dense) == 19 * 3 * 2 * 2  # yaws x TCP depths x pitches x rolls
    assert {deg for _, deg in dense} == set(oracle.NECK_PITCH_DEG)
    neck = scene.target.parts[1]
    z_sparse = neck.pos[2] + neck.half_extents[2] - oracle.NECK_TCP_DEPTH
    sparse = [T for T, deg in oracle.grasp_candidates(scene) if abs(T[2, 3] - z_sparse) < 1e-9]
    assert sparse and all(any(np.allclose(T, D) for D, _ in dense) for T in sparse
                          if abs(np.arctan2(T[1, 2], T[0, 2])) <= 0.45 + 1e-9)
    no_neck = replace(scene, target=replace(scene.target, parts=scene.target.parts[:1]))
    assert oracle.dense_neck_candidates(no_neck) == []

def test_predicted_removal_counts_a_pose_removed_only_when_every_solution_is_blocked():
    # two view poses: one with a single solution at x = 0.5, one with a second solution at x = -0.5
    views = [[[[0.5, 0.0, 0.5]]], [[[0.5, 0.0, 0.5]], [[-0.5, 0.0, 0.5]]]]
    # two grasps: grasp/pre-grasp/lift of one solution; the second grasp's lift rises to z = 1.0
    grasps = [[[[[0.5, 0.3, 0.5]], [[0.4, 0.3, 0.5]], [[0.5, 0.3, 0.55]]]],
              [[[[0.0, 0.6, 0.5]], [[0.0, 0.6, 0.5]], [[0.0, 0.6, 1.0]]]]]
    s = _samples(views, grasps)
    block = _box("b", (0.1, 0.5, 0.1), (0.5, 0.0, 0.5))  # holds x = 0.5 for every y in +-0.5
    assert predicted_removal(s, [block]) == (0.5, 0.5)
    assert predicted_removal(s, [_box("far", (0.05, 0.05, 0.05), (3.0, 3.0, 3.0))]) == (0.0, 0.0)
    # the grasp margin: a box 0.055 m from the second grasp's lift sphere surface blocks it (< 0.01 + 0.05)
    lid = _box("lid", (0.2, 0.2, 0.01), (0.0, 0.6, 1.0 + 0.05 + 0.005 + 0.01))
    assert predicted_removal(s, [lid]) == (0.0, 0.5)
    assert predicted_removal(_samples([], []), [block]) == (0.0, 0.0)


def test_home_shell_check_holds_obstacles_to_the_outside_margin():
    need = required_clearances()[1]
    s = _samples([], [], home=((0.0, 0.0, 0.5),))
    at = lambda gap: _box("b", (0.05, 0.05, 0.05), (0.0, 0.0, 0.5 + 0.05 + gap + 0.05))
    assert _home_shell_free(s, [at(need + 0.002)]) and not _home_shell_free(s, [at(need - 0.002)])


def test_aim_gives_up_on_a_layout_with_at_most_one_view():
    scene = regenerate((0, 3, 0, 0))
    one_view = _samples([[[[0.5, 0.0, 0.5]]]], [[[[[0.5, 0.3, 0.5]]] * 3]] * 3)
    assert aim(scene, one_view, np.random.default_rng(0)) is None


@pytest.fixture(scope="module")
def aimed():
    """The first aimed candidate of the default set's level-4 scene 1 and its layout's samples."""
    return regenerate((0, 4, 1, 0)), layout_samples(0, 4, 1, 0)


def test_an_aimed_level_4_draw_is_predicted_to_pass_and_keeps_the_home_shell_free(aimed):
    scene, samples = aimed
    assert scene.extra["aim_draws"] >= 1
    names = {p.name for p in scene.base_obstacles}
    assert "base_low_bar" in names and any(n.startswith("base_wall") for n in names)  # a lateral constraint
    v, g = predicted_removal(samples, scene.base_obstacles)
    assert 0.3 <= v < 1.0 and 0.3 <= g < 1.0
    assert home_clearance(scene).obstacles_m >= required_clearances()[1]
    assert regenerate((0, 4, 1, 0)) == scene  # same sub-seed, same scene


def test_aimed_draws_keep_the_layout_and_the_variant(aimed):
    scene, _ = aimed
    other = regenerate((0, 4, 1, 1))
    assert other.cabinet == scene.cabinet and other.target == scene.target and other.clutter == scene.clutter
    assert other.extra["obstacle_variant"] == scene.extra["obstacle_variant"]
    assert regenerate((0, 4, 1, OBSTACLE_DRAWS)).cabinet != scene.cabinet
    blind = draw_base_obstacles(replace(scene, base_obstacles=()), np.random.default_rng(3))
    assert [p.name for p in blind][-1] == "base_low_bar" and PrimitiveSet.from_shapes(list(blind)) is not None


def test_level_4_counts_its_grasps_over_the_dense_family_and_gates_them_per_kind(aimed):
    from compass_manip.sim.certify import CertFailure, CertifyConfig, _grasps, certify
    from compass_manip.sim.world import World
    scene, samples = aimed
    far = replace(scene, base_obstacles=(_box("base_far", (0.05, 0.05, 0.05), (-0.8, -0.8, 0.05)),))
    world = World(far)
    try:
        ik = oracle.robot_ik(world.robot)
        cfg = CertifyConfig()
        m = cfg.margin + cfg.severe_grasp_margin
        _, n_with, n_dense = _grasps(world, cfg, ik, True, m)
        _, _, n_sparse = _grasps(world, replace(cfg, dense_grasp_levels=()), ik, True, m)
    finally:
        world.close()
    assert n_dense >= n_sparse + 2 and n_with == n_dense  # the far box removes none
    assert n_dense >= len(samples.grasps)  # the aiming's samples: the dense family, the same validity
    c = certify(far, replace(cfg, physics=False))  # per kind at level 4: the grasps' half fails
    assert c.failure is CertFailure.OBSTACLES_TOO_WEAK and c.grasps_removed_by_obstacles == 0.0
    assert c.n_grasps_without == n_dense
