"""The home-clearance gate of the certification: nothing of a scene may lie in the space a
method assumes free around the robot's start posture.

A method's world model (`exploration.world_model.WorldModel`) takes the unknown space within
`start_body_margin` [m] of the robot's spheres at the start configuration as free inside the
confined space's outer box, and within `start_free_margin` [m] outside it (the paper's
premise that the initial posture is safe, extended to a shell). The shell is marked on voxel
centres, so a voxel whose centre lies in it may hold geometry up to half a voxel diagonal
farther out. A scene whose boards, objects or base obstacles reach into that shell breaks the
premise: the method's first moves may sweep through them before any camera has seen them
(a finger touched a face-frame rail 0.03 mm deep so). The margins and the voxel size are read
from the method's own config (`WorldModelConfig`), never repeated here.

Cabinet boards and objects are held to the body margin, base obstacles to the larger outside
margin (conservative where an obstacle reaches into the space's box). The floor, which every
method knows (`Task.floor_z`), is not checked. Ground truth: for certification only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exploration.world_model import WorldModelConfig
from ..motion.primitives import PrimitiveSet
from ..robot.model import GRIPPER_MAX_WIDTH, RobotConfig
from ..robot.spheres import panda_sphere_model
from .scenes import SceneSpec


@dataclass(frozen=True)
class HomeClearance:
    """Clearances [m] between the robot's spheres at home (fingers open) and the scene:
    cabinet_m (boards and objects), obstacles_m (base obstacles; inf without), the required
    ones (the method's margin plus half a voxel diagonal) and the nearest item's name."""

    cabinet_m: float
    obstacles_m: float
    required_cabinet_m: float
    required_obstacles_m: float
    nearest: str

    @property
    def ok(self) -> bool:
        return self.cabinet_m >= self.required_cabinet_m and self.obstacles_m >= self.required_obstacles_m


def required_clearances(config: WorldModelConfig | None = None) -> tuple[float, float]:
    """(inside the confined space, outside it) [m]: the start shell's margins of the method's
    world model plus half its map's voxel diagonal."""
    config = config or WorldModelConfig()
    half_diag = 0.5 * math.sqrt(3.0) * config.map.resolution
    return config.start_body_margin + half_diag, config.start_free_margin + half_diag


def _clearance(items, centres: np.ndarray, radii: np.ndarray) -> tuple[float, str]:
    best, name = math.inf, ""
    for it in items:
        d = float(np.min(PrimitiveSet.from_shapes([it]).distance(centres) - radii))
        if d < best:
            best, name = d, it.name
    return best, name


def home_clearance(scene: SceneSpec, config: WorldModelConfig | None = None) -> HomeClearance:
    """The scene's clearance to the robot's spheres at its home configuration."""
    robot = RobotConfig(base_pos=scene.robot_base_pos, base_yaw=scene.robot_base_yaw)
    spheres = panda_sphere_model(robot, GRIPPER_MAX_WIDTH)
    centres = spheres.sphere_centers(np.asarray(robot.q_home)[None])[0]
    inside = scene.cabinet.boards() + [p for o in scene.objects for p in o.parts]
    d_cab, n_cab = _clearance(inside, centres, spheres.radii)
    d_obs, n_obs = _clearance(scene.base_obstacles, centres, spheres.radii)
    need_cab, need_obs = required_clearances(config)
    nearest = n_cab if d_cab - need_cab <= d_obs - need_obs else n_obs
    return HomeClearance(d_cab, d_obs, need_cab, need_obs, nearest)
