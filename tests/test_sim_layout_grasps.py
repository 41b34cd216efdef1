"""The per-layout grasp chains: the same answers as checking every obstacle draw in full."""
from dataclasses import replace

import numpy as np
import pytest

from compass_manip.robot.model import Q_MAX, Q_MIN
from compass_manip.sim import oracle
from compass_manip.sim.certify import CertifyConfig, _grasps, regenerate
from compass_manip.sim.layout_grasps import KEEP_LAYOUTS, LayoutGrasps, _LAYOUTS, layout_grasps, layout_key
from compass_manip.sim.scenes import Primitive
from compass_manip.sim.world import World

MARGIN = 0.0


def _box(name, half, pos):
    return Primitive(name, "box", half, pos)


@pytest.fixture(scope="module")
def layout():
    """A level-3 candidate with valid grasps (seed 0, scene 2, sub-seed 13: certified), its IK
    solver and home."""
    scene = regenerate((0, 3, 2, 13))
    world = World(scene)
    ik = oracle.robot_ik(world.robot)
    home = np.asarray(world.robot.q_home)
    yield scene, world, ik, home
    world.close()


def _obstacle_sets(scene):
    """The scene's own draw, other blind draws of its layout, a box over the target's approach
    (blocks grasps) and one far away (blocks none)."""
    t = np.asarray(scene.target.pos, float)
    sets = [scene.base_obstacles] + [regenerate((0, 3, 2, k)).base_obstacles for k in (12, 14)]
    sets.append((_box("base_block", (0.05, 0.12, 0.05), (t[0] - 0.2, t[1], t[2] + 0.1)),))
    sets.append((_box("base_far", (0.05, 0.05, 0.05), (-0.8, -0.8, 0.05)),))
    return sets


def test_first_valid_with_obstacles_equals_the_full_check(layout):
    scene, world, ik, home = layout
    shared = LayoutGrasps(scene, ik, home, 12, MARGIN)
    cands = oracle.grasp_candidates(scene)[:10]
    n_diff_sets = set()
    for obstacles in _obstacle_sets(scene):
        s = replace(scene, base_obstacles=obstacles)
        full = oracle.ground_truth_checker(s, margin=MARGIN)
        no_target = oracle.ground_truth_checker(s, exclude_target=True, margin=MARGIN)
        obs = oracle.obstacle_checker(s, MARGIN)
        w = World(s)
        try:
            found = []
            for T, _ in cands:
                sols = oracle.grasp_solutions(ik, T, home, 12)
                for use_world in (None, w):
                    want = oracle.first_valid_grasp(ik, T, sols, full, no_target, use_world)
                    got = shared.first_valid_with(T, obs, use_world)
                    assert (want is None) == (got is None)
                    if want is not None:
                        assert all(np.array_equal(a, b) for a, b in zip(want, got))
                found.append(want is not None)
            n_diff_sets.add(tuple(found))
        finally:
            w.close()
    assert len(n_diff_sets) >= 2  # the sets differ in what they leave: the check can fail
    # without obstacles: the layout's own answer
    wo = oracle.ground_truth_checker(scene, base_obstacles=False, margin=MARGIN)
    nt = oracle.ground_truth_checker(scene, exclude_target=True, base_obstacles=False, margin=MARGIN)
    for T, _ in cands:
        want = oracle.first_valid_grasp(ik, T, oracle.grasp_solutions(ik, T, home, 12), wo, nt)
        got = shared.first_valid_with(T, None)
        assert (want is None) == (got is None) and (want is None or np.array_equal(want[0], got[0]))


def test_obstacle_checker_and_layout_checker_together_are_the_full_checker(layout):
    scene, _, _, home = layout
    rng = np.random.default_rng(3)
    Q = np.clip(home + rng.uniform(-1.0, 1.0, (400, 7)), Q_MIN, Q_MAX)
    for obstacles in _obstacle_sets(scene):
        s = replace(scene, base_obstacles=obstacles)
        full = oracle.ground_truth_checker(s, margin=0.01).are_valid(Q)
        parts = (oracle.ground_truth_checker(s, base_obstacles=False, margin=0.01).are_valid(Q)
                 & oracle.obstacle_checker(s, 0.01).are_valid(Q))
        assert np.array_equal(full, parts)
    assert not full.all() and full.any()


def test_certify_grasp_counts_equal_the_full_recount(layout):
    """`certify._grasps` with the shared chains: the counts and grasps of checking each
    candidate three times in full (the code before the per-layout chains)."""
    scene, world, ik, home = layout
    cfg = CertifyConfig(max_grasp_candidates=8)
    found, n_with, n_without = _grasps(world, cfg, ik, True, MARGIN)
    full = oracle.ground_truth_checker(scene, margin=MARGIN)
    no_target = oracle.ground_truth_checker(scene, exclude_target=True, margin=MARGIN)
    wo = oracle.ground_truth_checker(scene, base_obstacles=False, margin=MARGIN)
    nt = oracle.ground_truth_checker(scene, exclude_target=True, base_obstacles=False, margin=MARGIN)
    want, w_with, w_without = [], 0, 0
    for T, deg in oracle.grasp_candidates(scene)[:8]:
        sols = oracle.grasp_solutions(ik, T, home, 12)
        g = oracle.first_valid_grasp(ik, T, sols, full, no_target, world)
        if g is not None:
            want.append((T, g))
        w_with += oracle.first_valid_grasp(ik, T, sols, full, no_target) is not None
        w_without += oracle.first_valid_grasp(ik, T, sols, wo, nt) is not None
    assert (n_with, n_without) == (w_with, w_without) and w_without >= 1
    assert len(found) == len(want)
    for f, (T, g) in zip(found, want):
        assert np.array_equal(f.T_world_tcp, T) and np.array_equal(f.q_grasp, g[0])
        assert np.array_equal(f.q_pregrasp, g[1]) and np.array_equal(f.q_lift, g[2])


def test_layouts_are_shared_by_their_draws_and_few_are_kept(layout):
    scene, _, ik, home = layout
    a = layout_grasps(scene, ik, home, 12, MARGIN)
    other_draw = regenerate((0, 3, 2, 12))
    assert layout_key(other_draw) == layout_key(scene) and other_draw.base_obstacles != scene.base_obstacles
    assert layout_grasps(other_draw, ik, home, 12, MARGIN) is a
    assert layout_grasps(scene, ik, home, 12, 0.01) is not a  # another margin: other chains
    for k in range(KEEP_LAYOUTS + 1):
        layout_grasps(regenerate((0, 3, 3 + k, 0)), ik, home, 12, MARGIN)
    assert len(_LAYOUTS) == KEEP_LAYOUTS and layout_grasps(scene, ik, home, 12, MARGIN) is not a
