"""The grasp's own map: every depth frame of the trial at the grasp's resolution.

The exploration methods map at 2 cm (`exploration.world_model.default_map_config`, chosen for
the speed of their information-gain views). At 2 cm every seen neighbour of the target is a
2 cm cube, and the grasp's sound hand check loses up to half a voxel diagonal more: measured on
the 20 trials of seed 202 (levels 1-4, scenes 0-4), in 11 of them not one in-cone candidate's
hand was clear at the grasp even with all unknown space taken as free. `GraspMap` is a trial
observer that integrates the same depth frames (the robot's own camera; no ground truth) into
a 1 cm map (`mapping.occupancy.MapConfig()`, the grasp-only harness's) and marks the space the
arm moved through (`swept`); GRASP selects on it and INSPECT counts its hypotheses' voxels on
it. It also keeps the frames' depth images (no colour) so that GRASP can integrate them again
at 5 mm around the detected target (`grasp.field.local_fine_map`, as the grasp-only harness
does; `keep_frames`). `GraspWorld` gives `trial.grasp_views.GraspInspector` this map with the method's own
validity checker (the views are still planned on the method's map, by its rules)."""
from __future__ import annotations

from collections import deque

import numpy as np

from ..errors import CompassInputError
from ..exploration.world_model import start_shell
from ..grasp.field import FineMaps
from ..mapping.distance import mark_robot
from ..mapping.observe import integrate_observation
from ..mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from ..motion.timing import densify
from ..robot.spheres import panda_sphere_model
from ..types import Observation
from .observer import TrialObserver


class GraspMap(TrialObserver):
    """Integrates every frame into `occ` (map_config, default 1 cm) up to max_range [m]; the
    arm's spheres grown by swept_margin [m] along every motion (sampled every sweep_step
    [rad]) and at the start (grown by start_margin [m]; given the Task, only by
    start_body_margin [m] inside the confined space's box, as the method's world model,
    `exploration.world_model.start_shell`) are its own space (`swept`); with
    keep_frames every frame's observation (depth, K, pose, q; colour dropped) is kept in
    `frames`, in order, for `fine_map`.

    Frames are integrated into `occ`, and motions marked into `swept_all`, when these are
    read (frames in order: the same map as integrating each on arrival; the marks are a
    union, in one pass): a trial that never reaches INSPECT or GRASP (the target not found)
    pays nothing for this map."""

    def __init__(self, robot, map_config: MapConfig | None = None, max_range: float = 1.5,
                 swept_margin: float = 0.05, start_margin: float = 0.10, sweep_step: float = 0.05,
                 keep_frames: bool = True, task=None, start_body_margin: float = 0.05) -> None:
        self._occ = OccupancyMap(map_config or MapConfig())
        self._pending: deque[Observation] = deque()  # frames not yet integrated into _occ, in order
        self.keep_frames = bool(keep_frames)
        self.frames: list[Observation] = []
        self.spheres = panda_sphere_model(robot)
        self.max_range, self.swept_margin, self.start_margin, self.sweep_step = \
            max_range, swept_margin, start_margin, sweep_step
        self.task, self.start_body_margin = task, start_body_margin
        self._swept_all = np.zeros(self._occ.shape, bool)
        self._unmarked: list[np.ndarray] = []  # configurations (m, 7) [rad] of motions not yet marked
        self._way: list[np.ndarray] = []
        self._fine = FineMaps(self._occ, self.spheres, max_range)  # one fine map per box, kept

    @property
    def occ(self) -> OccupancyMap:
        """The 1 cm map with every frame so far integrated (the pending ones first, in order)."""
        while self._pending:
            integrate_observation(self._occ, self._pending[0], self.spheres, self.max_range)
            self._pending.popleft()
        return self._occ

    @property
    def swept_all(self) -> np.ndarray:
        """(nx,ny,nz) bool: the arm's spheres at the start and along every motion so far."""
        if self._unmarked:
            Q, self._unmarked = np.vstack(self._unmarked), []
            mark_robot(self._swept_all, self._occ, self.spheres, Q, self.swept_margin)
        return self._swept_all

    @property
    def swept(self) -> np.ndarray:
        """(nx,ny,nz) bool: the robot's own space, less voxels seen occupied."""
        return self.swept_all & (self.occ.state != VoxelState.OCCUPIED)

    @property
    def way(self) -> np.ndarray:
        """(m, 7) [rad]: the configurations the arm moved through (every sweep_step), in order."""
        return np.vstack(self._way) if self._way else np.zeros((0, 7))

    def start(self, world, method) -> None:
        q = np.asarray(world.q, dtype=np.float64)[None]
        if self.task is None:
            mark_robot(self._swept_all, self._occ, self.spheres, q, self.start_margin)
        else:  # as the method's world model: inside the confined space's box only the body margin
            self._swept_all |= start_shell(self.occ, self.spheres, q[0], self.start_body_margin, self.start_margin,
                                          self.task)
        self._way.append(q)

    def motion(self, trajectory, t_start: float, t_end: float) -> None:
        Q = np.asarray(densify(np.asarray(trajectory.q), self.sweep_step), dtype=np.float64)
        self._unmarked.append(Q)
        self._way.append(Q)

    def frame(self, frame, method) -> None:
        obs = frame.observation()
        kept = Observation(obs.depth, None, obs.K, obs.T_world_cam, obs.t, obs.q)  # colour is not needed
        self._pending.append(kept)
        if self.keep_frames:
            self.frames.append(kept)

    def fine_map_around(self, points: np.ndarray, margin: float, upsample: int = 2) -> OccupancyMap:
        """`fine_map` over the box of points (N,3) [m] grown by margin [m]: one box for the
        GRASP stage and INSPECT's hypotheses alike, so both read the same cached map."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return self.fine_map(pts.min(0) - margin, pts.max(0) + margin, upsample)

    def fine_map(self, lo: np.ndarray, hi: np.ndarray, upsample: int = 2) -> OccupancyMap:
        """Every kept frame integrated again into a map `upsample` times finer than occ over
        the box lo..hi (3,) [m] (`grasp.field.local_fine_map`, aligned with occ's voxels).
        The map of a box asked for before is kept and only the frames since are integrated
        into it (the same map as integrating all of them afresh: frames go in in order)."""
        if not self.keep_frames:
            raise CompassInputError("GraspMap.fine_map needs keep_frames=True (no frames were kept)")
        return self._fine.get(lo, hi, upsample, self.frames)


class GraspWorld:
    """The world model `GraspInspector` reads: the grasp map's occ and swept, the method's
    world model's checker, kinematics and spheres; with fine_margin [m], `fine_map(points)`
    gives the grasp map's frames at `upsample` times its resolution within fine_margin of
    the target's points (the GRASP stage's fine map), else None."""

    def __init__(self, grasp_map: GraspMap, method_world, fine_margin: float | None = None,
                 upsample: int = 2) -> None:
        self.grasp_map, self.method_world = grasp_map, method_world
        self.fine_margin, self.upsample = fine_margin, upsample

    def fine_map(self, points: np.ndarray) -> OccupancyMap | None:
        if self.fine_margin is None or not self.grasp_map.frames:
            return None
        return self.grasp_map.fine_map_around(points, self.fine_margin, self.upsample)

    @property
    def occ(self) -> OccupancyMap:
        return self.grasp_map.occ

    @property
    def swept(self) -> np.ndarray:
        return self.grasp_map.swept

    @property
    def checker(self):
        return self.method_world.checker

    @property
    def kin(self):
        return self.method_world.kin

    @property
    def spheres(self):
        return self.method_world.spheres
