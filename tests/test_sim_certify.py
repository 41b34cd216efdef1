"""Certification of all default scenes, and the measured difficulty ordering of the levels."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.sim.certify import CertFailure, certified_scene, certify, find_grasp
from compass_manip.sim.world import World


@pytest.fixture(scope="module")
def default_set():
    return {lv: [certified_scene(lv, i, 0) for i in range(20)] for lv in (1, 2, 3, 4)}


def test_all_20_scenes_of_every_level_are_certified(default_set):
    for lv, scenes in default_set.items():
        assert len(scenes) == 20
        for cs in scenes:
            c = cs.certificate
            assert c.certified and c.failure is CertFailure.NONE
            assert c.start_visibility < 0.05
            assert c.best_view_visibility >= 0.3 and c.view_visibility_fraction > 0
            assert c.grasp_found
            assert cs.scene.level == lv


def test_difficulty_ordering_is_measured(default_set):
    mean = lambda lv, key: np.mean([getattr(cs.certificate, key) for cs in default_set[lv]])  # noqa: E731
    # harder to see: L2 vs L1 and L4 vs L3
    assert mean(2, "view_visibility_fraction") < mean(1, "view_visibility_fraction")
    assert mean(4, "view_visibility_fraction") < mean(3, "view_visibility_fraction")
    # more constrained: L3 vs L1 and L4 vs L2
    assert mean(3, "free_config_fraction") < mean(1, "free_config_fraction") - 0.05
    assert mean(4, "free_config_fraction") < mean(2, "free_config_fraction") - 0.05


def test_certification_is_deterministic(default_set):
    cs = default_set[4][3]
    again = certified_scene(4, 3, 0)
    assert again.scene == cs.scene
    assert again.certificate.view_visibility_fraction == cs.certificate.view_visibility_fraction
    assert again.certificate.free_config_fraction == cs.certificate.free_config_fraction


def test_another_seed_gives_another_set():
    a, b = certified_scene(1, 0, 0), certified_scene(1, 0, 1)
    assert a.scene.to_json() != b.scene.to_json()


def test_found_grasp_is_collision_free_and_on_target(default_set):
    cs = default_set[3][0]
    w = World(cs.scene)
    try:
        g = find_grasp(w)
        assert g is not None
        assert not w.in_collision(g.q_grasp, 0.08) and not w.in_collision(g.q_pregrasp, 0.08)
        assert np.linalg.norm(g.T_world_tcp[:2, 3] - np.array(cs.scene.target.pos[:2])) < 1e-9
    finally:
        w.close()


def test_a_visible_target_fails_certification(default_set):
    from dataclasses import replace

    scene = default_set[1][0].scene
    no_occluders = replace(scene, clutter=tuple(p for p in scene.clutter if not p.name.startswith("occluder")))
    w = World(no_occluders)
    try:
        vis = w.target_visibility(w.robot.q_home)
        cert = certify(no_occluders, world=w)
    finally:
        w.close()
    if vis >= 0.05:  # nothing else hides it
        assert cert.failure is CertFailure.TARGET_VISIBLE_AT_START


def test_bad_arguments():
    with pytest.raises(CompassInputError, match="level 0"):
        certified_scene(0, 0)
    with pytest.raises(CompassInputError, match="index -1"):
        certified_scene(1, -1)
    with pytest.raises(CompassInputError, match="seed -3"):
        certified_scene(1, 0, -3)
