"""Panda arm + hand + wrist RGB-D camera as a model: assets, limits, home pose, camera mount.

The MJCF comes from `dm-robotics-panda` (Apache-2.0, installed with --no-deps). This module
only assembles an `mujoco.MjSpec`; it renders nothing and holds no simulator state, so the
kinematics and planning layers may use it too.

Frames: `hand` is the Franka hand flange frame (z along the fingers), `tcp` lies 0.1034 m
along hand z between the fingertips, `cam` is the optical frame of the wrist camera in the
OpenCV convention (+z forward, +x right, +y down).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError
from ..geometry import make_T, quat_to_R

N_ARM_JOINTS = 7
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("hand/panda_finger_joint1", "hand/panda_finger_joint2")

#: Joint limits [rad] of the Panda (Franka datasheet, same as the MJCF).
Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
_Q_LO, _Q_HI = Q_MIN - 1e-9, Q_MAX + 1e-9  # check_q's tolerance
#: Velocity [rad/s], acceleration [rad/s^2] and jerk [rad/s^3] limits (Franka datasheet).
QD_MAX = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
QDD_MAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
QDDD_MAX = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0])

#: Home configuration [rad]: the wrist camera looks horizontally along +x into the
#: workspace in front of the robot (camera at about (0.29, 0, 0.70) m, optical axis level).
Q_HOME = np.array([0.0, -1.1, 0.0, -2.9, 0.0, 3.37, 0.785])

#: Hand flange -> TCP (between the fingertips) [m].
T_HAND_TCP = make_T(t=[0.0, 0.0, 0.1034])
#: Maximum finger opening (distance between the fingers) [m].
GRIPPER_MAX_WIDTH = 0.08

# MuJoCo cameras look along their -z with +y up; OpenCV optical frames look along +z, +y down.
#: MuJoCo camera frame -> OpenCV optical frame (the same axes, y and z flipped).
MJCAM_TO_CV = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class CameraConfig:
    """Wrist RGB-D camera (RealSense D435-like defaults).

    width, height [px]; fovy_deg vertical field of view [deg]; depth_min/depth_max [m]
    valid depth range; pos_hand [m] and rpy_hand [rad] mount of the optical frame on the hand
    flange (optical axis along hand +z by default, i.e. looking where the fingers point).
    """

    width: int = 320
    height: int = 240
    fovy_deg: float = 58.0
    depth_min: float = 0.1
    depth_max: float = 2.0
    pos_hand: tuple[float, float, float] = (0.065, 0.0, 0.035)
    rpy_hand: tuple[float, float, float] = (0.0, 0.0, math.pi / 2)

    def __post_init__(self) -> None:
        if not (16 <= self.width <= 4096 and 16 <= self.height <= 4096):
            raise CompassInputError(
                f"camera size {self.width}x{self.height} px is not allowed; use 16..4096 px per side"
            )
        if not 10.0 <= self.fovy_deg <= 150.0:
            raise CompassInputError(f"camera fovy {self.fovy_deg} deg is not allowed; use 10..150 deg")
        if not 0.0 < self.depth_min < self.depth_max:
            raise CompassInputError(
                f"depth range {self.depth_min}..{self.depth_max} m is not allowed; need 0 < min < max"
            )

    @property
    def K(self) -> np.ndarray:
        """3x3 pinhole intrinsics [px]: square pixels, principal point at the image centre.

        Pixel (u, v) = (column, row) has its centre at integer coordinates (OpenCV), so the
        principal point is ((W - 1) / 2, (H - 1) / 2).
        """
        f = 0.5 * self.height / math.tan(math.radians(self.fovy_deg) / 2.0)
        cx, cy = (self.width - 1) / 2.0, (self.height - 1) / 2.0
        return np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])

    @property
    def T_hand_cam(self) -> np.ndarray:
        """Optical frame (OpenCV convention) in the hand flange frame."""
        r, p, y = self.rpy_hand
        from ..geometry import rot_x, rot_y, rot_z

        return make_T(rot_z(y) @ rot_y(p) @ rot_x(r), self.pos_hand)


@dataclass(frozen=True)
class RobotConfig:
    """Robot base pose and camera. base_pos [m], base_yaw [rad] in the world."""

    base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_yaw: float = 0.0
    camera: CameraConfig = field(default_factory=CameraConfig)
    q_home: tuple[float, ...] = tuple(Q_HOME)


def assets_dir() -> str:
    """Folder of the Panda MJCF + meshes shipped by dm-robotics-panda."""
    try:
        import dm_robotics  # type: ignore
    except ImportError as exc:  # pragma: no cover - install problem
        raise RuntimeError(
            "dm-robotics-panda is not installed: run `make test` or "
            "`pip install --no-deps dm-robotics-panda==0.4.8`"
        ) from exc
    path = os.path.join(list(dm_robotics.__path__)[0], "panda", "assets", "panda")
    if not os.path.isfile(os.path.join(path, "panda.xml")):
        raise RuntimeError(f"Panda assets not found in {path}; reinstall dm-robotics-panda==0.4.8")
    return path


def check_q(q: np.ndarray, name: str = "q") -> np.ndarray:
    """Return q as a float64 (7,) array or raise naming the bad value and the limits."""
    if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (N_ARM_JOINTS,) \
            and ((q >= _Q_LO) & (q <= _Q_HI)).all():  # the common case, in one test (NaN fails it)
        return q
    try:
        q = np.asarray(q, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{name} must be 7 joint angles [rad], got {q!r:.80}") from exc
    if q.shape != (N_ARM_JOINTS,):
        raise CompassInputError(f"{name} must have 7 joint angles [rad], got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise CompassInputError(f"{name} contains NaN or inf: {np.array2string(q, precision=3)}")
    bad = np.nonzero((q < Q_MIN - 1e-9) | (q > Q_MAX + 1e-9))[0]
    if bad.size:
        i = int(bad[0])
        raise CompassInputError(
            f"{name}[{i}] = {q[i]:.4f} rad is outside joint {i + 1}'s limits "
            f"[{Q_MIN[i]:.4f}, {Q_MAX[i]:.4f}] rad"
        )
    return q


def build_robot_spec(config: RobotConfig | None = None, actuators: bool = True):
    """Assemble the Panda arm + hand + wrist camera as an `mujoco.MjSpec`.

    Arm joints get position actuators (armature 0.1, implicitfast integrator) and the hand
    its tendon actuator (ctrl 0 = closed, 1 = open). The camera `wrist_cam` and a small box
    geom `camera_housing` for the camera body are added to the hand.
    """
    import mujoco

    config = config or RobotConfig()
    cam = config.camera
    A = assets_dir()
    arm = mujoco.MjSpec.from_file(os.path.join(A, "panda.xml"))
    hand = mujoco.MjSpec.from_file(os.path.join(A, "panda_hand.xml"))
    ws = arm.site("wrist_site")
    ws.quat = [math.cos(-math.pi / 8), 0.0, 0.0, math.sin(-math.pi / 8)]
    arm.attach(hand, prefix="hand/", site=ws)
    arm.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    arm.option.timestep = 0.002

    base = arm.body("panda_link0")
    base.pos = list(config.base_pos)
    base.quat = [math.cos(config.base_yaw / 2), 0.0, 0.0, math.sin(config.base_yaw / 2)]

    for i in range(N_ARM_JOINTS):
        j = arm.joint(ARM_JOINTS[i])
        j.armature = 0.1
        if actuators:
            kp = [4500, 4500, 3500, 3500, 2000, 2000, 2000][i]
            f = [87.0] * 4 + [12.0] * 3
            a = arm.add_actuator(name=f"arm{i + 1}", target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            a.set_to_position(kp=kp, kv=kp / 10)
            a.forcelimited = True
            a.forcerange = [-f[i], f[i]]
    if not actuators:
        for act in list(arm.actuators):
            arm.delete(act)

    hand_body = arm.body("hand/panda_hand")
    T_hand_mjcam = cam.T_hand_cam @ MJCAM_TO_CV
    from ..geometry import R_to_quat

    hand_body.add_camera(
        name="wrist_cam",
        pos=list(T_hand_mjcam[:3, 3]),
        quat=list(R_to_quat(T_hand_mjcam[:3, :3])),
        fovy=cam.fovy_deg,
    )
    # The camera body (D435-like, 90 x 25 x 25 mm) behind its optical centre.
    hand_body.add_geom(
        name="camera_housing",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.045, 0.0125, 0.0125],
        pos=list(cam.T_hand_cam[:3, :3] @ [0.0, 0.0, -0.0135] + cam.T_hand_cam[:3, 3]),
        quat=list(R_to_quat(cam.T_hand_cam[:3, :3])),
        rgba=[0.15, 0.15, 0.15, 1.0],
        mass=0.07,
    )
    return arm


def T_world_base(config: RobotConfig | None = None) -> np.ndarray:
    """Robot base (panda_link0) pose in the world."""
    config = config or RobotConfig()
    yaw = config.base_yaw
    return make_T(quat_to_R([math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]), config.base_pos)
