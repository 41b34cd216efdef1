"""Forward kinematics, geometric Jacobian and manipulability of the Panda + hand + camera.

The kinematic tree is read programmatically from the compiled robot-only MuJoCo model
(`build_robot_spec`): every body's fixed transform in its parent (body_pos/body_quat), its
joint type, axis and anchor. Nothing is typed in by hand, so FK stays identical to the
simulator. The hot path is a numba kernel chaining 4x4 transforms down the tree.

Frames: link frames are the MuJoCo bodies `panda_link0..8`, `hand/panda_hand` (flange; the
hand is mounted 45 deg about z on the wrist site), and the two fingers (opened by
`finger_width` [m], the distance between the fingers). `tcp` = hand @ T_HAND_TCP, `cam` =
hand @ CameraConfig.T_hand_cam (OpenCV optical frame). All poses are in the world frame [m].
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numba as nb
import numpy as np

from ..errors import CompassInputError, real_number
from ..geometry import make_T, quat_to_R
from .model import ARM_JOINTS, FINGER_JOINTS, GRIPPER_MAX_WIDTH, N_ARM_JOINTS, T_HAND_TCP
from .model import Q_MAX, Q_MIN, RobotConfig, build_robot_spec, check_q

#: Joint kinds in `KinematicTree.joint_kind`.
JOINT_FIXED, JOINT_REVOLUTE_ARM, JOINT_PRISMATIC_FINGER = 0, 1, 2
HAND_BODY = "hand/panda_hand"
FRAMES = ("tcp", "cam", "hand")
#: Largest finger_width [m] accepted (beyond GRIPPER_MAX_WIDTH only to mirror benchmark datasets).
MAX_FINGER_WIDTH = 0.2


@dataclass(frozen=True, eq=False)
class KinematicTree:
    """Arrays describing the tree of link frames (index 0 is the base, panda_link0).

    names (L,) body names; parent (L,) parent link index (-1: world); T_parent_link (L,4,4)
    fixed transform of the link in its parent (for the base: T_world_base); joint_kind (L,)
    JOINT_*; joint_index (L,) arm joint 0..6 (or -1); axis (L,3) unit joint axis and
    anchor (L,3) [m] joint position, both in the link frame.
    """

    names: tuple[str, ...]
    parent: np.ndarray
    T_parent_link: np.ndarray
    joint_kind: np.ndarray
    joint_index: np.ndarray
    axis: np.ndarray
    anchor: np.ndarray

    @property
    def n_links(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Link index of a body name (e.g. 'panda_link3', 'hand/panda_hand')."""
        if name not in self.names:
            raise CompassInputError(f"unknown link {name!r}; known links: {', '.join(self.names)}")
        return self.names.index(name)


def tree_from_mujoco(model) -> KinematicTree:
    """Extract the kinematic tree below panda_link0 from a compiled MuJoCo robot model."""
    import mujoco

    base_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "panda_link0")
    if base_id < 0:
        raise CompassInputError("the MuJoCo model has no body 'panda_link0'")
    arm_jnt = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in ARM_JOINTS]
    finger_jnt = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in FINGER_JOINTS]
    bodies = [base_id]
    for b in range(base_id + 1, model.nbody):  # bodies are stored parent-first
        if model.body_parentid[b] in bodies:
            bodies.append(b)
    L = len(bodies)
    parent = np.full(L, -1, np.int64)
    T = np.zeros((L, 4, 4))
    kind = np.zeros(L, np.int64)
    jidx = np.full(L, -1, np.int64)
    axis = np.zeros((L, 3))
    anchor = np.zeros((L, 3))
    for i, b in enumerate(bodies):
        p = int(model.body_parentid[b])
        parent[i] = bodies.index(p) if p in bodies else -1
        T[i] = make_T(quat_to_R(model.body_quat[b]), model.body_pos[b])
        if p not in bodies and p != 0:
            raise CompassInputError("panda_link0 must be a child of the world body")
        n = int(model.body_jntnum[b])
        if n > 1:
            raise CompassInputError(f"body {model.body(b).name} has {n} joints; at most 1 supported")
        if n == 1:
            j = int(model.body_jntadr[b])
            axis[i] = model.jnt_axis[j]
            anchor[i] = model.jnt_pos[j]
            if j in arm_jnt:
                kind[i] = JOINT_REVOLUTE_ARM
                jidx[i] = arm_jnt.index(j)
            elif j in finger_jnt:
                kind[i] = JOINT_PRISMATIC_FINGER
            else:
                raise CompassInputError(f"unexpected joint {model.joint(j).name} in the robot")
    names = tuple(model.body(b).name for b in bodies)
    return KinematicTree(names, parent, T, kind, jidx, axis, anchor)


@nb.njit(cache=True, inline="always")
def _axis_angle_T(axis, angle, out):
    """4x4 rotation about a unit axis through the origin (Rodrigues), written into out."""
    x, y, z = axis[0], axis[1], axis[2]
    c, s = np.cos(angle), np.sin(angle)
    C = 1.0 - c
    out[0, 0] = c + x * x * C
    out[0, 1] = x * y * C - z * s
    out[0, 2] = x * z * C + y * s
    out[1, 0] = y * x * C + z * s
    out[1, 1] = c + y * y * C
    out[1, 2] = y * z * C - x * s
    out[2, 0] = z * x * C - y * s
    out[2, 1] = z * y * C + x * s
    out[2, 2] = c + z * z * C
    for r in range(3):
        out[r, 3] = 0.0
        out[3, r] = 0.0
    out[3, 3] = 1.0


@nb.njit(cache=True, inline="always")
def _mul_T(A, B, out):
    """out = A @ B for rigid 4x4 transforms (last row 0 0 0 1); out must not alias A or B."""
    for r in range(3):
        a0, a1, a2 = A[r, 0], A[r, 1], A[r, 2]
        for c in range(4):
            out[r, c] = a0 * B[0, c] + a1 * B[1, c] + a2 * B[2, c]
        out[r, 3] += A[r, 3]
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@nb.njit(cache=True)
def fk_links_kernel(q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, out):
    """World pose of every link into out (L,4,4). q (7,) [rad], finger_pos [m] per finger."""
    L = parent.shape[0]
    M = np.empty((4, 4))
    A = np.empty((4, 4))
    for i in range(L):
        if parent[i] < 0:
            A[:, :] = T_parent_link[i]
        else:
            _mul_T(out[parent[i]], T_parent_link[i], A)
        k = joint_kind[i]
        if k == 1:
            _axis_angle_T(axis[i], q[joint_index[i]], M)
            # rotation about the anchor a: T(a) R T(-a)
            for r in range(3):
                M[r, 3] = anchor[i, r] - (M[r, 0] * anchor[i, 0] + M[r, 1] * anchor[i, 1] + M[r, 2] * anchor[i, 2])
            _mul_T(A, M, out[i])
        else:
            if k == 2:
                for r in range(3):
                    A[r, 3] += (A[r, 0] * axis[i, 0] + A[r, 1] * axis[i, 1] + A[r, 2] * axis[i, 2]) * finger_pos
            out[i, :, :] = A
    return out


@nb.njit(cache=True, parallel=True)
def fk_links_batch_kernel(Q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, out):
    """Batch of fk_links_kernel over Q (N,7) into out (N,L,4,4)."""
    for n in nb.prange(Q.shape[0]):
        fk_links_kernel(Q[n], finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, out[n])
    return out


@nb.njit(cache=True)
def jacobian_kernel(links, p_world, joint_kind, joint_index, axis, anchor, out):
    """Geometric 6x7 Jacobian of the world point p_world rigidly attached to the chain.

    Rows 0..2 linear velocity [m/rad], rows 3..5 angular velocity [1], world frame; links
    (L,4,4) from fk_links_kernel. Assumes p_world is on the last arm link or its children.
    """
    out[:, :] = 0.0
    for i in range(links.shape[0]):
        if joint_kind[i] != 1:
            continue
        j = joint_index[i]
        a = np.empty(3)
        d = np.empty(3)
        for r in range(3):
            a[r] = links[i, r, 0] * axis[i, 0] + links[i, r, 1] * axis[i, 1] + links[i, r, 2] * axis[i, 2]
            o = links[i, r, 0] * anchor[i, 0] + links[i, r, 1] * anchor[i, 1] + links[i, r, 2] * anchor[i, 2]
            d[r] = p_world[r] - o - links[i, r, 3]
        out[0, j] = a[1] * d[2] - a[2] * d[1]
        out[1, j] = a[2] * d[0] - a[0] * d[2]
        out[2, j] = a[0] * d[1] - a[1] * d[0]
        out[3, j] = a[0]
        out[4, j] = a[1]
        out[5, j] = a[2]
    return out


@lru_cache(maxsize=8)
def _tree_for(config: RobotConfig) -> KinematicTree:
    return tree_from_mujoco(build_robot_spec(config, actuators=False).compile())


def check_Q(Q: np.ndarray, name: str = "Q") -> np.ndarray:
    """Return Q as a contiguous float64 (N,7) array or raise naming the first bad row.

    Vectorised counterpart of `check_q`: NaN/inf or out-of-limit rows raise CompassInputError.
    """
    try:
        Q = np.asarray(Q, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{name} must be an (N, 7) array of joint angles [rad], got {Q!r:.80}") from exc
    if Q.ndim != 2 or Q.shape[1] != N_ARM_JOINTS:
        raise CompassInputError(f"{name} must be an (N, 7) array of joint angles [rad], got {Q.shape}")
    bad = ~np.all(np.isfinite(Q) & (Q >= Q_MIN - 1e-9) & (Q <= Q_MAX + 1e-9), axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        check_q(Q[i], f"{name}[{i}]")
    return np.ascontiguousarray(Q)


class KinematicsData(NamedTuple):
    """The kinematic tree as kernel arguments: finger_pos [m], parent (L,), T_parent_link
    (L, 4, 4), joint_kind (L,), joint_index (L,), axis (L, 3), anchor (L, 3) [m]."""

    finger_pos: np.ndarray
    parent: np.ndarray
    T_parent_link: np.ndarray
    joint_kind: np.ndarray
    joint_index: np.ndarray
    axis: np.ndarray
    anchor: np.ndarray


@nb.njit(cache=True)
def jacobian_batch_kernel(links, P, joint_kind, joint_index, axis, anchor, out):
    """`jacobian_kernel` of each configuration: links (N, L, 4, 4), points P (N, 3) [m]
    into out (N, 6, 7)."""
    for n in range(links.shape[0]):
        jacobian_kernel(links[n], P[n], joint_kind, joint_index, axis, anchor, out[n])
    return out


class PandaKinematics:
    """FK, Jacobian and manipulability of the Panda built by `build_robot_spec(robot_config)`.

    finger_width [m] is the opening used for the finger link frames: 0..0.08 on the real
    hand; up to 0.2 is accepted to reproduce datasets that open the fingers wider (the
    MotionBenchMaker requests set each finger joint to 0.065 m, i.e. a width of 0.13 m).
    Methods check q with `check_q` (CompassInputError on NaN / out-of-limit input).
    """

    def __init__(self, robot_config: RobotConfig | None = None, finger_width: float = GRIPPER_MAX_WIDTH):
        finger_width = real_number(finger_width, "finger_width", f"0..{MAX_FINGER_WIDTH} m")
        if not (0.0 <= finger_width <= MAX_FINGER_WIDTH):
            raise CompassInputError(
                f"finger_width {finger_width} m is not allowed; use 0..{MAX_FINGER_WIDTH} m "
                f"(0..{GRIPPER_MAX_WIDTH} m on the real hand)"
            )
        self.robot_config = robot_config or RobotConfig()
        self.tree = _tree_for(self.robot_config)
        self.finger_pos = 0.5 * float(finger_width)
        self.hand_index = self.tree.index(HAND_BODY)
        self.T_hand_tcp = T_HAND_TCP.copy()
        self.T_hand_cam = self.robot_config.camera.T_hand_cam

    @property
    def link_names(self) -> tuple[str, ...]:
        return self.tree.names

    @property
    def n_links(self) -> int:
        return self.tree.n_links

    def kernel_args(self) -> "KinematicsData":
        """The kinematic tree's arrays for the kernels (`fk_links_kernel` argument order)."""
        t = self.tree
        return KinematicsData(self.finger_pos, t.parent, t.T_parent_link, t.joint_kind, t.joint_index, t.axis,
                              t.anchor)

    def T_hand_frame(self, frame: str) -> np.ndarray:
        """Fixed transform hand flange -> frame ('tcp', 'cam' or 'hand')."""
        if not isinstance(frame, str):
            raise CompassInputError(f"frame {frame!r:.40} is not allowed; use one of {FRAMES}")
        if frame == "tcp":
            return self.T_hand_tcp
        if frame == "cam":
            return self.T_hand_cam
        if frame == "hand":
            return np.eye(4)
        raise CompassInputError(f"unknown frame {frame!r}; use one of {FRAMES}")

    # single configuration ------------------------------------------------------------
    def fk_links(self, q: np.ndarray) -> np.ndarray:
        """World poses (L,4,4) of all link frames (order: `link_names`)."""
        q = check_q(q)
        return fk_links_kernel(q, *self.kernel_args(), np.empty((self.n_links, 4, 4)))

    def T_world_frame(self, q: np.ndarray, frame: str) -> np.ndarray:
        """World pose of 'tcp', 'cam' (OpenCV optical frame) or 'hand' (flange)."""
        return self.fk_links(q)[self.hand_index] @ self.T_hand_frame(frame)

    def T_world_hand(self, q: np.ndarray) -> np.ndarray:
        return self.T_world_frame(q, "hand")

    def T_world_tcp(self, q: np.ndarray) -> np.ndarray:
        return self.T_world_frame(q, "tcp")

    def T_world_cam(self, q: np.ndarray) -> np.ndarray:
        return self.T_world_frame(q, "cam")

    def jacobian(self, q: np.ndarray, frame: str = "tcp") -> np.ndarray:
        """Geometric Jacobian (6,7) of `frame`'s origin: linear rows first, world frame."""
        links = self.fk_links(q)
        p = (links[self.hand_index] @ self.T_hand_frame(frame))[:3, 3]
        t = self.tree
        return jacobian_kernel(links, p, t.joint_kind, t.joint_index, t.axis, t.anchor, np.empty((6, 7)))

    def manipulability(self, q: np.ndarray, frame: str = "tcp") -> float:
        """Yoshikawa manipulability sqrt(det(J J^T)) of the 6x7 Jacobian."""
        J = self.jacobian(q, frame)
        return float(np.sqrt(max(np.linalg.det(J @ J.T), 0.0)))

    # batches -----------------------------------------------------------------------
    def fk_links_batch(self, Q: np.ndarray) -> np.ndarray:
        """World poses (N,L,4,4) of all link frames for Q (N,7) [rad]."""
        Q = check_Q(Q)
        out = np.empty((Q.shape[0], self.n_links, 4, 4))
        return fk_links_batch_kernel(Q, *self.kernel_args(), out)

    def T_world_frame_batch(self, Q: np.ndarray, frame: str) -> np.ndarray:
        """(N,4,4) world poses of 'tcp', 'cam' or 'hand' for Q (N,7)."""
        return self.fk_links_batch(Q)[:, self.hand_index] @ self.T_hand_frame(frame)

    def T_world_tcp_batch(self, Q: np.ndarray) -> np.ndarray:
        return self.T_world_frame_batch(Q, "tcp")

    def T_world_cam_batch(self, Q: np.ndarray) -> np.ndarray:
        return self.T_world_frame_batch(Q, "cam")

    def T_world_hand_batch(self, Q: np.ndarray) -> np.ndarray:
        return self.T_world_frame_batch(Q, "hand")

    def jacobian_batch(self, Q: np.ndarray, frame: str = "tcp", links: np.ndarray | None = None) -> np.ndarray:
        """(N,6,7) geometric Jacobians for Q (N,7); links: `fk_links_batch(Q)` when the caller has it."""
        links = self.fk_links_batch(Q) if links is None else links
        P = (links[:, self.hand_index] @ self.T_hand_frame(frame))[:, :3, 3]
        t = self.tree
        out = np.empty((links.shape[0], 6, 7))
        jacobian_batch_kernel(links, np.ascontiguousarray(P), t.joint_kind, t.joint_index, t.axis, t.anchor, out)
        return out

    def manipulability_batch(self, Q: np.ndarray, frame: str = "tcp", links: np.ndarray | None = None) -> np.ndarray:
        """(N,) Yoshikawa manipulability for Q (N,7); links: `fk_links_batch(Q)` when the caller has it."""
        J = self.jacobian_batch(Q, frame, links)
        return np.sqrt(np.maximum(np.linalg.det(J @ np.swapaxes(J, 1, 2)), 0.0))
