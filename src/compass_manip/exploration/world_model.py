"""What a method knows of the world while it explores: the occupancy map, the space the
arm itself has swept, and the validity checker built from both.

Unknown space is unsafe for motion. The only exception is unknown space the robot's own
body has occupied (proprioception: the arm was there, so nothing else is), inflated by
`swept_margin` [m] so that the configuration the arm rests in is not flagged against its
own unobserved surroundings (the margin must exceed the checker's margin plus half a voxel
diagonal plus a voxel). The start configuration counts as swept. Voxels seen occupied stay
unsafe even inside the swept space.

The margin alone would let the arm creep: a motion may end with a sphere up to ~3 cm beyond
where it has been, in unknown space the margin called free, and the next executed path grows
the swept space around that new position, so that motion after motion the arm could reach
farther into unseen space (three level-4 trials grazed an unseen bar that way). The creep
guard (`creep_guard`) forbids it: the voxels whose centres the robot's spheres grown by
`touch_margin` [m] have covered along executed paths (`touched`, sampled every `touch_step`
[rad]; the start shell counts) are the only unknown voxels outside the assumed-free space a
new motion's spheres, grown and sampled the same way, may cover (`creeps`). With the same
marking and test, the unknown space the arm may enter never grows; only seen free space
does (and with it the unknown voxels next to it, `creep_anchor`). Retracing an executed
path and the short escapes out of an invalidated configuration are exempt (the methods'
rule, `compass.py`, `escape.py`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..mapping.distance import mark_in_spheres, mark_robot, robot_covers_any, unsafe_mask
from ..mapping.distance_incremental import CappedDistance
from ..mapping.frontiers import FrontierCluster, FrontierConfig, find_frontiers
from ..mapping.observe import integrate_observation
from ..mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from ..motion.primitives import DistanceGrid
from ..motion.timing import densify
from ..motion.validity import ValidityChecker, ValidityConfig
from ..robot.kinematics import PandaKinematics
from ..robot.model import RobotConfig
from ..robot.spheres import panda_sphere_model
from ..types import Observation
from .halo import ObstacleHalo, manhattan_dilate  # noqa: F401 (manhattan_dilate: used here and imported from here)


def default_map_config() -> MapConfig:
    """2 cm voxels over the arm's workspace: distance field ~9 ms, frontiers ~1 ms,
    100 information-gain views ~3 ms on this machine (1 cm: 130 / 8 / 10 ms).

    OctoMap's update rule (`surface_guard=False`, `sticky_hits=0`), not the grasp maps'
    surface guard: on the side-by-side run (seed 101, 140 trials) the guard left COMPASS's
    and its ablations' trials without a contact either way, but made the finds slower
    (Level-3 mean TFT 21.6 s against 8.4 s), cost `compass-no-nfa` one Level-1 target and
    costs ~7 ms more per frame; the exploration's checker keeps its margins and obstacle
    halo instead. The grasp's 1 cm and 5 mm maps keep the guard (docs/grasping.md)."""
    return MapConfig(resolution=0.02, surface_guard=False, sticky_hits=0)


@dataclass(frozen=True)
class WorldModelConfig:
    """map: occupancy map settings; max_range [m] of depth integration; swept_margin [m]
    inflation of the robot's spheres when marking swept space safe; sweep_step [rad] joint
    step at which executed paths are sampled for the swept volume; validity: the checker's
    margins and edge step; frontiers: clustering; start_free_margin [m]: inflation of the
    robot's spheres at the start configuration assumed free (the paper's premise that the
    initial posture is safe, extended to a shell around it so the wrist can start the
    near-field scan; seen obstacles still count); inside the confined space's outer box
    (grown by its wall and one voxel), whose boards and face frame the Task leaves unknown,
    only start_body_margin [m] is (a finger touched an unseen face-frame rail 1.4 cm in
    front of it with the full shell; 5 cm lets the start posture and its first moves be
    valid on the 2 cm map); assume_free_outside_space: unknown voxels
    outside the confined space's outer box (its interior grown by the wall thickness plus
    space_margin [m], extended down to the floor) and more than floor_margin [m] above the
    floor count as free for motion, as the paper's planner treats all unknown space (inside
    the confined space, where the clutter is, unknown stays unsafe), except within
    obstacle_halo [m] of a voxel seen occupied (an obstacle seen in part probably goes on);
    near_base_box ((min), (max)) [m] relative to the base: where unknown stays unsafe outside
    the confined space too (None: nowhere); creep_guard: refuse new motions whose spheres
    (grown by touch_margin [m], sampled every touch_step [rad]) cover unknown voxels the arm
    has not covered before (module docstring); touch_margin: at least half a voxel diagonal,
    so that every voxel a sphere reaches into is counted; creep_anchor [m] (L1): unknown
    voxels this close to a voxel seen free may be covered too (one 2 cm voxel: the
    level-2 finds of the pure guard, 16/20 on the development trials, back to 20/20; the
    allowance is measured from seen free space, never from covered space, so it does not
    accumulate)."""

    map: MapConfig = field(default_factory=default_map_config)
    max_range: float = 1.5
    swept_margin: float = 0.05
    start_free_margin: float = 0.10
    start_body_margin: float = 0.05
    assume_free_outside_space: bool = True
    space_margin: float = 0.06
    floor_margin: float = 0.05
    obstacle_halo: float = 0.08
    near_base_box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    sweep_step: float = 0.05
    creep_guard: bool = True
    touch_margin: float = 0.018
    touch_step: float = 0.02
    creep_anchor: float = 0.02
    validity: ValidityConfig = field(default_factory=lambda: ValidityConfig(margin=0.005, edge_resolution=0.02))
    frontiers: FrontierConfig = field(default_factory=lambda: FrontierConfig(min_cluster_size=4))

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, max_range=(0.05, 10.0, "m"), swept_margin=(0.0, 0.5, "m"),
                     start_free_margin=(0.0, 0.5, "m"), start_body_margin=(0.0, 0.5, "m"),
                     space_margin=(-0.5, 0.5, "m"), floor_margin=(0.0, 1.0, "m"), obstacle_halo=(0.0, 0.5, "m"),
                     sweep_step=(1e-3, 1.0, "rad"), touch_margin=(0.0, 0.5, "m"), touch_step=(1e-3, 1.0, "rad"),
                     creep_anchor=(0.0, 0.5, "m"))
        box = None
        if self.near_base_box is not None and not isinstance(self.near_base_box, (str, bytes)):
            try:
                box = np.asarray(self.near_base_box, dtype=float)
            except (TypeError, ValueError):
                box = None
        if self.near_base_box is not None and (box is None or box.shape != (2, 3) or not np.isfinite(box).all()
                                               or not (box[0] < box[1]).all()):
            raise CompassInputError(f"WorldModelConfig.near_base_box = {self.near_base_box!r:.60} is not allowed; "
                                    "use None or ((x, y, z) min, (x, y, z) max) [m] with min < max")


def outside_space_mask(occ: OccupancyMap, task, margin: float, floor_margin: float) -> np.ndarray:
    """(nx, ny, nz) bool: voxels outside the confined space's outer box grown by margin [m]
    (extended down to the floor) and higher than floor_margin [m] above the floor."""
    inside = space_box_mask(occ, task, task.space.wall_thickness + margin, down_to_floor=True)
    return ~inside & (occ.voxel_centers()[..., 2] > task.floor_z + floor_margin)


def space_box_mask(occ: OccupancyMap, task, grow: float, down_to_floor: bool = False) -> np.ndarray:
    """(nx, ny, nz) bool: voxels whose centres lie in the confined space's interior box
    grown by grow [m] on every side (and, if down_to_floor, extended down to the floor)."""
    sp = task.space
    lo = np.asarray(sp.interior_min, float) - grow
    hi = np.asarray(sp.interior_max, float) + grow
    if down_to_floor:
        lo[2] = task.floor_z - 1.0
    c = occ.voxel_centers()
    return np.all((c >= lo) & (c <= hi), axis=-1)


def fresh_spheres(centers: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    """(m, S) bool: the spheres of m configurations (centers (m, S, 3) [m], one radius per
    sphere index) whose centre differs from the same sphere's in the configuration before
    (for the first one: in `previous` (S, 3), the last configuration already marked with the
    same radii, or None). A sphere equal to one already marked covers the same voxels, so
    marking only the fresh ones sets the same mask (the fixed base's spheres, the joint path's
    start, where the last path ended)."""
    fresh = np.ones(centers.shape[:2], bool)
    fresh[1:] = np.any(centers[1:] != centers[:-1], axis=2)
    if previous is not None:
        fresh[0] = np.any(centers[0] != previous, axis=1)
    return fresh


def assumed_free_mask(occ: OccupancyMap, task, config: WorldModelConfig) -> np.ndarray:
    """(nx, ny, nz) bool: the unknown space a method with `config` takes as free on occ's grid:
    outside the confined space's box (`outside_space_mask`) unless `near_base_box` holds it;
    nothing without a task or with `assume_free_outside_space` off."""
    if task is None or not config.assume_free_outside_space:
        return np.zeros(occ.shape, bool)
    out = outside_space_mask(occ, task, config.space_margin, config.floor_margin)
    if config.near_base_box is not None:
        base = np.asarray(task.robot_base_pos, float)
        lo = base + np.asarray(config.near_base_box[0])
        hi = base + np.asarray(config.near_base_box[1])
        c = occ.voxel_centers()
        out &= ~np.all((c >= lo) & (c <= hi), axis=-1)
    return out


def method_safe_voxels(occ: OccupancyMap, swept: np.ndarray, assumed_free: np.ndarray, obstacle_halo: float,
                       halo_of=None) -> np.ndarray:
    """(nx, ny, nz) bool: the voxels a method's validity checker takes as safe besides free
    ones: the robot's swept space and the unknown space assumed free (outside the confined
    space, `outside_space_mask`) farther than obstacle_halo [m] (L1) from a seen obstacle;
    voxels seen occupied never count. halo_of: a function occupied -> the halo mask for
    obstacle_halo (`halo.ObstacleHalo.near`, kept between calls), None: `manhattan_dilate`."""
    occupied = occ.occupied_mask()
    halo = int(round(obstacle_halo / occ.resolution))
    if halo > 0 and assumed_free.any():
        near = manhattan_dilate(occupied, halo) if halo_of is None else halo_of(occupied)
        assumed_free = assumed_free & ~near
    return (swept | assumed_free) & ~occupied


def capped_field(checker: ValidityChecker, resolution: float) -> CappedDistance:
    """The distance field for this checker on a grid of that resolution [m], capped where
    its verdicts stop depending on it (`ValidityChecker.grid_cap_m`) and updated where the map
    changed (`mapping.distance_incremental`): the same verdicts as the full field."""
    return CappedDistance(resolution, int(math.ceil(checker.grid_cap_m(resolution) / resolution)) + 1)


def guard_root_band(validity: ValidityConfig, resolution: float) -> float:
    """[m] around the robot's spheres within which `WorldModel.guarded_checker` leaves the
    guard's voxels to the checker's usual rule: its clearance (margin plus half a voxel
    diagonal) and one voxel for the field's interpolation between voxel centres."""
    return validity.margin + (math.sqrt(3) / 2 + 1.0) * resolution


def start_shell(occ: OccupancyMap, spheres, q_start: np.ndarray, body_margin: float, free_margin: float,
                task=None) -> np.ndarray:
    """(nx, ny, nz) bool: the start posture q_start (7,) [rad]'s spheres grown by body_margin
    [m] (the robot is there) and the shell of free_margin [m] around them, except inside the
    confined space's outer box grown by its wall thickness and one voxel (task None: no box):
    its boards, face frame and contents are what the Task leaves unknown, and a hand that
    starts near the opening must see them before it moves there."""
    q = np.asarray(q_start, dtype=np.float64).reshape(1, 7)
    body = np.zeros(occ.shape, bool)
    mark_robot(body, occ, spheres, q, body_margin)
    shell = np.zeros(occ.shape, bool)
    mark_robot(shell, occ, spheres, q, free_margin)
    if task is not None:
        shell &= ~space_box_mask(occ, task, task.space.wall_thickness + occ.resolution)
    return body | shell


class WorldModel:
    """Occupancy map + swept space + validity checker of one trial (one per method)."""

    def __init__(self, q_start: np.ndarray, config: WorldModelConfig | None = None,
                 robot: RobotConfig | None = None, task=None) -> None:
        self.config = config or WorldModelConfig()
        self.robot = robot or RobotConfig()
        self.occ = OccupancyMap(self.config.map)
        self.spheres = panda_sphere_model(self.robot)
        self.kin = PandaKinematics(self.robot)
        self.swept = np.zeros(self.occ.shape, bool)
        self.q = np.asarray(q_start, dtype=np.float64).copy()
        self._checker: ValidityChecker | None = None
        self._base_checker: ValidityChecker | None = None
        self._field: CappedDistance | None = None  # the distance field, updated where the map changed
        self._frontiers: tuple[FrontierCluster, ...] | None = None
        self._halo = None  # the obstacle halo, kept between checker rebuilds (`halo.ObstacleHalo`)
        self.assumed_free = assumed_free_mask(self.occ, task, self.config)
        self._mark_start_shell(task)
        self._touched = self.swept.copy()  # the unknown voxels a new motion may cover (creep guard)
        self._to_touch: list[np.ndarray] = []  # executed paths not yet marked in it (marked when asked)
        self._untouched: np.ndarray | None = None
        self._anchor = ObstacleHalo(int(round(self.config.creep_anchor / self.occ.resolution)))  # near seen free
        self._unsafe: np.ndarray | None = None  # the checker's unsafe mask
        self._guarded: ValidityChecker | None = None
        self._guard_field: CappedDistance | None = None

    def _mark_start_shell(self, task) -> None:
        self.swept |= start_shell(self.occ, self.spheres, self.q, self.config.start_body_margin,
                                  self.config.start_free_margin, task)
        self._marked = (self.spheres.sphere_centers(self.q[None])[0], float(self.config.start_body_margin))

    def observe(self, obs: Observation) -> None:
        integrate_observation(self.occ, obs, self.spheres, self.config.max_range)
        self._checker = self._guarded = None
        self._frontiers = None
        self._untouched = None

    def add_swept(self, path: np.ndarray, margin: float | None = None) -> None:
        """Mark the space the arm occupied along a joint path (m, 7) [rad], inflated by
        margin [m] (default swept_margin), as safe."""
        margin = self.config.swept_margin if margin is None else float(margin)
        Q = densify(np.asarray(path, dtype=np.float64).reshape(-1, 7), self.config.sweep_step)
        c = self.spheres.sphere_centers(Q)  # the same mask as mark_robot, without the spheres already marked
        last, last_margin = self._marked
        fresh = fresh_spheres(c, last if last_margin == margin else None)
        radii = np.broadcast_to(self.spheres.radii + margin, fresh.shape)
        mark_in_spheres(self.swept, self.occ.grid_min, self.occ.resolution, c[fresh], radii[fresh])
        self._marked = (c[-1].copy(), margin)
        self.q = np.asarray(path, dtype=np.float64).reshape(-1, 7)[-1].copy()
        self._checker = self._guarded = None
        if self.config.creep_guard:
            self._to_touch.append(np.asarray(path, dtype=np.float64).reshape(-1, 7).copy())
            self._untouched = None

    @property
    def touched(self) -> np.ndarray:
        """(nx, ny, nz) bool: the voxels the robot's spheres grown by touch_margin have covered
        at the executed paths' configurations every touch_step, and the start shell (marked
        when first asked for: the baselines share this model and never ask)."""
        for path in self._to_touch:
            mark_robot(self._touched, self.occ, self.spheres, self._touch_samples(path), self.config.touch_margin)
        self._to_touch.clear()
        return self._touched

    def _touch_samples(self, path: np.ndarray) -> np.ndarray:
        return densify(np.asarray(path, dtype=np.float64).reshape(-1, 7), self.config.touch_step)

    def creeps(self, path: np.ndarray) -> bool:
        """True if the joint path (m, 7) [rad] would take the arm into unknown space it has
        not covered before (its spheres grown by touch_margin, sampled every touch_step,
        cover an unknown voxel outside `touched` and the assumed-free space); always False
        without the creep guard."""
        if not self.config.creep_guard:
            return False
        return robot_covers_any(self.untouched, self.occ, self.spheres, self._touch_samples(path),
                                self.config.touch_margin)

    @property
    def untouched(self) -> np.ndarray:
        """(nx, ny, nz) bool: the unknown voxels a new motion may not cover under the creep
        guard (not touched, not assumed free, farther than creep_anchor from seen free space)."""
        if self._untouched is None:
            self._untouched = (self.occ.state == VoxelState.UNKNOWN) & ~self.touched & ~self.assumed_free
            if self._anchor.r > 0:  # the seen free space's L1 halo, kept between map updates
                self._untouched &= ~self._anchor.near(self.occ.state == VoxelState.FREE)
        return self._untouched

    @property
    def guarded_checker(self) -> ValidityChecker:
        """`checker` with the creep guard's `untouched` voxels unsafe too, except those within
        `guard_root_band` of the robot's spheres at the current configuration (the checker's
        clearance, wider than touch_margin, would otherwise flag the configuration the arm
        rests in): trees and scans grown on it keep to the motions the guard admits, up to
        that band, and `creeps` still decides exactly. `checker` itself without the guard;
        cached like it."""
        if not self.config.creep_guard:
            return self.checker
        if self._guarded is None:
            base = self.checker
            near_q = np.zeros(self.occ.shape, bool)
            mark_robot(near_q, self.occ, self.spheres, self.q[None], guard_root_band(self.config.validity,
                                                                                    self.occ.resolution))
            unsafe = self._unsafe | (self.untouched & ~near_q)
            if self._guard_field is None:
                self._guard_field = capped_field(self._base_checker, self.occ.resolution)
            grid = DistanceGrid(self._guard_field.update(unsafe), self.occ.grid_min, self.occ.resolution)
            self._guarded = base.with_grid(grid)
        return self._guarded

    @property
    def checker(self) -> ValidityChecker:
        """Validity against the current map (unknown unsafe, swept space safe); cached
        until the next observation or executed path."""
        if self._checker is None:
            if self._halo is None:
                self._halo = ObstacleHalo(int(round(self.config.obstacle_halo / self.occ.resolution)))
            safe = method_safe_voxels(self.occ, self.swept, self.assumed_free, self.config.obstacle_halo,
                                      self._halo.near)
            unsafe = self._unsafe = unsafe_mask(self.occ, safe_voxels=safe)
            if self._base_checker is None:  # packs the robot's spheres once (~15 ms); sizes the field's cap
                self._base_checker = ValidityChecker(self.spheres, config=self.config.validity)
                self._field = capped_field(self._base_checker, self.occ.resolution)
            grid = DistanceGrid(self._field.update(unsafe), self.occ.grid_min, self.occ.resolution)
            self._checker = self._base_checker.with_grid(grid)
        return self._checker

    @property
    def frontiers(self) -> tuple[FrontierCluster, ...]:
        if self._frontiers is None:
            self._frontiers = find_frontiers(self.occ, self.config.frontiers)
        return self._frontiers
