"""The MuJoCo world of one scene: model building, rendering, ray-cast depth, contacts.

Geom groups: 0 robot visuals, 1 static scene (floor, cabinet, base obstacles), 2 clutter,
3 target, 5 finger collision boxes (not rendered, not ray cast). Each object is one body
(free in physics) with one geom per part. Segmentation labels: 0 background, 1 robot,
2 floor, 3.. one per static primitive (`SceneSpec.static_primitives()` order), then one per
object (`SceneSpec.objects` order, the target last). Segmentation is ground truth: it is
rendered only when asked for (`render(seg=True)`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from ..errors import CompassInputError
from ..geometry import make_T
from ..robot.model import (FINGER_JOINTS, GRIPPER_MAX_WIDTH, MJCAM_TO_CV, RobotConfig, build_robot_spec,
                           check_q)
from ..types import Frame
from .rgbd import cull_outside_view, render_rgbd, view_planes
from .scenes import Primitive, SceneObject, SceneSpec

GROUP_ROBOT, GROUP_STATIC, GROUP_CLUTTER, GROUP_TARGET = 0, 1, 2, 3
_RAY_GROUPS = np.array([1, 1, 1, 1, 0, 0], dtype=np.uint8)
_TARGET_ONLY = np.array([0, 0, 0, 1, 0, 0], dtype=np.uint8)
_SCENE_GROUPS = np.array([0, 1, 1, 1, 0, 0], dtype=np.uint8)
LABEL_BACKGROUND, LABEL_ROBOT, LABEL_FLOOR = 0, 1, 2
#: Contact model of the physics mode: elliptic friction cones with frictional constraints
#: ten times harder than normal ones (MuJoCo's `impratio`). With MuJoCo's default (pyramidal
#: cone, impratio 1) a held object creeps down the fingers through soft friction: 6-12 mm in a
#: 2 s hold of a 0.09-0.16 kg can gripped with ~9 N per pad at mu = 1, where a real grasp with
#: a tenfold friction margin holds still. Objects: sliding friction 1.0 (rubber-like finger
#: pads on cans and bottles; a pair takes the larger of its two geoms' values), torsional
#: 0.01 m, rolling 0.001 m (condim 4).
CONE, IMPRATIO = mujoco.mjtCone.mjCONE_ELLIPTIC, 10.0
OBJECT_FRICTION = (1.0, 0.01, 0.001)


@dataclass(frozen=True)
class Contact:
    """A ground-truth contact between a robot geom and a scene geom (or two robot geoms)."""

    robot_geom: str
    other_geom: str
    depth: float  # penetration depth [m], >= 0
    pos: tuple[float, float, float]  # world position [m]


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def _geom_type(shape: str):
    return {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
            "sphere": mujoco.mjtGeom.mjGEOM_SPHERE}[shape]


def _size3(p: Primitive) -> list[float]:
    return list(p.size) + [0.0] * (3 - len(p.size))


def _add_static(spec, p: Primitive) -> None:
    spec.worldbody.add_geom(name=p.name, type=_geom_type(p.shape), size=_size3(p), pos=list(p.pos),
                            quat=_yaw_quat(p.yaw), rgba=list(p.rgba), group=GROUP_STATIC)


def _add_object(spec, obj: SceneObject, group: int) -> None:
    """One free body at the object's bounding-box centre, one geom per part; the mass is
    shared among the parts by volume."""
    origin = obj.pos
    body = spec.worldbody.add_body(name=obj.name, pos=list(origin))
    body.add_freejoint(name=f"{obj.name}_free")
    volume = sum(p.volume for p in obj.parts)
    for p in obj.parts:
        body.add_geom(name=p.name, type=_geom_type(p.shape), size=_size3(p), pos=list(np.asarray(p.pos) - origin),
                      quat=_yaw_quat(p.yaw), rgba=list(p.rgba), group=group, mass=obj.mass * p.volume / volume,
                      friction=list(OBJECT_FRICTION), condim=4)


def build_model(scene: SceneSpec, robot: RobotConfig | None = None) -> mujoco.MjModel:
    """Compile robot + scene into one MjModel. Robot joints first: qpos[0:7] arm, [7:9] fingers."""
    robot = replace(robot or RobotConfig(), base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw)
    spec = build_robot_spec(robot)
    spec.visual.quality.offsamples = 0
    spec.visual.global_.offwidth = max(640, robot.camera.width)
    spec.visual.global_.offheight = max(480, robot.camera.height)
    spec.stat.extent = 2.0
    spec.option.cone = CONE
    spec.option.impratio = IMPRATIO
    spec.visual.map.znear = 0.005  # x extent [m]
    spec.visual.map.zfar = 5.0
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    wb = spec.worldbody
    wb.add_light(name="top", pos=[0.6, 0.0, 2.0], dir=[0.0, 0.0, -1.0], diffuse=[0.6, 0.6, 0.6])
    wb.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3.0, 3.0, 0.05],
                pos=[0.0, 0.0, scene.floor_z], rgba=[0.82, 0.82, 0.8, 1.0], group=GROUP_STATIC)
    for p in scene.static_primitives():
        _add_static(spec, p)
    for obj in scene.clutter:
        _add_object(spec, obj, GROUP_CLUTTER)
    _add_object(spec, scene.target, GROUP_TARGET)
    return spec.compile()


class World:
    """One scene in MuJoCo: render frames, cast rays, report ground-truth contacts.

    The arm is placed kinematically by `set_q`; `physics.py` steps the same model with
    position control for grasping.
    """

    def __init__(self, scene: SceneSpec, robot: RobotConfig | None = None):
        self.scene = scene
        self.robot = replace(robot or RobotConfig(), base_pos=scene.robot_base_pos,
                             base_yaw=scene.robot_base_yaw)
        self.camera = self.robot.camera
        self.model = build_model(scene, self.robot)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._cam_id = m.camera("wrist_cam").id
        self._finger_qpos = [m.jnt_qposadr[m.joint(j).id] for j in FINGER_JOINTS]
        self._renderer: mujoco.Renderer | None = None
        #: leave geoms wholly outside the wrist camera's view out of its renders (the same
        #: images, `sim.rgbd.cull_outside_view`); False renders every geom
        self.cull_outside_view = True
        #: `contacts` lets MuJoCo test only the pairs with a robot geom (the same contacts,
        #: `_robot_only_scene_geoms`); False tests every pair as `mj_collision` does
        self.robot_pairs_only = True
        self._view_planes = view_planes(self.camera.K, self.camera.width, self.camera.height)
        self._ray_dirs_cam: np.ndarray | None = None
        # geom classification and labels
        body_root = m.body_rootid
        base_body = m.body("panda_link0").id
        self.is_robot_geom = body_root[m.geom_bodyid] == base_body
        names = [p.name for p in scene.static_primitives()] + [o.name for o in scene.objects]
        self.labels = {"background": LABEL_BACKGROUND, "robot": LABEL_ROBOT, "floor": LABEL_FLOOR}
        self.labels.update({n: i + 3 for i, n in enumerate(names)})
        self.target_label = self.labels[scene.target.name]
        part_owner = {p.name: o.name for o in scene.objects for p in o.parts}
        self.geom_label = np.zeros(m.ngeom, dtype=np.int32)
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
            if self.is_robot_geom[g]:
                self.geom_label[g] = LABEL_ROBOT
            elif name in part_owner:
                self.geom_label[g] = self.labels[part_owner[name]]
            elif name in self.labels:
                self.geom_label[g] = self.labels[name]
        #: geom ids of the target's parts, and a mask over all geoms
        self.target_geoms = np.array([m.geom(p.name).id for p in scene.target.parts], dtype=np.int32)
        self.is_target_geom = np.zeros(m.ngeom, dtype=bool)
        self.is_target_geom[self.target_geoms] = True
        self._floor_geom = m.geom("floor").id
        self._base_geom = m.geom("link0").id
        self._robot_body_depth = self._robot_tree_depth()
        self._scene_geoms = self._robot_only_scene_geoms()
        self.set_q(np.asarray(self.robot.q_home), GRIPPER_MAX_WIDTH)

    # ------------------------------------------------------------------ state
    def set_q(self, q: np.ndarray, finger_width: float | None = None) -> None:
        """Place the arm at q [rad] (and the fingers at `finger_width` [m]) kinematically."""
        q = check_q(q)
        self.data.qpos[:7] = q
        if finger_width is not None:
            if not (isinstance(finger_width, (int, float, np.integer, np.floating))
                    and 0.0 <= finger_width <= GRIPPER_MAX_WIDTH):
                raise CompassInputError(f"finger_width {finger_width!r} m is not allowed; "
                                        f"use 0..{GRIPPER_MAX_WIDTH} m")
            w = float(finger_width) / 2
            for a in self._finger_qpos:
                self.data.qpos[a] = w
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[:7].copy()

    def T_world_cam(self) -> np.ndarray:
        """Optical frame (OpenCV convention) at the current configuration."""
        R = self.data.cam_xmat[self._cam_id].reshape(3, 3) @ MJCAM_TO_CV[:3, :3]
        return make_T(R, self.data.cam_xpos[self._cam_id])

    # -------------------------------------------------------------- rendering
    def _get_renderer(self) -> mujoco.Renderer:
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, self.camera.height, self.camera.width)
            self._scene_option = mujoco.MjvOption()
            self._scene_option.geomgroup[:] = [1, 1, 1, 1, 0, 0]
        return self._renderer

    def _update_scene(self) -> mujoco.Renderer:
        r = self._get_renderer()
        r.update_scene(self.data, self._cam_id, self._scene_option)
        r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        if self.cull_outside_view:  # geoms wholly outside the wrist camera's view: no pixel
            cull_outside_view(r.scene, self.T_world_cam(), self._view_planes,
                              self.model.vis.map.znear * self.model.stat.extent, geom_aabb=self.model.geom_aabb)
        return r

    def render_depth(self) -> np.ndarray:
        """Depth image [m] at the current configuration (0 below depth_min, inf beyond depth_max)."""
        r = self._update_scene()
        r.enable_depth_rendering()
        depth = r.render().astype(np.float32)
        r.disable_depth_rendering()
        return self._apply_range(depth)

    def render_rgb(self) -> np.ndarray:
        r = self._update_scene()
        return r.render().copy()

    def render_rgbd(self) -> tuple[np.ndarray, np.ndarray]:
        """(RGB, depth [m]) at the current configuration from one GL pass (`sim.rgbd`);
        equal to `render_rgb()` and `render_depth()`."""
        rgb, depth = render_rgbd(self._update_scene())
        return rgb, self._apply_range(depth)

    def render_seg(self) -> np.ndarray:
        """Segmentation labels (H, W) int32: see the module docstring."""
        r = self._update_scene()
        r.enable_segmentation_rendering()
        raw = r.render()
        r.disable_segmentation_rendering()
        ids, types = raw[..., 0], raw[..., 1]
        seg = np.zeros(ids.shape, dtype=np.int32)
        is_geom = (ids >= 0) & (types == int(mujoco.mjtObj.mjOBJ_GEOM))
        seg[is_geom] = self.geom_label[ids[is_geom]]
        return seg

    def render(self, q: np.ndarray | None = None, t: float = 0.0, rgb: bool = True, seg: bool = False,
               raycast: bool = False) -> Frame:
        """A wrist-camera Frame at q (default: the current configuration) at time t [s].

        seg=True adds ground-truth segmentation labels (for metrics and figures only).

        raycast=True computes depth with `mj_multiRay` instead of OpenGL (no GL needed;
        RGB and segmentation are then not available).
        """
        if q is not None:
            self.set_q(q)
        if raycast:
            depth, image = self.raycast_depth(), None
        elif rgb:
            image, depth = self.render_rgbd()
        else:
            depth, image = self.render_depth(), None
        return Frame(
            depth=depth,
            rgb=image,
            seg=self.render_seg() if (seg and not raycast) else None,
            K=self.camera.K,
            T_world_cam=self.T_world_cam(),
            t=float(t),
            q=self.q,
        )

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # --------------------------------------------------------------- ray cast
    def _pixel_dirs_cam(self) -> np.ndarray:
        """(H*W, 3) camera-frame ray directions with z = 1 (so ray distance = z-depth)."""
        if self._ray_dirs_cam is None:
            K = self.camera.K
            u, v = np.meshgrid(np.arange(self.camera.width), np.arange(self.camera.height))
            x = (u - K[0, 2]) / K[0, 0]
            y = (v - K[1, 2]) / K[1, 1]
            self._ray_dirs_cam = np.stack([x, y, np.ones_like(x)], axis=-1).reshape(-1, 3)
        return self._ray_dirs_cam

    def cast_rays(self, origin: np.ndarray, dirs_world: np.ndarray, groups: np.ndarray = _RAY_GROUPS,
                  cutoff: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
        """Ray distances (in units of each direction's length; -1 = miss) and hit geom ids."""
        n = len(dirs_world)
        dist = np.empty(n, dtype=np.float64)
        gid = np.empty(n, dtype=np.int32)
        mujoco.mj_multiRay(self.model, self.data, np.asarray(origin, dtype=np.float64),
                           np.ascontiguousarray(dirs_world, dtype=np.float64).ravel(), groups, 1, -1,
                           gid, dist, None, n, cutoff)
        return dist, gid

    def raycast_depth(self) -> np.ndarray:
        """GL-free depth image [m] by `mj_multiRay`; equals `render_depth` on hit pixels."""
        T = self.T_world_cam()
        dirs = self._pixel_dirs_cam() @ T[:3, :3].T
        dist, _ = self.cast_rays(T[:3, 3], dirs)
        depth = np.where(dist < 0, np.inf, dist).astype(np.float32)
        return self._apply_range(depth.reshape(self.camera.height, self.camera.width))

    def _apply_range(self, depth: np.ndarray) -> np.ndarray:
        depth = depth.astype(np.float32, copy=True)
        depth[depth > self.camera.depth_max] = np.inf
        depth[depth < self.camera.depth_min] = 0.0
        return depth

    # --------------------------------------------------------------- contacts
    def _robot_tree_depth(self) -> np.ndarray:
        m = self.model
        depth = np.zeros(m.nbody, dtype=int)
        for b in range(1, m.nbody):
            depth[b] = depth[m.body_parentid[b]] + 1
        return depth

    def _robot_only_scene_geoms(self) -> np.ndarray | None:
        """The scene's geom ids: with their contype at 0 MuJoCo tests exactly the pairs with a
        robot geom that it tests with the model's own types (robot-scene and robot-robot),
        and none between scene geoms (objects resting on shelves), whose contacts
        `contacts` drops anyway. Exact when every colliding robot geom has contype equal to
        conaffinity and the model has no explicit pairs; None (every pair tested) otherwise."""
        m = self.model
        robot = self.is_robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
        if m.npair or np.any(m.geom_contype[robot] != m.geom_conaffinity[robot]):
            return None
        return np.flatnonzero(~self.is_robot_geom)

    def _self_pair_ignored(self, b1: int, b2: int) -> bool:
        """Robot body pairs that touch by construction (within two links of each other)."""
        m = self.model
        a, b = (b1, b2) if self._robot_body_depth[b1] >= self._robot_body_depth[b2] else (b2, b1)
        for _ in range(3):  # b is an ancestor of a within 3 steps (link7-link8-hand-finger chain)
            if a == b:
                return True
            a = m.body_parentid[a]
        # the two fingers share the hand
        return m.body_parentid[b1] == m.body_parentid[b2]

    def contacts(self, q: np.ndarray | None = None, finger_width: float | None = None,
                 include_self: bool = False) -> list[Contact]:
        """Ground-truth contacts of the robot at q with the scene (and itself if asked).

        The base link resting on the floor is not a contact. Contacts are reported only
        with penetration (distance < 0). Afterwards `data.contact` holds the robot's pairs
        only (`robot_pairs_only`).
        """
        if q is not None:
            self.set_q(q, finger_width)
        m, d = self.model, self.data
        if self.robot_pairs_only and self._scene_geoms is not None:
            contype = m.geom_contype.copy()
            m.geom_contype[self._scene_geoms] = 0
            try:
                mujoco.mj_collision(m, d)
            finally:
                m.geom_contype[:] = contype
        else:
            mujoco.mj_collision(m, d)
        out = []
        if d.ncon == 0:
            return out
        # only penetrating contacts with a robot geom (scene objects resting on each other are
        # most of d.contact: filtered as arrays, not one by one)
        geom, dist = d.contact.geom, d.contact.dist
        robot = self.is_robot_geom[geom]
        for i in np.flatnonzero(~(dist >= 0) & (robot[:, 0] | robot[:, 1])):
            c = d.contact[i]
            g1, g2 = int(geom[i, 0]), int(geom[i, 1])
            r1, r2 = robot[i, 0], robot[i, 1]
            if r1 and r2:
                if not include_self or self._self_pair_ignored(m.geom_bodyid[g1], m.geom_bodyid[g2]):
                    continue
            rg, og = (g1, g2) if r1 else (g2, g1)
            if rg == self._base_geom and og == self._floor_geom:
                continue
            out.append(Contact(self._geom_name(rg), self._geom_name(og), float(-c.dist), tuple(map(float, c.pos))))
        return out

    def in_collision(self, q: np.ndarray, finger_width: float | None = None, include_self: bool = True) -> bool:
        return bool(self.contacts(q, finger_width, include_self))

    def _geom_name(self, g: int) -> str:
        name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, g)
        if name:
            return name
        return f"{mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, self.model.geom_bodyid[g])}/geom{g}"

    def target_visibility(self, q: np.ndarray | None = None, stride: int = 1) -> float:
        """Fraction of the target's unoccluded image area visible from the wrist camera at q
        (the robot's own body may occlude it). See `visibility_from`."""
        if q is not None:
            self.set_q(q)
        return self.visibility_from(self.T_world_cam(), stride)

    def visibility_from(self, T_world_cam: np.ndarray, stride: int = 1, with_robot: bool = True) -> float:
        """Fraction of the target's unoccluded image area visible from a camera at T_world_cam.

        Rays are cast through the pixels of the target's projected bounding box, once
        against the scene (with or without the robot at its current configuration) and once
        against the target alone; the ratio of target hits within the depth range is returned
        (0 when the target is out of the image or beyond depth_max).
        """
        px = self._target_pixels(T_world_cam, stride)
        if px is None:
            return 0.0
        dirs = self._pixel_dirs_cam().reshape(self.camera.height, self.camera.width, 3)[px[1], px[0]]
        dirs_w = dirs @ T_world_cam[:3, :3].T
        dist_t, gid_t = self.cast_rays(T_world_cam[:3, 3], dirs_w, _TARGET_ONLY)
        on_target = (gid_t >= 0) & (dist_t > self.camera.depth_min) & (dist_t <= self.camera.depth_max)
        alone = np.count_nonzero(on_target)
        if alone == 0:
            return 0.0
        # only the rays that reach the target alone can see it: the scene is cast along those
        _, gid_all = self.cast_rays(T_world_cam[:3, 3], dirs_w[on_target], _RAY_GROUPS if with_robot else _SCENE_GROUPS)
        ok = gid_all >= 0
        seen = np.count_nonzero(self.is_target_geom[gid_all[ok]])
        return seen / alone

    def _target_pixels(self, T_world_cam: np.ndarray, stride: int):
        lo, hi = self.scene.target.aabb()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        pc = (corners - T_world_cam[:3, 3]) @ T_world_cam[:3, :3]
        if np.all(pc[:, 2] <= 1e-3):
            return None
        K = self.camera.K
        W, H = self.camera.width, self.camera.height
        if np.any(pc[:, 2] <= 1e-3):  # straddles the image plane: use the whole image
            u0, u1, v0, v1 = 0, W - 1, 0, H - 1
        else:
            u = K[0, 0] * pc[:, 0] / pc[:, 2] + K[0, 2]
            v = K[1, 1] * pc[:, 1] / pc[:, 2] + K[1, 2]
            u0, u1 = int(max(0, np.floor(u.min()))), int(min(W - 1, np.ceil(u.max())))
            v0, v1 = int(max(0, np.floor(v.min()))), int(min(H - 1, np.ceil(v.max())))
            if u0 > u1 or v0 > v1:
                return None
        uu, vv = np.meshgrid(np.arange(u0, u1 + 1, stride), np.arange(v0, v1 + 1, stride))
        return uu.ravel(), vv.ravel()


def see_through_geoms(world: World) -> list[int]:
    """Geom ids of the cabinet's top, side boards, face frame and shelves: the boards an
    overview draws see-through so the inside shows."""
    m = world.model
    return [m.geom(p.name).id for p in world.scene.cabinet.boards()
            if p.name in ("cab_top", "cab_left", "cab_right") or p.name.startswith(("frame_", "cab_shelf"))]


def overview_camera(world: World, azimuth: float = -35.0, elevation: float = -30.0,
                    distance: float = 1.7) -> tuple[mujoco.MjvCamera, mujoco.MjvOption]:
    """The free camera (front-left, above, aimed between the base and the cabinet; angles in
    deg, distance in m) and the visual option (collision geoms hidden) of an overview."""
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    lo, hi = np.array(world.scene.cabinet.interior_min), np.array(world.scene.cabinet.interior_max)
    cam.lookat[:] = 0.5 * (np.array([0.1, 0.0, 0.4]) + 0.5 * (lo + hi))
    cam.azimuth, cam.elevation, cam.distance = azimuth, elevation, distance
    opt = mujoco.MjvOption()
    opt.geomgroup[:] = [1, 1, 1, 1, 0, 0]
    return cam, opt


def render_overview(world: World, width: int = 640, height: int = 480, azimuth: float = -35.0,
                    elevation: float = -30.0, distance: float = 1.7) -> np.ndarray:
    """An RGB overview of the robot and the scene from a free camera (front-left, above).

    The cabinet's top and side boards are drawn see-through so the inside shows.
    """
    m = world.model
    see_through = see_through_geoms(world)
    alpha = m.geom_rgba[see_through, 3].copy()
    renderer = mujoco.Renderer(m, height, width)
    try:
        m.geom_rgba[see_through, 3] = 0.15
        cam, opt = overview_camera(world, azimuth, elevation, distance)
        renderer.update_scene(world.data, cam, opt)
        return renderer.render().copy()
    finally:
        m.geom_rgba[see_through, 3] = alpha
        renderer.close()
