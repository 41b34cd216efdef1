"""The trial's grasp-aware INSPECT (`trial.grasp_views.GraspInspector`) inside the grasp-only
harness, so `--grasp-only` measures what the trial does.

The harness has no exploration world model, so `HarnessModel` gives the inspector the same
interface over the harness's own map: `occ`, `swept` (the robot's way, its spheres grown by
the world model's `swept_margin`), `checker` (the trial's method's rules: unknown and
occupied unsafe, except the swept space and unknown space outside the confined space away
from seen obstacles, `exploration.world_model.WorldModel.checker`), `kin` and `spheres`. `inspect_views` runs the loop: each planned view is executed by
rendering depth frames along the path (every `frame_step` [rad]) into the map, with a
ground-truth contact check every `check_step` [rad] (the simulator's, as the trial's
executor does); a contact stops the loop and is reported."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError
from ..exploration.world_model import WorldModelConfig, method_safe_voxels, outside_space_mask
from ..grasp.field import FineMaps
from ..mapping.distance import DistanceField, mark_robot
from ..mapping.observe import integrate_observation
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..motion.primitives import DistanceGrid
from ..motion.timing import densify, segment_durations
from ..motion.validity import ValidityChecker
from ..robot.kinematics import PandaKinematics
from ..robot.model import GRIPPER_MAX_WIDTH


class HarnessModel:
    """The harness's map with the robot's way as its own space (module doc). frames: the depth
    frames integrated into occ so far (kept, with every frame `observe`d later, for
    `fine_map`; None: no fine map); max_range [m] of the sensor; fine_margin [m] around the
    target's points and upsample of the fine map (the harness's `GraspOnlyConfig`)."""

    def __init__(self, occ: OccupancyMap, spheres, robot, task, config: WorldModelConfig | None = None,
                 frames: list | None = None, max_range: float = 2.0, fine_margin: float = 0.2,
                 upsample: int = 2) -> None:
        if not 0.0 < max_range <= 10.0 or not 0.0 < fine_margin <= 1.0:
            raise CompassInputError(f"max_range {max_range} m / fine_margin {fine_margin} m not allowed; "
                                    "use (0, 10] and (0, 1] m")
        self.occ, self.spheres = occ, spheres
        self.frames = None if frames is None else list(frames)
        self.max_range, self.fine_margin, self.upsample = float(max_range), float(fine_margin), int(upsample)
        self._fine = FineMaps(occ, spheres, self.max_range)
        self.config = config or WorldModelConfig()
        self.kin = PandaKinematics(robot)
        self.swept_all = np.zeros(occ.shape, bool)
        self.assumed_free = outside_space_mask(occ, task, self.config.space_margin, self.config.floor_margin)
        self._checker = None

    def add_swept(self, Q: np.ndarray) -> None:
        """Mark the spheres of configurations Q (m,7) [rad], grown by margin, as the robot's."""
        mark_robot(self.swept_all, self.occ, self.spheres, Q, self.config.swept_margin)
        self._checker = None

    @property
    def swept(self) -> np.ndarray:
        return self.swept_all & (self.occ.state != VoxelState.OCCUPIED)

    @property
    def checker(self) -> ValidityChecker:
        if self._checker is None:  # the trial's method's rules (`WorldModel.checker`)
            safe = method_safe_voxels(self.occ, self.swept_all, self.assumed_free, self.config.obstacle_halo)
            field_ = DistanceField.from_map(self.occ, safe_voxels=safe)
            self._checker = ValidityChecker(self.spheres, grid=DistanceGrid.from_distance_field(field_),
                                            config=self.config.validity)
        return self._checker

    def observe(self, frame, max_range: float) -> None:
        integrate_observation(self.occ, frame, self.spheres, max_range)
        if self.frames is not None:
            self.frames.append(frame)
        self._checker = None

    def fine_map(self, points: np.ndarray) -> OccupancyMap | None:
        """The kept frames integrated at `upsample` x the map's resolution within fine_margin [m]
        of points (N,3) [m] (`grasp.field.local_fine_map`: the map the harness's selection
        gets); a box asked for before is kept and takes only the frames since. None without
        frames."""
        if not self.frames:
            return None
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return self._fine.get(pts.min(0) - self.fine_margin, pts.max(0) + self.fine_margin, self.upsample,
                              self.frames)


@dataclass(frozen=True, eq=False)
class HarnessInspection:
    """q_end (7,) [rad] where the inspection ended; n_views reached; n_plans attempted /
    succeeded; contacts: ground-truth contacts on the way ((geom, geom) pairs); paths (each
    (m,7) [rad]) the robot moved along; frames the depth frames rendered on the way (already
    integrated into the model's map)."""

    q_end: np.ndarray
    n_views: int
    n_plans: int
    n_planned: int
    contacts: tuple
    paths: tuple
    frames: tuple = ()

    @property
    def motion_s(self) -> float:
        """Simulated time [s] of the moves to the views (rest to rest through every waypoint,
        `motion.timing.segment_durations`)."""
        return float(sum(segment_durations(p).sum() for p in self.paths))


def inspect_views(world, model: HarnessModel, inspector, q_start: np.ndarray, detection, n_views: int,
                  frame_step: float = 0.1, check_step: float = 0.01, on_move=None) -> HarnessInspection:
    """Up to n_views grasp-aware INSPECT views from q_start (module doc). on_move: called with
    each reached path densified at 0.05 rad ((m,7) [rad]) as soon as the robot has moved
    along it (e.g. the harness's own-space mask, which the next step's needed voxels read)."""
    q = np.asarray(q_start, dtype=np.float64)
    n_plans = n_planned = reached = 0
    paths: list[np.ndarray] = []
    frames: list = []
    for _ in range(n_views):
        p = inspector(q, detection)
        if not p.planned:
            break
        n_plans += getattr(p, "n_calls", 1)
        if p.path is None:
            break
        n_planned += 1
        dense = densify(np.asarray(p.path), check_step)
        for qc in dense:
            hit = world.contacts(qc, GRIPPER_MAX_WIDTH, include_self=True)
            if hit:
                world.set_q(q, GRIPPER_MAX_WIDTH)
                return HarnessInspection(q, reached, n_plans, n_planned, tuple(hit), tuple(paths), tuple(frames))
        for qf in densify(np.asarray(p.path), frame_step)[1:]:
            frames.append(world.render(qf, rgb=False, seg=False))
            model.observe(frames[-1], world.camera.depth_max)
        model.add_swept(dense[:: max(1, int(0.05 / check_step))])
        if on_move is not None:
            on_move(densify(np.asarray(p.path), 0.05))
        paths.append(np.asarray(p.path))
        q = np.asarray(p.path)[-1]
        reached += 1
    world.set_q(q, GRIPPER_MAX_WIDTH)
    return HarnessInspection(q, reached, n_plans, n_planned, (), tuple(paths), tuple(frames))
