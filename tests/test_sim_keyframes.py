"""The keyframe rule: which camera poses along a motion are rendered."""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.executor import ExecutorConfig, execute, interpolate, sample_times
from compass_manip.sim.keyframes import KeyframeRule, select_keyframes, turn_angle
from compass_manip.sim.world import World
from compass_manip.trial.config import SensingConfig
from compass_manip.types import Trajectory


def _pose(x: float, yaw: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = [[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]]
    T[0, 3] = x
    return T


def test_hand_built_trajectory():
    rule = KeyframeRule(min_move_m=0.1, min_turn_rad=0.5, max_interval_s=1.5)
    t = 0.1 * np.arange(30)
    # 0-5: slides 4 cm per sample; 6-8: turns 0.2 rad per sample in place; 9-29: still
    x = np.minimum(0.04 * np.arange(30), 0.2)
    yaw = np.clip(0.2 * (np.arange(30) - 5), 0.0, 0.6)
    poses = np.stack([_pose(a, b) for a, b in zip(x, yaw)])
    # 3: 12 cm from sample 0; 8: turned 0.6 rad from sample 3 (moved 8 cm only);
    # 23: 1.5 s after sample 8 with the camera still
    assert select_keyframes(t, poses, rule).tolist() == [3, 8, 23]
    # a camera that never moves gets one frame per max_interval_s
    still = np.repeat(_pose(0.0, 0.0)[None], 30, axis=0)
    assert select_keyframes(t, still, rule).tolist() == [15]
    assert turn_angle(_pose(0, 0.3)[:3, :3], _pose(0, -0.4)[:3, :3]) == pytest.approx(0.7)


def test_bad_rules_are_rejected():
    with pytest.raises(CompassInputError, match="min_move_m"):
        KeyframeRule(min_move_m=-0.1)
    with pytest.raises(CompassInputError, match="max_interval_s"):
        KeyframeRule(max_interval_s=float("nan"))
    with pytest.raises(CompassInputError, match="keyframes"):
        SensingConfig(keyframes=3.0)
    with pytest.raises(CompassInputError, match="keyframes"):
        ExecutorConfig(keyframes="yes")


@pytest.fixture(scope="module")
def world():
    w = World(certified_scene(3, 1, 0).scene)
    yield w
    w.close()


def test_executor_renders_the_rule_s_samples(world):
    rule = KeyframeRule(min_move_m=0.05, min_turn_rad=0.3, max_interval_s=0.8)
    q1 = Q_HOME + np.array([0.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.8])
    traj = Trajectory(np.array([0.0, 1.0, 3.0]), np.stack([Q_HOME, Q_HOME + 0.5 * (q1 - Q_HOME), q1]))
    res = execute(world, traj, ExecutorConfig(keyframes=rule, frame_rate=3.0), t0=5.0)
    assert res.completed and not res.contacts
    ts = sample_times(traj, 0.005)
    poses = []
    for q in interpolate(traj, ts):
        world.set_q(q)
        poses.append(world.T_world_cam())
    want = [i for i in select_keyframes(ts, np.stack(poses), rule) if ts[i] < traj.t[-1]]
    assert len(want) >= 3
    assert [f.t for f in res.frames] == pytest.approx([5.0 + ts[i] for i in want])
    for f, i in zip(res.frames, want):
        assert np.allclose(f.T_world_cam, poses[i])
