"""The grasp-only harness's near-field scan (sim/near_field.py): greedy views that shrink the
unknown space of the box around the base, each reached along a contact-free straight way,
stopping when no view gains enough; its config rejects bad values."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.exploration.nfa import safe_box_map
from compass_manip.mapping.observe import integrate_observation
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import GRIPPER_MAX_WIDTH
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.grasp_only import near_field_configs
from compass_manip.sim.near_field import NearFieldScanConfig, near_field_scan, scan_candidates
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
from compass_manip.sim.world import World

RED = (0.9, 0.05, 0.05, 1.0)


@pytest.fixture(scope="module")
def world():
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.80, 0.3, 0.80))
    target = Primitive("target", "box", (0.02, 0.02, 0.06), (0.60, 0.0, 0.36), 0.2, RED, True, 0.08)
    w = World(SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target))
    yield w
    w.close()


def _unknown_in_box(occ, world, config):
    base = np.asarray(world.robot.base_pos)
    m = safe_box_map(occ, base + config.box_min, base + config.box_max)
    return int(np.count_nonzero(m.state == VoxelState.UNKNOWN))


def _home_map(world, spheres):
    occ = OccupancyMap(MapConfig())
    integrate_observation(occ, world.render(np.asarray(world.robot.q_home), rgb=False, seg=False), spheres,
                          world.camera.depth_max)
    return occ


def test_scan_views_are_reachable_and_see_more_of_the_box_than_random_views(world):
    spheres = panda_sphere_model(world.robot)
    config = NearFieldScanConfig(n_candidates=40, max_views=4)
    occ = _home_map(world, spheres)
    before = _unknown_in_box(occ, world, config)
    frames, views = near_field_scan(world, occ, spheres, np.random.default_rng(1), config)
    after = _unknown_in_box(occ, world, config)
    assert len(frames) == len(views) == 4 and after < before
    q_home = np.asarray(world.robot.q_home)
    for q in views:  # each view reached along a straight way free of ground-truth contacts
        for s in np.linspace(0.0, 1.0, 21):
            assert not world.in_collision(q_home + s * (q - q_home), GRIPPER_MAX_WIDTH)
    # as many random near-field views (the harness's other views) leave more of the box unseen
    rand = _home_map(world, spheres)
    for q in near_field_configs(world, np.random.default_rng(1), 4):
        integrate_observation(rand, world.render(q, rgb=False, seg=False), spheres, world.camera.depth_max)
    assert after < _unknown_in_box(rand, world, config)


def test_scan_stops_when_no_view_gains_enough(world):
    spheres = panda_sphere_model(world.robot)
    occ = _home_map(world, spheres)
    frames, views = near_field_scan(world, occ, spheres, np.random.default_rng(2),
                                    NearFieldScanConfig(n_candidates=10, min_gain=10 ** 8))
    assert frames == [] and views == []


def test_candidates_stay_in_the_limits_and_keep_the_body_near_home():
    from compass_manip.robot.model import Q_MAX, Q_MIN
    config = NearFieldScanConfig()
    q_home = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785])
    Q = scan_candidates(q_home, 200, np.random.default_rng(3), config)
    assert np.all(Q >= Q_MIN) and np.all(Q <= Q_MAX)
    assert np.all(np.abs(Q[:, 0] - q_home[0]) <= config.yaw_range + 1e-9)
    assert np.all(Q[:, 2] == q_home[2])  # joint 3 is held


@pytest.mark.parametrize("kw", [dict(n_candidates=0), dict(max_views=-1), dict(box_min=(0.0, 0.0, 2.0))])
def test_config_rejects_bad_values(kw):
    with pytest.raises(CompassInputError):
        NearFieldScanConfig(**kw)
