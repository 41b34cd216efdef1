"""The root config of a trial: every component's frozen config in one record, saved with
each result (`TrialConfig.to_dict()` is JSON-able)."""
from __future__ import annotations

import enum
from dataclasses import dataclass, field, fields, is_dataclass

from ..errors import CompassInputError, check_field_types
from ..exploration.compass import CompassConfig
from ..grasp.robot_space import check_near_body_yaw
from ..grasp.select import GraspSelectConfig
from ..grasp.target import TargetConfig
from ..motion.timing import TimingConfig
from ..perception.buffer import BufferConfig
from ..perception.detector import DETECTORS, DetectorConfig
from ..sim.grasp_exec import GraspExecConfig
from ..sim.advance import AdvanceConfig
from ..sim.keyframes import KeyframeRule
from .grasp_looks import BaseLookConfig
from .grasp_scan import TrialScanConfig
from .inspect import InspectConfig
from .verify import VerifyConfig

#: Detector kinds a trial may use: the registered image detectors plus the oracle.
ORACLE_DETECTOR = "oracle-segmentation"
#: the paper's grasp ablation as a trial method: COMPASS's exploration, then the grasp
#: selection without its constraints (`GraspSelectConfig(constrained=False)`)
GRASP_ABLATION_METHOD = "compass-no-grasp-constraints"


@dataclass(frozen=True)
class ClockConfig:
    """The simulated clock: each decision costs `planning_charge_s` [s] (fixed: the same seed
    gives a bit-identical trial), or its measured compute time when `measured` is True."""

    planning_charge_s: float = 0.1
    measured: bool = False

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if not 0.0 <= self.planning_charge_s <= 60.0:
            raise CompassInputError(f"planning_charge_s {self.planning_charge_s} must be in 0..60 s")


@dataclass(frozen=True)
class SensingConfig:
    """Camera frames along every trajectory (a frame is also rendered at the end of every
    motion): a fixed frame_rate [Hz] (the default), or keyframes, a
    `sim.keyframes.KeyframeRule` (a frame when the camera has moved 10 cm or turned 0.5 rad
    since the last one, at least every 1.5 s), which saves about a tenth of the frames but
    sees less on the way (seed 404, Level 3, scene 3: COMPASS ran into the time limit with
    keyframes and found the target at 29.7 s with 3 Hz); check_step [rad] of the
    ground-truth contact checks; advance: their conservative advancement (`sim.advance`:
    samples proven contact-free are not tested, the same contacts; None: every sample)."""

    frame_rate: float = 3.0
    check_step: float = 0.005
    keyframes: KeyframeRule | None = None
    advance: AdvanceConfig | None = None

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if self.advance is not None and not isinstance(self.advance, AdvanceConfig):
            raise CompassInputError(f"SensingConfig.advance = {self.advance!r:.40} is not allowed; "
                                    "use an AdvanceConfig or None")
        if self.keyframes is not None and not isinstance(self.keyframes, KeyframeRule):
            raise CompassInputError(f"SensingConfig.keyframes = {self.keyframes!r:.40} is not allowed; "
                                    "use a KeyframeRule or None")
        if not 0.0 <= self.frame_rate <= 1000.0:  # as sim.executor.ExecutorConfig, checked before the trial
            raise CompassInputError(f"SensingConfig.frame_rate = {self.frame_rate} Hz is not allowed; use 0..1000 Hz")
        if not 1e-4 <= self.check_step <= 0.5:
            raise CompassInputError(f"SensingConfig.check_step = {self.check_step} rad is not allowed; "
                                    "use 1e-4..0.5 rad")


@dataclass(frozen=True)
class GraspTrialConfig:
    """The GRASP state: enabled (False: find-only, FOUND is terminal, as the exploration
    baselines are compared); target model, selection (`constrained=False` is the paper's
    ablation) and physics execution settings; moved_margin [m] added to the robot's spheres
    along its executed way (its own space in the map), max_moved_configs of that way used;
    near_body_free: unknown voxels the arm's links 0-4 sweep near home count as free (an
    assumption: a wrist camera never sees the space its own elbow moves through);
    inspect: the INSPECT views between FOUND and GRASP (`trial.inspect.InspectConfig`;
    n_views=0: off): views chosen for the unknown space the grasp hypotheses need
    (`trial.grasp_views`); since branch sevt (2026-11-24, fourth session) with the escape
    from a start the method's checker refuses and up to 3 view groups planned a step
    (`escape=True, plan_groups=3`), still without the looks up (`n_up=0`): end to end on
    the fresh seed 9595 (levels 2 + 4, scenes 0-4) 1/10 grasped against 0/10 (level 2 scene 1:
    the best group of views had no path twice, the second group did), on seeds 5151 and 101
    (levels 2 + 4) 0/20 both, levels 1 + 3 of seeds 101 and 2026 as many as before, no
    collision trial in any (docs/grasping_log.md, "The severe levels end to end"). The looks
    up stay off: with them (`trial_variants:insp_all`) seed 101 level 3 scene 2 was lost, and
    with the former +-1.2 rad near-body volume they ran link 4 into an unseen base wall on seed
    101 level 3 scene 0 (`insp_all_yaw12`, branch insp's collision; not with today's +-0.6
    rad: `insp_all`, `insp_all_noscan`); grasp_map: GRASP and INSPECT use a 1 cm map of every depth frame
    (`trial.grasp_map`) instead of the method's (2 cm for the exploration methods); with it,
    fine_map: the grasp map's frames integrated again at 5 mm within fine_margin [m] of the
    target's points for the hand's checks (as in the grasp-only harness); scan: the
    near-field scan before INSPECT (`trial.grasp_scan`, on the grasp map; `TrialScanConfig()`,
    up to 8 views, the default since 2026-11-24's second session, together with near_body_yaw
    0.6: `max_views=0` turns it off). With the wide near-body volume (1.2 rad) the scan grasped
    more (26/50 against 16/50) but collided more (5 collision trials against 2: the elbow on
    unseen lateral base walls, which no scan sees); with the narrow one it grasps as many as
    the former defaults (scan off, 1.2 rad) with no collision: 19/50 and 0 collision trials
    against 19/50 and 3 over seeds 101 + 2026 (levels 1 + 3, scenes 0-4), 5151 (levels 1-2,
    scenes 0-4), 7777 and 4242 (level 3, scenes 0-9; 4242 fresh for both); docs/grasping_log.md,
    "Beside the base: no view, and the elbow must go there");
    plan_via_home: when no path to the pre-grasps plans directly, the selection tries one via
    the home posture (`select_grasp(q_via=...)`); near_body_halo [m]: the near-body
    assumption leaves out unknown voxels within this L1 distance of a voxel seen occupied,
    as the method's own rule does (`WorldModelConfig.obstacle_halo`; 0: off); near_body_yaw
    [rad]: the near-body volume is swept with joint 1 within this of home's (0.6 by default
    since 2026-11-24's second session, with the scan; 1.2 before: alone, without the scan,
    0.6 kept the elbow off an unseen lateral base wall on seed 5151 level 3 scene 2 but
    grasped 3/20 instead of 10/20 on seeds 101 + 2026; docs/grasping_log.md, "The near field
    the arm needs is never seen"). The defaults
    (since 2026-11-23): the grasp map with its fine map, 20 INSPECT views and an 8 cm halo,
    with `method_swept` (`benchmarks/trial_variants.py`' `grasp_inspect_halo` before): end to
    end on levels 1 and 3, scenes 0-4, 9/20 over seeds 101 and 2026 with 1 collision trial
    (seed 101, level 3 scene 4: link 3 on an unseen base wall in the transfer, the near-body
    assumption's risk; docs/grasping.md, "Where it stands"); the former defaults (the
    method's 2 cm map, 6 INSPECT views, no halo) 0/7 on seed 101, and without the near-body
    assumption (`grasp_inspect_own`) 0/6 on seed 2026. Before `method_swept` this configuration gave 3/20
    on seed 101 and 0/20 with 1 collision trial on seed 2026 (link 3 on a base wall in the
    transfer, through unseen space the near-body assumption took as free).
    outside_free: the unknown space the
    method's own validity checker takes as free (outside the confined space's box, farther
    than its obstacle halo from anything seen; `exploration.world_model.assumed_free_mask`)
    is free for INSPECT's hypotheses and GRASP too: the arm moved under that rule all
    through the exploration, and its elbow at a grasp pose is where a wrist camera seldom
    looks. verify: look before moving (`trial.verify.VerifyConfig`, None: off): the grasp chosen
    (optimistically, with the assumptions above) is executed only when every voxel its
    transfer, approach and lift sweep is seen free or the robot's own; until then look views
    of those voxels are executed and the grasp re-selected (`GRASP_UNVERIFIED` when the budget
    is spent). Measured (docs/grasping.md, "Look before moving"): 0/10 with 0 collision trials on
    seed 101 L1/L3 seen-free only; with `VerifyConfig.trust_outside_space` 2/10 there but 2
    collision trials on seed 2026: off by default. method_swept: the method's own space (its
    world model's swept space: the executed way grown by its swept_margin, the start posture's
    shell outside the confined space) is the robot's own for GRASP too, as INSPECT counts its
    hypotheses' voxels and the method itself moves (before, GRASP took only the way grown by
    moved_margin, so INSPECT stopped on hypotheses the selection then refused). looks: when INSPECT
    ends, up to `looks.max_looks` looks at its hypotheses' needed voxels outside the confined
    space (beside and in front of the base), then back the way the arm came
    (`trial.grasp_looks.BaseLookConfig`; 0 looks: off)."""

    enabled: bool = True
    target: TargetConfig = field(default_factory=TargetConfig)
    select: GraspSelectConfig = field(default_factory=GraspSelectConfig)
    execute: GraspExecConfig = field(default_factory=GraspExecConfig)
    moved_margin: float = 0.02
    max_moved_configs: int = 400
    near_body_free: bool = True
    inspect: InspectConfig = field(default_factory=lambda: InspectConfig(n_views=20, n_up=0, escape=True,
                                                                         plan_groups=3))
    grasp_map: bool = True
    fine_map: bool = True
    fine_margin: float = 0.2
    scan: TrialScanConfig = field(default_factory=TrialScanConfig)
    plan_via_home: bool = False
    outside_free: bool = False
    near_body_halo: float = 0.08
    near_body_yaw: float = 0.6
    verify: VerifyConfig | None = None
    method_swept: bool = True
    looks: BaseLookConfig = field(default_factory=BaseLookConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if not 0.02 <= self.fine_margin <= 0.5:
            raise CompassInputError(f"fine_margin {self.fine_margin} m is not allowed; use 0.02..0.5 m")
        if self.verify is not None and not isinstance(self.verify, VerifyConfig):
            raise CompassInputError(f"GraspTrialConfig.verify = {self.verify!r:.40} is not allowed; "
                                    "use a VerifyConfig or None")
        check_near_body_yaw(self.near_body_yaw)
        if not 0.0 <= self.near_body_halo <= 0.3:
            raise CompassInputError(f"near_body_halo {self.near_body_halo} m is not allowed; use 0..0.3 m")
        if not 0.0 <= self.moved_margin <= 0.1 or not 1 <= self.max_moved_configs <= 100000:
            raise CompassInputError(f"moved_margin {self.moved_margin} m / max_moved_configs "
                                    f"{self.max_moved_configs} not allowed; use 0..0.1 m and 1..100000")


@dataclass(frozen=True)
class TrialConfig:
    """method: the exploration config shared by all registered methods; detector /
    detector_kind: the image detector ('appearance', or the oracle 'oracle-segmentation'
    for ablations); buffer: the detection window; clock; sensing; timing: trajectory
    limits (Panda datasheet, scaled); time_limit_s [s]; surroundings_margin [m] of the
    target region whose explored fraction is recorded; grasp: the GRASP state after FOUND
    (`GraspTrialConfig(enabled=False)` for find-only trials)."""

    method: CompassConfig = field(default_factory=CompassConfig)
    detector: DetectorConfig = field(default_factory=DetectorConfig)
    detector_kind: str = "appearance"
    buffer: BufferConfig = field(default_factory=BufferConfig)
    clock: ClockConfig = field(default_factory=ClockConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    timing: TimingConfig = field(default_factory=lambda: TimingConfig(velocity_scale=0.5, acceleration_scale=0.5))
    time_limit_s: float = 200.0
    surroundings_margin: float = 0.1
    grasp: GraspTrialConfig = field(default_factory=GraspTrialConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        kinds = (*DETECTORS, ORACLE_DETECTOR)
        if self.detector_kind not in kinds:
            raise CompassInputError(f"detector_kind {self.detector_kind!r} is not one of {kinds}")
        if not 0 < self.time_limit_s <= 3600:
            raise CompassInputError(f"time_limit_s {self.time_limit_s} must be in (0, 3600] s")
        if not 0.0 <= self.surroundings_margin <= 1.0:
            raise CompassInputError(f"TrialConfig.surroundings_margin = {self.surroundings_margin} m is not allowed; "
                                    "use 0..1 m")

    def to_dict(self) -> dict:
        return _jsonable(self)


def _jsonable(x):
    if is_dataclass(x):
        return {f.name: _jsonable(getattr(x, f.name)) for f in fields(x)}
    if isinstance(x, enum.Enum):
        return x.name
    if isinstance(x, (tuple, list)):
        return [_jsonable(v) for v in x]
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    return x
