"""Validity checking: conservative against MuJoCo contacts, primitives, grid, edges, input errors."""
import mujoco
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import R_to_quat, make_T, rot_x, rot_z
from compass_manip.motion.primitives import PrimitiveSet, box_distance, cylinder_distance, grid_clearance
from compass_manip.motion.validity import (
    DistanceGrid,
    ValidityChecker,
    ValidityConfig,
    config_valid_kernel,
)
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN, build_robot_spec
from compass_manip.robot.spheres import panda_sphere_model

BOXES = [
    (make_T(rot_z(0.3), [0.5, 0.1, 0.35]), [0.08, 0.25, 0.3]),
    (make_T(rot_z(-0.5), [-0.1, 0.55, 0.5]), [0.2, 0.05, 0.5]),
    (make_T(rot_x(0.4), [0.3, -0.5, 0.8]), [0.15, 0.1, 0.04]),
    (make_T(t=[0.0, 0.0, -0.05]), [1.5, 1.5, 0.05]),  # floor under the base
]
SPHERES = [(np.array([-0.45, -0.3, 0.4]), 0.12)]
CYLINDERS = [(make_T(rot_x(np.pi / 2), [0.0, -0.55, 0.3]), 0.06, 0.25)]


@pytest.fixture(scope="module")
def sm():
    return panda_sphere_model()


@pytest.fixture(scope="module")
def prims():
    return PrimitiveSet.from_lists(boxes=BOXES, spheres=SPHERES, cylinders=CYLINDERS)


def _scene():
    """Robot + the obstacles as MuJoCo geoms (ground truth for the conservativeness test)."""
    spec = build_robot_spec(actuators=False)
    G = mujoco.mjtGeom
    for i, (T, h) in enumerate(BOXES):
        spec.worldbody.add_geom(name=f"obs_box{i}", type=G.mjGEOM_BOX, size=list(h), pos=list(T[:3, 3]),
                                quat=list(R_to_quat(T[:3, :3])))
    for i, (c, r) in enumerate(SPHERES):
        spec.worldbody.add_geom(name=f"obs_sph{i}", type=G.mjGEOM_SPHERE, size=[r, 0, 0], pos=list(c))
    for i, (T, r, h) in enumerate(CYLINDERS):
        spec.worldbody.add_geom(name=f"obs_cyl{i}", type=G.mjGEOM_CYLINDER, size=[r, h, 0], pos=list(T[:3, 3]),
                                quat=list(R_to_quat(T[:3, :3])))
    m = spec.compile()
    obstacles = {g for g in range(m.ngeom) if m.geom(g).name.startswith("obs_")}
    return m, mujoco.MjData(m), obstacles


def _gt_env_contact(m, d, obstacles, q):
    d.qpos[:7] = q
    d.qpos[7:9] = 0.04
    mujoco.mj_kinematics(m, d)
    mujoco.mj_collision(m, d)
    base = m.body("panda_link0").id
    for c in d.contact[: d.ncon]:
        if (c.geom1 in obstacles) != (c.geom2 in obstacles):
            robot_geom = c.geom2 if c.geom1 in obstacles else c.geom1
            if m.geom_bodyid[robot_geom] != base:  # the base stands on the floor
                return True
    return False


def test_spheres_free_implies_no_ground_truth_contact(sm, prims):
    m, d, obstacles = _scene()
    vc = ValidityChecker(sm, obstacles=prims, config=ValidityConfig(check_self=False))
    Q = np.random.default_rng(0).uniform(Q_MIN, Q_MAX, (10_000, 7))
    free = vc.are_valid(Q)
    gt = np.array([_gt_env_contact(m, d, obstacles, q) for q in Q])
    assert not np.any(free & gt)
    assert gt.mean() > 0.2  # the scene is cluttered enough to matter
    assert free.mean() > 0.8 * (1 - gt.mean())  # and the spheres are not absurdly conservative


def test_self_collision_free_implies_no_ground_truth_self_contact(sm):
    m = build_robot_spec(actuators=False).compile()
    d = mujoco.MjData(m)
    vc = ValidityChecker(sm)
    Q = np.random.default_rng(1).uniform(Q_MIN, Q_MAX, (3000, 7))
    free = vc.are_valid(Q)
    n_gt = 0
    for q, f in zip(Q, free):
        d.qpos[:7] = q
        d.qpos[7:9] = 0.04
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        n_gt += d.ncon > 0
        assert not (f and d.ncon > 0)
    assert n_gt > 100


def test_grid_checker_is_conservative_wrt_voxelised_obstacles(sm, prims):
    res = 0.02
    origin = np.array([-1.0, -1.0, -0.12])
    n = (100, 100, 70)
    idx = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1).reshape(-1, 3)
    centres = origin + (idx + 0.5) * res
    unsafe = (prims.distance(centres) <= 0.5 * res * np.sqrt(3)).reshape(n)  # voxels touching obstacles
    grid = DistanceGrid.from_unsafe_mask(unsafe, origin, res)
    # lookup: lower bound on the distance to the unsafe voxel cubes, checked by brute force
    cubes = centres[unsafe.ravel()]
    rng = np.random.default_rng(2)
    pts = rng.uniform(origin - 0.3, origin + np.array(n) * res + 0.3, (400, 3))  # some outside
    for outside_free in (False, True):
        packed = (grid.dist, grid.origin, grid.resolution, True, outside_free)
        for p in pts:
            true = np.min(np.linalg.norm(np.maximum(np.abs(cubes - p) - 0.5 * res, 0.0), axis=1))
            assert grid_clearance(p, packed, 0.5 * np.sqrt(3) * res) <= true + 1e-9
    vc_grid = ValidityChecker(sm, grid=grid, config=ValidityConfig(check_self=False))
    vc_prim = ValidityChecker(sm, obstacles=prims, config=ValidityConfig(check_self=False))
    Q = rng.uniform(Q_MIN, Q_MAX, (5000, 7))
    g, p = vc_grid.are_valid(Q), vc_prim.are_valid(Q)
    assert not np.any(g & ~p)  # grid verdict free => primitive verdict free
    assert g.mean() > 0.5 * p.mean()


def test_outside_grid_is_unsafe_unless_flagged(sm):
    tiny = DistanceGrid(np.full((4, 4, 4), 1.0, np.float32), np.array([5.0, 5.0, 5.0]), 0.1)
    assert not ValidityChecker(sm, grid=tiny).is_valid(Q_HOME)
    assert ValidityChecker(sm, grid=tiny, config=ValidityConfig(outside_grid_free=True)).is_valid(Q_HOME)
    with pytest.raises(CompassInputError, match="resolution"):
        DistanceGrid(np.zeros((2, 2, 2)), np.zeros(3), 0.0)


def test_primitive_distances_hand_computed():
    R = rot_z(np.pi / 2)
    t = np.array([1.0, 0.0, 0.0])
    half = np.array([0.2, 0.1, 0.3])  # after the 90 deg yaw: 0.1 along x, 0.2 along y
    assert box_distance(np.array([1.5, 0.0, 0.0]), R, t, half) == pytest.approx(0.4)
    assert box_distance(np.array([1.0, 0.5, 0.0]), R, t, half) == pytest.approx(0.3)
    assert box_distance(np.array([1.0, 0.0, 0.0]), R, t, half) == pytest.approx(-0.1)
    assert box_distance(np.array([1.4, 0.6, 0.0]), R, t, half) == pytest.approx(0.5)
    Rc = rot_x(np.pi / 2)  # cylinder axis along world -y
    assert cylinder_distance(np.array([0.0, 0.0, 0.5]), Rc, np.zeros(3), 0.1, 0.3) == pytest.approx(0.4)
    assert cylinder_distance(np.array([0.0, 0.7, 0.0]), Rc, np.zeros(3), 0.1, 0.3) == pytest.approx(0.4)
    assert cylinder_distance(np.array([0.0, 0.6, 0.5]), Rc, np.zeros(3), 0.1, 0.3) == pytest.approx(0.5)
    assert cylinder_distance(np.zeros(3), Rc, np.zeros(3), 0.1, 0.3) == pytest.approx(-0.1)
    ps = PrimitiveSet.from_lists(spheres=[(np.zeros(3), 0.5)], boxes=[(make_T(t=t), [0.1, 0.1, 0.1])])
    np.testing.assert_allclose(ps.distance(np.array([[0.0, 0.0, 2.0], [0.5, 0.0, 0.0]])), [1.5, 0.0])
    assert ps.merged(PrimitiveSet.empty()).n_primitives == 2
    with pytest.raises(CompassInputError, match="half extents"):
        PrimitiveSet.from_lists(boxes=[(np.eye(4), [0.1, -0.1, 0.1])])


def test_primitive_set_distance_is_the_pointwise_distance_bit_for_bit():
    """`PrimitiveSet.distance` runs one compiled loop: the same values as calling
    `primitives_distance` point by point (as it did before), exactly."""
    from compass_manip.motion.primitives import primitives_distance
    rng = np.random.default_rng(5)
    ps = PrimitiveSet.from_lists(
        boxes=[(make_T(rot_z(0.4), [0.3, 0.1, 0.2]), [0.1, 0.2, 0.05]), (make_T(t=[-0.2, 0.0, 0.5]), [0.3, 0.01, 0.2])],
        spheres=[(np.array([0.0, 0.4, 0.1]), 0.07)], cylinders=[(make_T(rot_x(0.3), [0.1, -0.3, 0.4]), 0.04, 0.2)])
    P = rng.uniform(-0.6, 0.8, (500, 3))
    want = np.array([primitives_distance(p, ps.arrays(), -np.inf) for p in P])
    assert np.array_equal(ps.distance(P), want) and (want < 0).any() and (want > 0).any()
    assert np.all(np.isinf(PrimitiveSet.empty().distance(P[:3])))


def test_batch_single_edge_and_first_invalid_agree(sm, prims):
    vc = ValidityChecker(sm, obstacles=prims)
    rng = np.random.default_rng(3)
    Q = rng.uniform(Q_MIN, Q_MAX, (300, 7))
    np.testing.assert_array_equal(vc.are_valid(Q), [vc.is_valid(q) for q in Q])
    free = Q[vc.are_valid(Q)]
    assert vc.is_valid(Q_HOME)
    starts = [Q_HOME] * 30 + list(free[30:60])  # long edges from home, short ones elsewhere
    ends = list(free[:30]) + [np.clip(q + rng.uniform(-0.3, 0.3, 7), Q_MIN, Q_MAX) for q in free[30:60]]
    n_valid = 0
    for q0, q1 in zip(starts, ends):
        n = int(np.ceil(np.max(np.abs(q1 - q0)) / 0.01))
        S = q0 + (q1 - q0) * (np.arange(n + 1) / n)[:, None]
        dense = vc.are_valid(S)
        assert vc.edge_valid(q0, q1) == bool(dense.all())
        n_valid += bool(dense.all())
        s = vc.first_invalid(q0, q1)
        if dense.all():
            assert s is None
        else:
            assert s == pytest.approx(np.argmin(dense) / n)
    assert 5 < n_valid < 55  # both verdicts occur
    path = np.stack([Q_HOME, Q_HOME + 0.05, Q_HOME + 0.1])
    assert vc.path_valid(path)


def test_goal_inside_obstacle_is_invalid_and_clearance(sm):
    vc0 = ValidityChecker(sm)
    tcp = sm.kinematics.T_world_tcp(Q_HOME)[:3, 3]
    blocked = ValidityChecker(sm, obstacles=PrimitiveSet.from_lists(spheres=[(tcp, 0.03)]))
    assert vc0.is_valid(Q_HOME) and not blocked.is_valid(Q_HOME)
    assert blocked.clearance(Q_HOME) < 0
    assert vc0.clearance(Q_HOME) == np.inf
    near = ValidityChecker(sm, obstacles=PrimitiveSet.from_lists(spheres=[(tcp + [0, 0, 0.5], 0.03)]))
    c = near.clearance(Q_HOME)
    assert 0.0 < c < 0.5
    for m, expected in ((c + 0.01, False), (c - 0.01, True)):
        assert ValidityChecker(sm, obstacles=near.obstacles, config=ValidityConfig(margin=m)).is_valid(Q_HOME) == expected


def test_bad_joint_vectors_rejected(sm):
    vc = ValidityChecker(sm)
    q = Q_HOME.copy()
    q[5] = 4.0
    with pytest.raises(CompassInputError, match=r"q\[5\].*outside joint 6"):
        vc.is_valid(q)
    with pytest.raises(CompassInputError, match="NaN"):
        vc.is_valid(np.full(7, np.nan))
    Q = np.tile(Q_HOME, (4, 1))
    Q[1, 2] = np.inf
    with pytest.raises(CompassInputError, match=r"Q\[1\]"):
        vc.are_valid(Q)
    with pytest.raises(CompassInputError, match="q1"):
        vc.edge_valid(Q_HOME, q)
    with pytest.raises(CompassInputError, match="edge resolution"):
        vc.edge_valid(Q_HOME, Q_HOME, resolution=2.0)
    # the raw kernel (used inside planners) answers False instead of raising
    links, W = np.empty((sm.kinematics.n_links, 4, 4)), np.empty((sm.n_spheres, 3))
    assert config_valid_kernel(Q_HOME, *vc.kernel_args(), links, W)
    assert not config_valid_kernel(np.full(7, np.nan), *vc.kernel_args(), links, W)
    assert not config_valid_kernel(q, *vc.kernel_args(), links, W)


@pytest.mark.parametrize("level", [3, 4])
def test_conservative_in_generated_scenes(level):
    from compass_manip.robot.model import RobotConfig
    from compass_manip.sim.levels import generate_scene
    from compass_manip.sim.world import World

    scene = generate_scene(level, 0, np.random.default_rng(level))
    world = World(scene)
    sm_scene = panda_sphere_model(RobotConfig(base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw))
    obstacles = PrimitiveSet.from_shapes(scene.all_primitives(), floor_z=scene.floor_z)
    vc = ValidityChecker(sm_scene, obstacles=obstacles, config=ValidityConfig(check_self=False))
    Q = np.random.default_rng(10 + level).uniform(Q_MIN, Q_MAX, (5000, 7))
    free = vc.are_valid(Q)
    n_contact = 0
    for q, f in zip(Q, free):
        hits = [c for c in world.contacts(q, finger_width=0.08) if c.robot_geom != "link0"]
        n_contact += bool(hits)
        assert not (f and hits), hits
    assert n_contact > 500 and free.sum() > 500


def test_distance_grid_from_mapping_field_and_lookup_values():
    from types import SimpleNamespace

    unsafe = np.zeros((10, 10, 10), bool)
    unsafe[5, 5, 5] = True
    field = SimpleNamespace(distances=None, grid_min=np.array([1.0, 2.0, 3.0]), resolution=0.1)
    g0 = DistanceGrid.from_unsafe_mask(unsafe, field.grid_min, field.resolution)
    field.distances = g0.dist
    g = DistanceGrid.from_distance_field(field)
    assert g.dist[5, 5, 8] == pytest.approx(0.3)
    packed = (g.dist, g.origin, g.resolution, True, False)
    centre = field.grid_min + (np.array([5, 5, 8]) + 0.5) * 0.1  # voxel centre: exact value
    assert grid_clearance(centre, packed, 0.0) == pytest.approx(0.3)
    assert grid_clearance(centre, packed, 0.05) == pytest.approx(0.25)
    off = centre + [0.0, 0.0, 0.03]  # 3 cm off the centre: the bound drops by 3 cm
    assert grid_clearance(off, packed, 0.0) == pytest.approx(0.27)
    assert grid_clearance(np.array([0.0, 0.0, 0.0]), packed, 0.0) == -np.inf
    free_outside = (g.dist, g.origin, g.resolution, True, True)
    far = grid_clearance(np.array([0.0, 0.0, 0.0]), free_outside, 0.0)  # the grid box is 3.74 m away
    assert far == pytest.approx(np.linalg.norm([1.0, 2.0, 3.0]))
    near = field.grid_min + [0.55, 0.55, -0.05]  # 5 cm below the grid, 0.45 m under the unsafe voxel
    assert 0.05 <= grid_clearance(near, free_outside, 0.0) <= 0.45
    inside_unsafe = field.grid_min + [0.55, 0.55, 0.55]
    assert grid_clearance(inside_unsafe, free_outside, 0.0) <= 0.0


def _grid_of(prims, res=0.02):
    """Voxelised primitives (a voxel is unsafe when its cube may touch one) as a DistanceGrid."""
    lo, n = np.array([-1.0, -1.0, -0.2]), np.array([110, 100, 80])
    axes = [lo[i] + (np.arange(n[i]) + 0.5) * res for i in range(3)]
    P = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    unsafe = (prims.distance(P) <= 0.5 * np.sqrt(3.0) * res).reshape(n)
    return DistanceGrid.from_unsafe_mask(unsafe, lo, res)


def test_clusters_partition_and_enclose_each_links_spheres(sm):
    vc = ValidityChecker(sm)
    bi, cl, rad, start = vc._p.robot[:4]
    clu_start, clu_c, clu_r, mem_start, members = vc._p.robot[12:]
    np.testing.assert_array_equal(np.sort(members), np.arange(len(rad)))  # every sphere exactly once
    for i in range(len(start) - 1):
        for k in range(clu_start[i], clu_start[i + 1]):
            m = members[mem_start[k]:mem_start[k + 1]]
            assert 1 <= len(m) <= 8 and np.all(bi[m] == i)
            assert np.all(np.linalg.norm(cl[m] - clu_c[k], axis=1) + rad[m] <= clu_r[k] + 1e-12)


def test_motion_bounds_bound_sphere_and_pair_motion(sm):
    from compass_manip.motion.edge_bounds import edge_rates

    vc = ValidityChecker(sm)
    R_link, R_pair = vc._bounds
    robot = vc._p.robot
    bi, lp, lp_run, run_u, run_start, partner = robot[0], robot[7], robot[8], robot[9], robot[10], robot[11]
    rng = np.random.default_rng(5)
    worst_env, worst_pair = 0.0, 0.0
    for _ in range(40):
        q0 = rng.uniform(Q_MIN, Q_MAX)
        q1 = np.clip(q0 + rng.uniform(-0.6, 0.6, 7), Q_MIN, Q_MAX)
        rl, rp = np.empty(len(R_link)), np.empty(len(R_pair))
        edge_rates(q0, q1, R_link, R_pair, rl, rp)
        t = np.linspace(0.0, 1.0, 21)
        W = sm.sphere_centers(q0 + t[:, None] * (q1 - q0))  # (21,S,3)
        moved = np.linalg.norm(W - W[0], axis=2)  # |p(t) - p(0)| <= t * rate
        ratio = moved[1:] / (t[1:, None] * rl[bi][None, :] + 1e-300)
        worst_env = max(worst_env, float(ratio[:, rl[bi] > 0].max()))
        assert np.all(moved[:, rl[bi] == 0] < 1e-12)  # links no joint moves stay put
        for li in range(len(lp)):
            r = lp_run[li]
            u, v = run_u[r], partner[run_start[r]:run_start[r + 1]]
            d = np.linalg.norm(W[:, u][:, None] - W[:, v], axis=2)
            change = np.abs(d - d[0])[1:] / (t[1:, None] * rp[li] + 1e-300)
            worst_pair = max(worst_pair, float(change.max()))
    assert 0.2 < worst_env <= 1.0 and 0.1 < worst_pair <= 1.0  # bounds hold and are not vacuous


def _checker_and_samples(sm, prims, kind: str, seed: int):
    """(checker on the primitives or their grid, its generator, 600 uniform configurations,
    the valid ones among them)."""
    vc = ValidityChecker(sm, obstacles=prims) if kind == "primitives" else ValidityChecker(sm, grid=_grid_of(prims))
    rng = np.random.default_rng(seed)
    Q = rng.uniform(Q_MIN, Q_MAX, (600, 7))
    return vc, rng, Q, Q[vc.are_valid(Q)]


@pytest.mark.parametrize("kind", ["primitives", "grid"])
def test_adaptive_edge_check_equals_checking_every_state(sm, prims, kind):
    from compass_manip.motion.edge_bounds import edge_valid_adaptive_kernel
    from compass_manip.motion.validity import edge_valid_kernel

    vc, rng, _, free = _checker_and_samples(sm, prims, kind, 11)
    verdicts = []
    for k in range(150):
        q0 = free[k % len(free)]
        q1 = np.clip(q0 + rng.uniform(-0.8, 0.8, 7) * rng.uniform(0.05, 1.0), Q_MIN, Q_MAX)
        for res in (0.005, 0.03):
            n = max(1, int(np.ceil(np.max(np.abs(q1 - q0)) / res)))
            dense = bool(edge_valid_kernel(q0, q1, n, *vc.kernel_args()))
            assert bool(edge_valid_adaptive_kernel(q0, q1, n, *vc.edge_kernel_args())) == dense
            assert vc.edge_valid(q0, q1, res, adaptive=True) == dense
            verdicts.append(dense)
    assert 0.1 < np.mean(verdicts) < 0.95  # both verdicts occur


def test_edge_kernels_check_every_state_and_the_from_kernel_skips_only_the_start(sm, prims):
    """The edge kernels' one-loop bisection visits every state k = 0..n (edge_valid_kernel) or
    k = 1..n (edge_valid_from_kernel): their verdicts equal checking each state, for every n
    up to 17 (powers of two and not) and edges out of an invalid start."""
    from compass_manip.motion.validity import edge_valid_from_kernel, edge_valid_kernel

    vc = ValidityChecker(sm, obstacles=prims)
    rng = np.random.default_rng(5)
    Q = rng.uniform(Q_MIN, Q_MAX, (800, 7))
    ok = vc.are_valid(Q)
    starts = np.vstack([Q[ok][:40], Q[~ok][:20]])  # valid and invalid starts
    seen = set()
    for i, q0 in enumerate(starts):
        q1 = np.clip(q0 + rng.uniform(-0.6, 0.6, 7), Q_MIN, Q_MAX)
        for n in range(1, 18):
            states = q0 + (q1 - q0) * (np.arange(n + 1)[:, None] / n)
            valid = vc.are_valid(states)
            full = bool(edge_valid_kernel(q0, q1, n, *vc.kernel_args()))
            after = bool(edge_valid_from_kernel(q0, q1, n, *vc.kernel_args()))
            assert full == bool(valid.all()) and after == bool(valid[1:].all()), (i, n)
            seen.add((full, after))
    assert seen == {(True, True), (False, False), (False, True)}  # each case occurs
    # one state alone invalid: a 5 mm ball on the hand's last sphere at state k
    q0 = np.asarray(Q_HOME, float)
    q1 = q0 + np.array([2.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # the hand sweeps sideways, far per step
    cases = 0
    for n in (5, 8, 11, 13, 16):
        states = q0 + (q1 - q0) * (np.arange(n + 1)[:, None] / n)
        for k in range(n + 1):
            ball = PrimitiveSet.from_lists(spheres=[(sm.sphere_centers(states[k:k + 1])[0, -1], 0.005)])
            one = ValidityChecker(sm, obstacles=ball)
            valid = one.are_valid(states)
            if valid.sum() != n:
                continue  # another state hits the ball too
            cases += 1
            assert not edge_valid_kernel(q0, q1, n, *one.kernel_args()), (n, k)
            assert bool(edge_valid_from_kernel(q0, q1, n, *one.kernel_args())) == (k == 0), (n, k)
    assert cases >= 20  # 23 of the 58 (n, k)


def test_checkers_of_one_sphere_model_share_its_packing_and_equal_a_fresh_one(sm, prims):
    """The packed spheres and motion bounds are computed once per sphere model and
    check_self; they equal a fresh packing, and a checker using them gives the same
    verdicts as one built on a copy of the model (packed anew)."""
    import dataclasses

    from compass_manip.motion.edge_bounds import motion_bounds
    from compass_manip.motion.validity import _pack_robot

    a, b = ValidityChecker(sm, obstacles=prims), ValidityChecker(sm, config=ValidityConfig(margin=0.01))
    assert a._p.robot is b._p.robot and a._bounds is b._bounds
    assert ValidityChecker(sm, config=ValidityConfig(check_self=False))._p.robot is not a._p.robot
    fresh = _pack_robot(sm, True)
    for x, y in zip(a._p.robot, fresh):
        np.testing.assert_array_equal(x, y)
    for x, y in zip(a._bounds, motion_bounds(sm, fresh)):
        np.testing.assert_array_equal(x, y)
    other = ValidityChecker(dataclasses.replace(sm), obstacles=prims)
    assert other._p.robot is not a._p.robot
    Q = np.random.default_rng(3).uniform(Q_MIN, Q_MAX, (300, 7))
    np.testing.assert_array_equal(a.are_valid(Q), other.are_valid(Q))


@pytest.mark.parametrize("kind", ["primitives", "grid"])
def test_first_invalid_equals_checking_every_state_fully(sm, prims, kind):
    """The scan skips links no moving joint carries once the start is valid: on segments
    moving only the wrist, only the elbow and wrist, or every joint, its answer is that of
    checking every state in full."""
    vc, rng, Q, free = _checker_and_samples(sm, prims, kind, 21)
    firsts = []
    for k in range(120):
        q0 = free[k % len(free)] if k % 10 else Q[k]  # some starts invalid
        moving = (4, 3, 0)[k % 3]  # joints from this index on move
        q1 = q0.copy()
        q1[moving:] = np.clip(q0[moving:] + rng.uniform(-1.0, 1.0, 7 - moving), Q_MIN[moving:], Q_MAX[moving:])
        for res in (0.005, 0.03):
            n = max(1, int(np.ceil(np.max(np.abs(q1 - q0)) / res)))
            states = q0 + (q1 - q0) * (np.arange(n + 1) / n)[:, None]
            bad = np.flatnonzero(~vc.are_valid(states))
            want = None if len(bad) == 0 else bad[0] / n
            assert vc.first_invalid(q0, q1, res) == want
            firsts.append(-1 if want is None else bad[0])
    firsts = np.asarray(firsts)
    assert (firsts == -1).any() and (firsts == 0).any() and (firsts > 1).sum() > 20  # all kinds occur
