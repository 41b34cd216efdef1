"""FV's sequence depends on the cabinet only; GSE's tree nodes are valid and reachable;
every baseline decides a validated path on a real first view; one short oracle trial."""
from dataclasses import replace

import numpy as np
import pytest

from compass_manip.exploration.baselines import FV_CONFIG
from compass_manip.exploration.compass import CompassConfig
from compass_manip.exploration.fixed_views import FixedViewsMethod, fixed_view_poses
from compass_manip.exploration.gse import GSEConfig, grow_random_tree, node_scores
from compass_manip.exploration.registry import make_method
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.scenes import Primitive
from compass_manip.sim.world import World


def _first_frame(scene):
    world = World(scene)
    try:
        q0 = np.asarray(world.robot.q_home)
        return world.render(q0, seg=False), q0, world.camera.K
    finally:
        world.close()


@pytest.fixture(scope="module")
def setup():
    scene = certified_scene(1, 1, 0).scene
    frame, q0, K = _first_frame(scene)
    return scene, frame, q0, K


def test_fv_sequence_is_the_same_for_different_contents(setup):
    scene, frame, q0, K = setup
    # same cabinet, other contents: no clutter, the target moved and recoloured, an extra box
    c = scene.cabinet
    box = Primitive("extra", "box", (0.03, 0.03, 0.05), tuple(np.asarray(c.interior_min) + [0.08, 0.1, 0.05]))
    part = scene.target.parts[0]  # the target moved, recoloured and reduced to one part
    moved = Primitive("target", part.shape, part.size, tuple(np.asarray(part.pos) + [0.02, -0.05, 0.0]), part.yaw,
                      (0.2, 0.45, 0.8, 1.0))
    other = replace(scene, clutter=(box,), target=moved)
    frame2, _, _ = _first_frame(other)
    assert not np.array_equal(frame.depth, frame2.depth)  # the contents are seen differently
    a = FixedViewsMethod(scene.task(), CompassConfig().world, FV_CONFIG, np.random.default_rng(0), q0, K)
    b = FixedViewsMethod(other.task(), CompassConfig().world, FV_CONFIG, np.random.default_rng(7), q0, K)
    a.observe(frame.observation())
    b.observe(frame2.observation())
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_array_equal(a.view_index, b.view_index)
    for sa, sb in zip(a.view_solutions, b.view_solutions, strict=True):
        np.testing.assert_array_equal(sa, sb)
    assert len(a.view_index) >= 4
    # every view looks into the space from in front of its opening
    out = np.asarray(scene.task().space.outward)
    assert np.all(a.poses[:, :3, 2] @ out < -0.5)
    assert np.all((a.poses[:, :3, 3] - scene.task().space.opening_centre) @ out > 0.1)
    # and visits it in order: the first decision goes to the first reachable view
    d = a.decide()
    assert d.path is not None and a.world.checker.path_valid(d.path, 0.005)
    assert d.stats["view"] == a.view_index[d.plans_attempted - 1]
    np.testing.assert_allclose(a.world.kin.T_world_cam(d.path[-1]), a.poses[d.stats["view"]], atol=1e-6)


def test_gse_tree_nodes_are_valid_and_reachable(setup):
    scene, frame, q0, K = setup
    m = make_method("gse", scene.task(), CompassConfig(), np.random.default_rng(0), q0, K)
    m.observe(frame.observation())
    for local_range in (0.6, np.inf):  # local box and the whole joint range
        tree = grow_random_tree(m.world, replace(GSEConfig(), local_range=local_range), np.random.default_rng(3))
        # from the first frame most of the joint range is unknown space: the whole-range tree
        # grows a few nodes only (3 here since the start shell stays out of the space's box)
        assert tree.count > (5 if local_range < np.inf else 2)
        assert np.all(m.world.checker.are_valid(tree.q))
        for k in range(tree.count):  # each node's path is its parents' edges: every edge checked once
            path = tree.path_to(k)
            assert np.allclose(path[0], m.world.q) and np.allclose(path[-1], tree.q[k])
            assert k == 0 or np.array_equal(path[-2], tree.q[tree.parent[k]])
            assert k == 0 or m.world.checker.edge_valid(tree.q[tree.parent[k]], tree.q[k], 0.005), k
    d = m.decide()
    assert d.path is not None and m.world.checker.path_valid(d.path, 0.005)
    assert d.stats["stage"] == "local" and d.stats["G"] >= GSEConfig().min_gain


def test_gse_tree_grows_as_one_extend_per_uniform_draw(setup):
    """grow_random_tree's compiled loop gives the tree of `extend(rng.uniform(lo, hi))` per
    iteration, node for node, and leaves the generator where those draws leave it, also
    when the capacity ends the growth early."""
    from compass_manip.motion.tree import JointTree
    from compass_manip.robot.model import Q_MAX, Q_MIN

    scene, frame, q0, K = setup
    m = make_method("gse", scene.task(), CompassConfig(), np.random.default_rng(0), q0, K)
    m.observe(frame.observation())
    for config in (GSEConfig(), replace(GSEConfig(), capacity=8)):
        rng_fast, rng_ref = np.random.default_rng(11), np.random.default_rng(11)
        fast = grow_random_tree(m.world, config, rng_fast)
        ref = JointTree(m.world.q, m.world.checker, capacity=config.capacity, step=config.step, res=config.res)
        lo = np.maximum(Q_MIN, m.world.q - config.local_range)
        hi = np.minimum(Q_MAX, m.world.q + config.local_range)
        for _ in range(config.iterations):
            if ref.count >= config.capacity - 2:
                break
            ref.extend(rng_ref.uniform(lo, hi), connect=False)
        assert fast.count == ref.count > 1
        assert np.array_equal(fast.q, ref.q) and np.array_equal(fast.parent, ref.parent)
        assert fast.edge_checks == ref.edge_checks
        assert rng_fast.random() == rng_ref.random()


def test_gse_score_is_nbvp_discounted_gain():
    np.testing.assert_allclose(node_scores([10, 10, 0], [0.0, 2.0, 1.0], 0.5), [10, 10 * np.exp(-1.0), 0])
    np.testing.assert_allclose(node_scores([3, 5], [4.0, 9.0], 0.0), [3, 5])


@pytest.mark.parametrize("name", ["ig", "ig-occlusion"])
def test_ig_decides_a_valid_path_to_its_best_view(setup, name):
    scene, frame, q0, K = setup
    m = make_method(name, scene.task(), CompassConfig(), np.random.default_rng(0), q0, K)
    m.observe(frame.observation())
    d = m.decide()
    assert d.path is not None and m.world.checker.path_valid(d.path, 0.005)
    assert d.plans_attempted >= d.plans_succeeded == 1
    assert d.stats["information"] >= m.config.min_information


def test_fv_poses_do_not_depend_on_the_target_query(setup):
    task = setup[0].task()
    other = replace(task, target=replace(task.target, colour="blue", shape="box"))
    np.testing.assert_array_equal(fixed_view_poses(task, FV_CONFIG), fixed_view_poses(other, FV_CONFIG))


def test_oracle_trial_finds_the_target_on_level_1():
    from compass_manip.trial.config import GraspTrialConfig, TrialConfig
    from compass_manip.trial.runner import TrialSpec, run_trial

    r = run_trial(TrialSpec("oracle", 1, 0, 0, 0), TrialConfig(grasp=GraspTrialConfig(enabled=False)))  # find-only
    assert r.failure is None and r.true_detection, r
    assert r.decisions >= 1 and r.mpsr is not None and r.mpsr > 0


@pytest.mark.parametrize("name", ["fv", "ig", "gse", "oracle"])
def test_baselines_escape_a_start_the_map_has_made_invalid(setup, name):
    """A voxel seen occupied between the fingers makes the start configuration invalid on
    the map: every baseline's first decision is COMPASS's escape, a short motion to a valid
    configuration, not a stop."""
    from compass_manip.mapping.occupancy import VoxelState

    from compass_manip.trial.oracle_method import make_oracle_method

    scene, frame, q0, K = setup
    if name == "oracle":  # the reference, told the target's position by the runner
        m = make_oracle_method(scene, scene.task(), CompassConfig(), np.random.default_rng(0), q0, K)
    else:
        m = make_method(name, scene.task(), CompassConfig(), np.random.default_rng(0), q0, K)
    m.observe(frame.observation())
    tcp = m.world.kin.T_world_tcp(q0)[:3, 3]
    m.world.occ.set_voxels(m.world.occ.world_to_voxel(tcp[None]), VoxelState.OCCUPIED)
    m.world._checker = None  # the map changed outside observe()
    assert not m.world.checker.is_valid(q0)
    d = m.decide()
    assert d.stop is None and d.stats.get("escape") == 1
    np.testing.assert_allclose(d.path[0], q0)
    assert m.world.checker.is_valid(d.path[-1])
