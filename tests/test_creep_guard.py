"""The creep guard (`world_model.WorldModel.creeps`): the swept-space margin lets each motion
end a few cm beyond where the arm has been, in unknown space; without the guard, motion after
motion carries the arm into space nobody has seen. The guard refuses any new motion whose
spheres cover unknown voxels the arm has not covered, and lets it retrace its way."""
from dataclasses import replace

import numpy as np

from compass_manip.exploration.world_model import WorldModel, WorldModelConfig
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.robot.model import RobotConfig

Q_HOME = np.asarray(RobotConfig().q_home, float)


def shoulder_steps(q: np.ndarray, n: int, step: float = 0.01) -> list[np.ndarray]:
    """n paths that each lower the shoulder (joint 2) by step [rad]: the hand goes forward."""
    out = []
    for _ in range(n):
        nxt = q.copy()
        nxt[1] += step
        out.append(np.stack([q, nxt]))
        q = nxt
    return out


def sphere_travel(wm: WorldModel, q: np.ndarray) -> float:
    """Farthest any sphere centre lies from where it was at home [m]."""
    c = wm.spheres.sphere_centers(np.stack([Q_HOME, q]))
    return float(np.linalg.norm(c[1] - c[0], axis=1).max())


def test_without_the_guard_checker_valid_motions_creep_far_into_unknown_space():
    wm = WorldModel(Q_HOME, WorldModelConfig(creep_guard=False))
    q = Q_HOME
    for path in shoulder_steps(Q_HOME, 60):
        if not wm.checker.path_valid(path, 0.01):
            break
        assert not wm.creeps(path)  # the guard is off
        wm.add_swept(path)
        q = path[-1]
    # every 1 cm step was valid on the checker (5 cm margin around the way so far) although
    # the map has seen nothing: the hand went 25 cm, beyond the start shell's 10 cm
    assert q[1] - Q_HOME[1] > 0.5
    assert sphere_travel(wm, q) > 0.25


def test_the_guard_refuses_the_first_step_into_unknown_space_that_the_checker_allows():
    wm = WorldModel(Q_HOME)
    steps = shoulder_steps(Q_HOME, 60)
    q = Q_HOME
    refused = None
    for i, path in enumerate(steps):
        assert wm.checker.path_valid(path, 0.01)
        if wm.creeps(path):
            refused = i
            break
        wm.add_swept(path)
        q = path[-1]
    assert refused is not None  # within the start shell (10 cm) and no farther
    assert 0.02 < sphere_travel(wm, q) < 0.12


def test_executed_paths_and_their_reverse_never_creep():
    wm = WorldModel(Q_HOME)
    rng = np.random.default_rng(5)
    q = Q_HOME
    for _ in range(4):
        path = np.vstack([q, q + np.cumsum(rng.uniform(-0.03, 0.03, (3, 7)), axis=0)])
        wm.add_swept(path)  # as if executed (proprioception: the arm was there)
        assert not wm.creeps(path) and not wm.creeps(path[::-1])
        q = path[-1]
    assert not wm.creeps(q[None])  # resting where it stands


def test_seen_free_space_and_assumed_free_space_may_be_entered():
    wm = WorldModel(Q_HOME)
    path = shoulder_steps(Q_HOME, 1, 0.3)[0]
    assert wm.creeps(path)
    wm.occ.state[wm.occ.state == VoxelState.UNKNOWN] = VoxelState.FREE
    wm._untouched = None  # as after an observation
    assert not wm.creeps(path)
    wm2 = WorldModel(Q_HOME)
    wm2.assumed_free[...] = True
    assert not wm2.creeps(path)


def test_touched_space_is_the_spheres_grown_by_touch_margin_sampled_every_touch_step():
    config = WorldModelConfig()
    wm = WorldModel(Q_HOME, config)
    before = wm.touched.copy()
    path = shoulder_steps(Q_HOME, 1, 0.3)[0]
    wm.add_swept(path)
    grown = wm.touched & ~before
    assert grown.any()
    wm_small = WorldModel(Q_HOME, replace(config, touch_margin=0.0))
    wm_small.add_swept(path)
    assert (wm_small.touched & ~before).sum() < grown.sum()
    # the swept space (5 cm margin) covers more than what the guard lets a motion enter
    assert (wm.swept & ~wm.touched).any() and not (wm.touched & ~wm.swept).any()


def test_the_anchor_lets_a_motion_cover_unknown_voxels_next_to_seen_free_space_only():
    config = WorldModelConfig(creep_anchor=0.02)
    path = shoulder_steps(Q_HOME, 1, 0.3)[0]
    wm = WorldModel(Q_HOME, config)
    covered = np.zeros(wm.occ.shape, bool)
    from compass_manip.mapping.distance import mark_robot
    mark_robot(covered, wm.occ, wm.spheres, wm._touch_samples(path), config.touch_margin)
    new = covered & ~wm.touched
    assert new.any() and wm.creeps(path)
    # seen free: every other plane of voxels across x; every unknown voxel lies next to one
    x = np.arange(wm.occ.shape[0])
    wm.occ.state[x % 2 == 0] = VoxelState.FREE
    wm._untouched = None
    assert not wm.creeps(path)
    # every fourth plane: the planes x % 4 == 2 lie two voxels (4 cm) from seen free space
    assert np.any(new[x % 4 == 2])
    wm.occ.state[...] = VoxelState.UNKNOWN
    wm.occ.state[x % 4 == 0] = VoxelState.FREE
    wm._untouched = None
    assert wm.creeps(path)


def test_robot_covers_any_equals_marking_the_spheres_and_intersecting():
    from compass_manip.mapping.distance import mark_robot, robot_covers_any
    from compass_manip.motion.timing import densify
    from compass_manip.robot.model import Q_MAX, Q_MIN
    wm = WorldModel(Q_HOME)
    rng = np.random.default_rng(11)
    answers = set()
    for trial in range(12):
        mask = rng.random(wm.occ.shape) < (0.0005 if trial % 2 else 0.00005)
        path = np.vstack([Q_HOME, Q_HOME + rng.uniform(-0.4, 0.4, 7) * [1, 1, 1, 0, 1, 0, 1]])
        margin = rng.uniform(0.0, 0.03)
        covered = np.zeros(wm.occ.shape, bool)
        mark_robot(covered, wm.occ, wm.spheres, path, margin)
        expected = bool(np.any(covered & mask))
        assert robot_covers_any(mask, wm.occ, wm.spheres, path, margin) == expected
        answers.add(expected)
    assert answers == {True, False}


def test_the_guarded_checker_keeps_the_resting_configuration_and_refuses_what_the_guard_refuses():
    wm = WorldModel(Q_HOME)
    steps = shoulder_steps(Q_HOME, 60)
    for path in steps:  # walk to the edge of the start shell, as the guard lets the arm
        if wm.creeps(path):
            break
        wm.add_swept(path)
    q = wm.q
    far = q.copy()
    far[1] += 0.3  # 30 cm of shoulder: far into space the arm has never covered
    assert wm.checker.is_valid(q) and wm.guarded_checker.is_valid(q)  # the resting configuration
    assert wm.creeps(np.stack([q, far]))
    assert not wm.guarded_checker.is_valid(far)  # unknown, uncovered: unsafe on the guarded checker
    nxt = q.copy()
    nxt[1] += 0.01  # the step the guard refuses: the checker's swept margin allows it, the guarded one not
    assert wm.creeps(np.stack([q, nxt]))
    assert wm.checker.is_valid(nxt) and not wm.guarded_checker.is_valid(nxt)
    back = np.stack([q, Q_HOME])  # back along covered space: the same verdict as the checker's
    assert wm.guarded_checker.path_valid(back, 0.01) == wm.checker.path_valid(back, 0.01)
    assert wm.guarded_checker.path_valid(back, 0.01)


def test_motions_valid_on_the_guarded_checker_creep_only_near_where_the_arm_rests():
    from compass_manip.exploration.world_model import guard_root_band
    from compass_manip.mapping.distance import mark_robot, robot_covers_any
    from compass_manip.motion.timing import densify
    from compass_manip.robot.model import Q_MAX, Q_MIN
    wm = WorldModel(Q_HOME)
    rng = np.random.default_rng(3)
    near_q = np.zeros(wm.occ.shape, bool)
    mark_robot(near_q, wm.occ, wm.spheres, wm.q[None], guard_root_band(wm.config.validity, wm.occ.resolution))
    outside_band = wm.untouched & ~near_q
    valid = 0
    for _ in range(300):
        goal = np.clip(Q_HOME + rng.uniform(-0.25, 0.25, 7), Q_MIN, Q_MAX)
        path = np.stack([Q_HOME, goal])
        if wm.guarded_checker.path_valid(path, 0.01):
            valid += 1
            Q = densify(path, 0.01)
            assert not robot_covers_any(outside_band, wm.occ, wm.spheres, Q, wm.config.touch_margin)
    assert valid > 5  # the band leaves room to move (the test is not vacuous)


def test_the_guard_screen_keeps_the_best_nodes_the_guard_admits_in_order():
    from types import SimpleNamespace
    from compass_manip.exploration.compass import CompassConfig, CompassMethod
    from compass_manip.motion.tree import JointTree
    from compass_manip.robot.model import Q_MAX, Q_MIN
    wm = WorldModel(Q_HOME)
    for path in shoulder_steps(Q_HOME, 20):  # executed (as without the guard): the swept margin
        if not wm.checker.path_valid(path, 0.01):  # outgrows what was touched
            break
        wm.add_swept(path)
    tree = JointTree(wm.q, wm.checker, capacity=400, step=0.05, res=0.005)  # on the checker, as the tree grows
    rng = np.random.default_rng(2)
    for _ in range(300):
        tree.extend(np.clip(wm.q + rng.uniform(-0.3, 0.3, 7), Q_MIN, Q_MAX))
    assert tree.count > 30
    order = np.arange(1, tree.count)
    rng.shuffle(order)  # any utility order
    config = replace(CompassConfig(), guard_screen=60)
    method = SimpleNamespace(world=wm, config=config)
    stats = {}
    kept = CompassMethod._guard_screened(method, SimpleNamespace(tree=tree), order, stats)
    creeping = [int(k) for k in order[:60] if wm.creeps(tree.path_to(int(k)))]
    admitted = [int(k) for k in order[:60] if int(k) not in creeping]
    assert creeping and admitted  # both kinds among the 60 best
    assert not any(wm.creeps(tree.path_to(int(k))) for k in kept)
    # the best admitted nodes, in utility order, max_attempts of them; every node passed over crept
    assert list(kept) == admitted[: config.max_attempts]
    tested = list(order[: list(order).index(kept[-1]) + 1])
    assert stats["creep_screened"] == sum(int(k) in creeping for k in tested)
