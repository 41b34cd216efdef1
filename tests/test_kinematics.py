"""FK against MuJoCo's body/site/camera poses, Jacobian against finite differences."""
import mujoco
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.geometry import inv_T
from compass_manip.robot.kinematics import PandaKinematics, check_Q
from compass_manip.robot.model import Q_HOME, Q_MAX, Q_MIN, CameraConfig, RobotConfig, build_robot_spec

CFG = RobotConfig(base_pos=(0.1, -0.2, 0.05), base_yaw=0.7, camera=CameraConfig(pos_hand=(0.06, 0.01, 0.03)))


@pytest.fixture(scope="module")
def kin():
    return PandaKinematics(CFG)


@pytest.fixture(scope="module")
def mj():
    m = build_robot_spec(CFG, actuators=False).compile()
    return m, mujoco.MjData(m)


def _rotvec(R):
    c = np.clip((np.trace(R) - 1) / 2, -1, 1)
    a = np.arccos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return v * (0.5 if a < 1e-9 else a / (2 * np.sin(a)))


def test_fk_matches_mujoco_bodies_tcp_and_camera(kin, mj):
    m, d = mj
    rng = np.random.default_rng(1)
    tcp = m.site("hand/TCP").id
    cam = m.camera("wrist_cam").id
    for _ in range(50):
        q = rng.uniform(Q_MIN, Q_MAX)
        d.qpos[:7] = q
        d.qpos[7:9] = 0.04  # fully open: finger_width 0.08 m
        mujoco.mj_kinematics(m, d)
        mujoco.mj_camlight(m, d)
        L = kin.fk_links(q)
        for i, name in enumerate(kin.link_names):
            b = m.body(name).id
            np.testing.assert_allclose(L[i][:3, 3], d.xpos[b], atol=1e-12)
            np.testing.assert_allclose(L[i][:3, :3], d.xmat[b].reshape(3, 3), atol=1e-12)
        T = kin.T_world_tcp(q)
        np.testing.assert_allclose(T[:3, 3], d.site_xpos[tcp], atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], d.site_xmat[tcp].reshape(3, 3), atol=1e-12)
        C = kin.T_world_cam(q)  # OpenCV optical frame = MuJoCo camera with y, z flipped
        np.testing.assert_allclose(C[:3, 3], d.cam_xpos[cam], atol=1e-12)
        np.testing.assert_allclose(C[:3, :3] @ np.diag([1, -1, -1]), d.cam_xmat[cam].reshape(3, 3), atol=1e-12)


def test_frames_relations_and_base(kin):
    q = Q_HOME
    H = kin.T_world_hand(q)
    np.testing.assert_allclose(inv_T(H) @ kin.T_world_tcp(q), kin.T_hand_tcp, atol=1e-12)
    np.testing.assert_allclose(inv_T(H) @ kin.T_world_cam(q), CFG.camera.T_hand_cam, atol=1e-12)
    base = kin.fk_links(q)[0]
    np.testing.assert_allclose(base[:3, 3], CFG.base_pos)
    np.testing.assert_allclose(np.arctan2(base[1, 0], base[0, 0]), CFG.base_yaw)
    # the hand is mounted -45 deg about z on the flange (panda_link8)
    L = kin.fk_links(q)
    R = (inv_T(L[kin.tree.index("panda_link8")]) @ H)[:3, :3]
    np.testing.assert_allclose(np.arctan2(R[1, 0], R[0, 0]), -np.pi / 4, atol=1e-12)


@pytest.mark.parametrize("frame", ["tcp", "cam", "hand"])
def test_jacobian_matches_finite_differences(kin, frame):
    rng = np.random.default_rng(2)
    eps = 1e-6
    lo, hi = Q_MIN + 1e-3, Q_MAX - 1e-3
    for _ in range(10):
        q = rng.uniform(lo, hi)
        J = kin.jacobian(q, frame)
        Jn = np.zeros((6, 7))
        for j in range(7):
            dq = np.zeros(7)
            dq[j] = eps
            Tp, Tm = kin.T_world_frame(q + dq, frame), kin.T_world_frame(q - dq, frame)
            Jn[:3, j] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * eps)
            Jn[3:, j] = _rotvec(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * eps)
        np.testing.assert_allclose(J, Jn, atol=1e-7)


def test_manipulability_and_batches(kin):
    rng = np.random.default_rng(3)
    Q = rng.uniform(Q_MIN, Q_MAX, (20, 7))
    Jb = kin.jacobian_batch(Q)
    mb = kin.manipulability_batch(Q)
    Tb = kin.T_world_tcp_batch(Q)
    Cb = kin.T_world_cam_batch(Q)
    Lb = kin.fk_links_batch(Q)
    from compass_manip.robot.kinematics import jacobian_kernel  # the batch's compiled loop: the same numbers
    P = (Lb[:, kin.hand_index] @ kin.T_hand_frame("tcp"))[:, :3, 3]
    t = kin.tree
    for n in range(len(Q)):
        ref = np.empty((6, 7))
        jacobian_kernel(Lb[n], P[n], t.joint_kind, t.joint_index, t.axis, t.anchor, ref)
        assert np.array_equal(Jb[n], ref)
    # given the links the caller already has (the trial's metrics), the same numbers
    assert np.array_equal(kin.manipulability_batch(Q, links=Lb), mb)
    assert np.array_equal(kin.jacobian_batch(Q, links=Lb), Jb)
    assert np.array_equal((Lb[:, kin.hand_index] @ kin.T_hand_frame("tcp"))[:, :3, 3], Tb[:, :3, 3])
    for n, q in enumerate(Q):
        J = kin.jacobian(q)
        np.testing.assert_allclose(Jb[n], J, atol=1e-14)
        sv = np.linalg.svd(J, compute_uv=False)
        assert kin.manipulability(q) == pytest.approx(np.prod(sv), rel=1e-9)
        assert mb[n] == pytest.approx(np.prod(sv), rel=1e-9)
        np.testing.assert_allclose(Tb[n], kin.T_world_tcp(q), atol=1e-14)
        np.testing.assert_allclose(Cb[n], kin.T_world_cam(q), atol=1e-14)
        np.testing.assert_allclose(Lb[n], kin.fk_links(q), atol=1e-14)
    # at a stretched-out (singular) arm the manipulability vanishes
    q_sing = np.array([0.0, 0.0, 0.0, -0.0698, 0.0, 0.0, 0.0])
    assert kin.manipulability(q_sing) < 0.1 * kin.manipulability(Q_HOME)


def test_finger_width_moves_finger_frames():
    k0, k8 = PandaKinematics(finger_width=0.0), PandaKinematics(finger_width=0.08)
    i, j = k0.tree.index("hand/panda_leftfinger"), k0.tree.index("hand/panda_rightfinger")
    gap0 = np.linalg.norm(k0.fk_links(Q_HOME)[i][:3, 3] - k0.fk_links(Q_HOME)[j][:3, 3])
    gap8 = np.linalg.norm(k8.fk_links(Q_HOME)[i][:3, 3] - k8.fk_links(Q_HOME)[j][:3, 3])
    assert gap0 == pytest.approx(0.0, abs=1e-12)
    assert gap8 == pytest.approx(0.08, abs=1e-12)
    with pytest.raises(CompassInputError, match="finger_width"):
        PandaKinematics(finger_width=0.25)


def test_bad_joint_vectors_rejected(kin):
    q = Q_HOME.copy()
    q[3] = 0.5
    with pytest.raises(CompassInputError, match=r"q\[3\].*outside joint 4"):
        kin.T_world_tcp(q)
    with pytest.raises(CompassInputError, match="NaN"):
        kin.fk_links(np.full(7, np.nan))
    with pytest.raises(CompassInputError, match="7 joint angles"):
        kin.jacobian(np.zeros(6))
    Q = np.tile(Q_HOME, (3, 1))
    Q[2, 0] = 4.0
    with pytest.raises(CompassInputError, match=r"Q\[2\]\[0\]"):
        check_Q(Q)
    with pytest.raises(CompassInputError, match="frame"):
        kin.jacobian(Q_HOME, "elbow")


def test_fk_matches_the_simulator_world():
    from compass_manip.sim.levels import generate_scene
    from compass_manip.sim.world import World

    scene = generate_scene(4, 0, np.random.default_rng(7))
    world = World(scene)
    kin = PandaKinematics(world.robot)
    rng = np.random.default_rng(8)
    for _ in range(10):
        q = rng.uniform(Q_MIN, Q_MAX)
        world.set_q(q, 0.08)
        mujoco.mj_kinematics(world.model, world.data)
        mujoco.mj_camlight(world.model, world.data)
        L = kin.fk_links(q)
        for i, name in enumerate(kin.link_names):
            b = world.model.body(name).id
            np.testing.assert_allclose(L[i][:3, 3], world.data.xpos[b], atol=1e-12)
            np.testing.assert_allclose(L[i][:3, :3], world.data.xmat[b].reshape(3, 3), atol=1e-12)
        np.testing.assert_allclose(kin.T_world_cam(q), world.T_world_cam(), atol=1e-9)
