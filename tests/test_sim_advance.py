"""Conservative advancement of the contact checks (sim.advance): the same contacts as a test
at every sample, on constructed near misses and hits, with fewer tests when far."""
import mujoco
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.advance import AdvanceConfig, ClearanceModel, MotionBound
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.executor import ExecutorConfig, execute, interpolate, sample_times
from compass_manip.sim.world import World
from compass_manip.types import Trajectory

EXACT = ExecutorConfig(frame_rate=0.0)
FAST = ExecutorConfig(frame_rate=0.0, advance=AdvanceConfig())


@pytest.fixture(scope="module")
def world():
    w = World(certified_scene(3, 1, 0).scene)
    yield w
    w.close()


class CountingWorld:
    """The world with its contact tests counted."""

    def __init__(self, world):
        self.world, self.tests = world, 0

    def __getattr__(self, name):
        return getattr(self.world, name)

    def contacts(self, *args, **kwargs):
        self.tests += 1
        return self.world.contacts(*args, **kwargs)


def _same(a, b) -> bool:
    return (a.completed == b.completed and a.t_end == b.t_end and np.array_equal(a.q_end, b.q_end)
            and [(c.t, c.q.tobytes(), c.contact) for c in a.contacts]
            == [(c.t, c.q.tobytes(), c.contact) for c in b.contacts])


def _run_both(world, traj, **kw):
    import dataclasses
    out = []
    for cfg in (EXACT, FAST):
        counted = CountingWorld(world)
        res = execute(counted, traj, dataclasses.replace(cfg, **kw))
        out.append((res, counted.tests))
    return out


def _swing():
    """Joint 1 swung into the obstacles beside the base (a hit, as in test_sim_executor)."""
    q1 = Q_HOME.copy()
    q1[0], q1[1] = 2.5, 0.3
    return Trajectory(np.array([0.0, 3.0]), np.stack([Q_HOME, q1]))


def test_rates_bound_every_geom_motion(world):
    rng = np.random.default_rng(3)
    model = ClearanceModel(world, include_self=True)
    lo, hi = world.model.jnt_range[:7, 0], world.model.jnt_range[:7, 1]
    for _ in range(30):
        qa = rng.uniform(lo, hi)
        qb = np.clip(qa + rng.normal(0.0, 0.3, 7), lo, hi)
        world.set_q(qa)
        rates = model.geom_rates()
        pa = world.data.geom_xpos[model.robot].copy()
        world.set_q(qb)
        moved = np.linalg.norm(world.data.geom_xpos[model.robot] - pa, axis=1)
        bound = rates @ np.abs(qb - qa)
        assert np.all(moved <= bound + 1e-12)
        # the bound is for any point of the geom: the centre moves at most bound - radius * sum|dq|
        # over the joints that move it
        turned = (rates > 0) @ np.abs(qb - qa)
        assert np.all(moved <= bound - world.model.geom_rbound[model.robot] * turned + 1e-9)


def test_clearances_equal_brute_force_distances(world):
    m, d = world.model, world.data
    model = ClearanceModel(world, include_self=True)
    rng = np.random.default_rng(4)
    fromto = np.zeros(6)
    for _ in range(5):
        world.set_q(np.clip(Q_HOME + rng.normal(0.0, 0.4, 7), m.jnt_range[:7, 0], m.jnt_range[:7, 1]))
        geom, pairs = model.clearances(model.scene_boxes())
        cap = model.config.cap_m
        brute = np.full(len(model.robot), cap)
        for i, o in model.scene_pairs:
            brute[i] = min(brute[i], mujoco.mj_geomDistance(m, d, int(model.robot[i]), int(o), cap, fromto))
        assert geom == pytest.approx(brute, abs=1e-9)
        brute_pairs = [mujoco.mj_geomDistance(m, d, int(a), int(b), cap, fromto) for a, b in model.self_pairs]
        assert pairs == pytest.approx(np.array(brute_pairs), abs=1e-9)


def test_hit_gives_the_same_first_contact(world):
    for stop in (True, False):
        (exact, n_exact), (fast, n_fast) = _run_both(world, _swing(), stop_on_contact=stop)
        assert exact.contacts and _same(exact, fast)
        assert n_fast < n_exact  # the first part of the swing is far from everything


def test_near_miss_and_grazing_hit(world):
    """A motion ending at the last contact-free sample before the swing's first contact
    (a near miss: one check step short of the obstacle), and one ending a quarter step
    further (the first penetration the exact test sees), both as the exact test reports."""
    traj = _swing()
    ts = sample_times(traj, EXACT.check_step)
    qs = interpolate(traj, ts)
    first = next(k for k, q in enumerate(qs) if world.contacts(q, include_self=True))
    lo = qs[first - 1]
    for frac in (0.25, 0.5, 1.0):
        q_end = lo + frac * (qs[first] - lo)
        near = Trajectory(np.array([0.0, 3.0]), np.stack([Q_HOME, q_end]))
        (exact, _), (fast, n_fast) = _run_both(world, near)
        assert _same(exact, fast)
    miss = Trajectory(np.array([0.0, 3.0]), np.stack([Q_HOME, lo]))
    (exact, n_exact), (fast, n_fast) = _run_both(world, miss)
    assert exact.completed and not exact.contacts and _same(exact, fast) and n_fast < n_exact
    world.set_q(lo)
    model = ClearanceModel(world, include_self=True)
    geom, _ = model.clearances(model.scene_boxes())
    assert 0.0 < geom.min() < 0.02  # it is a near miss: within two centimetres of the obstacle


def test_random_motions_report_the_same_contacts(world):
    rng = np.random.default_rng(11)
    m = world.model
    lo, hi = m.jnt_range[:7, 0] + 0.01, m.jnt_range[:7, 1] - 0.01
    hits = 0
    for _ in range(12):
        qa = np.clip(Q_HOME + rng.normal(0.0, 0.4, 7), lo, hi)
        qb = np.clip(qa + rng.normal(0.0, 0.4, 7), lo, hi)
        traj = Trajectory(np.array([0.0, 1.0, 2.5]), np.stack([qa, 0.5 * (qa + qb), qb]))
        for stop in (True, False):
            (exact, _), (fast, _) = _run_both(world, traj, stop_on_contact=stop)
            assert _same(exact, fast)
        hits += bool(exact.contacts)
    assert 0 < hits < 12  # both kinds were tried


def test_far_motion_proves_most_samples_free(world):
    q1 = Q_HOME + np.array([0.0, 0.0, 0.0, 0.0, 0.3, -0.2, 0.4])
    traj = Trajectory(np.array([0.0, 2.0]), np.stack([Q_HOME, q1]))
    ts = sample_times(traj, EXACT.check_step)
    world.set_q(Q_HOME)
    bound = MotionBound(ClearanceModel(world, include_self=True), interpolate(traj, ts))
    assert bound.proven_until(0) > 5
    (exact, n_exact), (fast, n_fast) = _run_both(world, traj)
    assert _same(exact, fast) and n_fast * 3 < n_exact


def test_bad_advance_configs_are_rejected():
    with pytest.raises(CompassInputError, match="slack_m"):
        AdvanceConfig(slack_m=0.0)
    with pytest.raises(CompassInputError, match="backoff_max"):
        AdvanceConfig(backoff_max=0)
    with pytest.raises(CompassInputError, match="advance"):
        ExecutorConfig(advance=0.1)


def _sample_times_reference(traj, check_step):
    """The executor's sampling as it was written first: one np.linspace per segment."""
    ts = [traj.t[:1]]
    for i in range(len(traj.t) - 1):
        n = max(1, int(np.ceil(np.max(np.abs(traj.q[i + 1] - traj.q[i])) / check_step)))
        ts.append(np.linspace(traj.t[i], traj.t[i + 1], n + 1)[1:])
    return np.concatenate(ts)


def test_vectorised_sample_times_equal_linspace_per_segment():
    rng = np.random.default_rng(5)
    for _ in range(200):
        m = int(rng.integers(1, 30))
        t = np.cumsum(rng.uniform(1e-4, 0.5, m)) + rng.uniform(-5.0, 100.0)
        q = np.cumsum(rng.normal(0.0, rng.choice([1e-4, 0.01, 0.1]), (m, 7)), axis=0)
        traj = Trajectory(t, q)
        step = float(rng.choice([0.001, 0.005, 0.05]))
        assert np.array_equal(sample_times(traj, step), _sample_times_reference(traj, step))


def test_robot_pairs_only_gives_every_contact_in_order(world):
    """`World.contacts` with MuJoCo testing only the robot's pairs equals the test of every
    pair (the same contacts in the same order), and leaves the model's types as they were."""
    rng = np.random.default_rng(12)
    m = world.model
    lo, hi = m.jnt_range[:7, 0] + 0.01, m.jnt_range[:7, 1] - 0.01
    types = m.geom_contype.copy()
    hits = 0
    try:
        for _ in range(150):
            q = np.clip(Q_HOME + rng.normal(0.0, 0.8, 7), lo, hi)
            fw = float(rng.uniform(0.0, 0.08))
            for include_self in (True, False):
                world.robot_pairs_only = False
                full = world.contacts(q, fw, include_self=include_self)
                world.robot_pairs_only = True
                fast = world.contacts(q, fw, include_self=include_self)
                assert fast == full
                hits += bool(full)
            assert np.array_equal(m.geom_contype, types)
    finally:
        world.robot_pairs_only = True
    assert 20 < hits < 280  # both contact and free states were compared
