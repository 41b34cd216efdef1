"""A near-field scan between FOUND and GRASP: look at the space around the robot's body that
the arm needs on its way into the confined space, so the grasp assumes none of it free.

The grasp's selection takes unknown space as unsafe. The arm configurations of a grasp deep in
a cabinet put links 2-4 0.2-0.4 m from the base, where a wrist camera that looked into the
cabinet never looked (diagnosed in docs/grasping_log.md on the grasp-only harness, whose own
near-field scan, `sim.near_field`, fixed it there). The trial's grasp stage assumed that
space free instead (`GraspTrialConfig.near_body_free`). `NearFieldScanner` is the trial's
version of the harness's scan with nothing from the simulator: the candidates are the
harness's (`sim.near_field.scan_candidates`: joint 1 turned, joints 2 and 4 bent, the wrist
anywhere), kept when valid for the method's own checker; each is scored by the unknown
voxels of the box around the base (`NearFieldScanConfig.box_min/box_max`) its camera sees on
the grasp's 1 cm map (`mapping.infogain`, the exploration's gain); the shared planner (the
method's checker) takes the best `n_goals`. A step whose best gain is below `min_gain`, or
whose plan fails, ends the scan; then the calls go to `then` (the grasp-aware INSPECT). The
machine executes each plan like an INSPECT view (it counts in MPSR, its frames feed the maps).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types
from ..exploration.nfa import safe_box_map
from ..exploration.viewpoints import view_pose
from ..exploration.world_model import method_safe_voxels
from ..mapping.distance import unsafe_mask
from ..mapping.occupancy import VoxelState
from ..mapping.self_occlusion import robot_view_gains
from ..motion.planner import DEFAULT_MAX_CHECKS, PlannerConfig, plan
from ..motion.primitives import DistanceGrid
from ..motion.validity import ValidityChecker
from ..robot.ik import PandaIK
from ..robot.model import Q_MAX, Q_MIN
from ..sim.near_field import NearFieldScanConfig, scan_candidates
from .inspect import InspectPlan


@dataclass(frozen=True)
class TrialScanConfig:
    """max_views scan views at most (0: off); candidates: how they are sampled and scored
    (`sim.near_field.NearFieldScanConfig`: n_candidates per step, the joint ranges, the box
    relative to the base, rays, max_range; its max_views is not used); target_margin [m]
    of the box around the target's points whose unknown voxels count too; way_candidates
    configurations next to the way moved (joints 1-4 by way_sigma [rad], 5-7 by wrist_sigma
    [rad], normal); min_gain [voxels]
    the best view must see to be taken; n_goals best views handed to the planner; assumed_free:
    the views are checked and planned on the method's checker with the unknown space the GRASP
    stage itself takes as free also free (the near-body assumption, `grasp_stage.assumed_unknown_free`;
    `survey_checker`): the scan's arm may stand where the grasp's arm would go anyway, and its
    camera then sees beside and in front of the base, which no view valid for the method alone
    sees (docs/grasping_log.md, "IG and COMPASS at GRASP"); n_back: camera poses a step that look
    back at the elbow's band beside the base (`back_candidates`: a random unknown voxel of
    back_band [m], relative to the base, mirrored to either side, seen from a random eye point in
    back_eye [m] in front of the base), solved by camera IK and kept, like the others, when valid
    for the scan's checker (0: none); return_back: when the scan ends, the arm first goes back
    along the scan's own paths to where the scan started (`NearFieldScanner.way_back`: a look
    back leaves the arm folded towards the base, from where the grasp's transfer seldom plans);
    self_occlusion: the gain leaves out the rays the arm's own body blocks at each candidate
    (`mapping.self_occlusion`; off by default: measured in docs/grasping_log.md)."""

    max_views: int = 8
    min_gain: int = 40
    n_goals: int = 5
    way_candidates: int = 300
    way_sigma: float = 0.05
    wrist_sigma: float = 0.4
    target_margin: float = 0.2
    candidates: NearFieldScanConfig = field(default_factory=NearFieldScanConfig)
    planner: PlannerConfig = field(default_factory=lambda: PlannerConfig(max_checks=2 * DEFAULT_MAX_CHECKS))
    assumed_free: bool = False
    n_back: int = 0
    return_back: bool = False
    back_band: tuple[tuple[float, float, float], tuple[float, float, float]] = ((-0.1, 0.15, 0.3), (0.35, 0.45, 0.8))
    back_eye: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.25, -0.35, 0.55), (0.6, 0.35, 1.05))
    self_occlusion: bool = False

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if isinstance(self.max_views, bool) or not isinstance(self.max_views, int) or not 0 <= self.max_views <= 20:
            raise CompassInputError(f"max_views {self.max_views!r} is not allowed; use an integer 0..20")
        if self.min_gain < 0 or not 1 <= self.n_goals <= 100 or not 0 <= self.way_candidates <= 10000:
            raise CompassInputError(f"min_gain {self.min_gain} / n_goals {self.n_goals} / way_candidates "
                                    f"{self.way_candidates} not allowed; use >= 0, 1..100 and 0..10000")
        if isinstance(self.n_back, bool) or not isinstance(self.n_back, int) or not 0 <= self.n_back <= 1000:
            raise CompassInputError(f"n_back {self.n_back!r} is not allowed; use an integer 0..1000")
        if not 0.0 <= self.target_margin <= 0.5:
            raise CompassInputError(f"target_margin {self.target_margin} m is not allowed; use 0..0.5 m")
        if not 0.0 <= self.way_sigma <= 1.0 or not 0.0 <= self.wrist_sigma <= 3.0:
            raise CompassInputError(f"way_sigma {self.way_sigma} / wrist_sigma {self.wrist_sigma} rad not allowed; "
                                    "use 0..1 and 0..3")


def survey_checker(wm, free_of) -> ValidityChecker:
    """The method's validity checker (world model `wm`: occ, swept, assumed_free, config,
    spheres) on a field where the unknown voxels `free_of(occ)` ((nx, ny, nz) bool on wm.occ's
    grid) count as free besides the method's own safe space (voxels seen occupied never do)."""
    occ = wm.occ
    safe = method_safe_voxels(occ, wm.swept, wm.assumed_free, wm.config.obstacle_halo)
    safe |= np.asarray(free_of(occ), dtype=bool) & (occ.state == VoxelState.UNKNOWN)
    grid = DistanceGrid.from_unsafe_mask(unsafe_mask(occ, safe_voxels=safe), occ.grid_min, occ.resolution)
    return ValidityChecker(wm.spheres, config=wm.config.validity).with_grid(grid)


def back_candidates(occ, base: np.ndarray, config: TrialScanConfig, ik, q_ref: np.ndarray,
                    rng: np.random.Generator) -> np.ndarray:
    """(m, 7) [rad] camera-IK configurations (up to 2 a pose) of config.n_back poses, each
    looking at a random unknown voxel of occ inside `back_band` (relative to base (3,) [m],
    |y| taken on either side) from a random eye point in `back_eye`, 0.25-0.9 m away, rolled
    at random; none when the band holds no unknown voxel."""
    if config.n_back == 0:
        return np.zeros((0, 7))
    (x0, y0, z0), (x1, y1, z1) = config.back_band
    out = []
    for side in (1.0, -1.0):
        lo = base + np.array([x0, min(side * y0, side * y1), z0])
        hi = base + np.array([x1, max(side * y0, side * y1), z1])
        a = np.clip(occ.world_to_voxel(lo[None])[0], 0, occ.shape)
        b = np.clip(occ.world_to_voxel(hi[None])[0] + 1, 0, occ.shape)
        idx = np.argwhere(occ.state[a[0]:b[0], a[1]:b[1], a[2]:b[2]] == VoxelState.UNKNOWN) + a
        if len(idx):
            out.append(occ.voxel_to_world(idx))
    if not out:
        return np.zeros((0, 7))
    looks = np.vstack(out)
    e_lo, e_hi = base + np.asarray(config.back_eye[0]), base + np.asarray(config.back_eye[1])
    Q = []
    for _ in range(config.n_back):
        look = looks[rng.integers(len(looks))]
        eye = rng.uniform(e_lo, e_hi)
        d = float(np.linalg.norm(look - eye))
        if not 0.25 <= d <= 0.9:
            continue
        T = view_pose(look, (look - eye) / d, d, rng.uniform(-np.pi, np.pi))
        Q.extend(ik.solve(T, "cam", q_ref, 4, retry=False).solutions[:2])
    return np.array(Q).reshape(-1, 7)


class NearFieldScanner:
    """The scan (module doc) as an INSPECT step: call with (q_current (7,) [rad], detection)
    -> `trial.inspect.InspectPlan`. occ_of(): the grasp's map now; wm: the method's world
    model (checker, kin); K (3,3) and image_size (w, h) of the camera; q_home (7,) [rad];
    base_pos (3,) [m]; then: the INSPECT step called once the scan has ended (None: stop);
    way_of(): (m, 7) [rad] configurations the arm moved through (None: none); checker_of():
    the validity checker the scan's candidates and plans use (None: `wm.checker`; with
    `TrialScanConfig.assumed_free` the runner passes `survey_checker`'s).
    `views` counts the scan plans returned, `stopped` says why the scan ended."""

    def __init__(self, occ_of, wm, K: np.ndarray, image_size: tuple[int, int], q_home: np.ndarray,
                 base_pos: np.ndarray, config: TrialScanConfig, rng: np.random.Generator, then=None,
                 way_of=None, checker_of=None) -> None:
        if not isinstance(rng, np.random.Generator):
            raise CompassInputError(f"rng {rng!r:.40} is not allowed; give an explicit np.random.Generator")
        self.occ_of, self.wm, self.then, self.rng, self.config = occ_of, wm, then, rng, config
        self.way_of = way_of
        self.checker_of = checker_of
        self.K, self.image_size = np.asarray(K, dtype=np.float64), tuple(image_size)
        self.q_home = np.asarray(q_home, dtype=np.float64)
        self.base = np.asarray(base_pos, dtype=np.float64)
        self.views, self.stopped, self.gains = 0, None, []
        self._scratch = None
        self._ik = None
        self.back_valid: list[tuple[int, int]] = []  # per step: look-back candidates, of them valid
        self._paths: list[np.ndarray] = []  # the scan's views' paths, in order (for `way_back`)
        self._returned = False

    def step(self, q_current: np.ndarray, detection=None) -> InspectPlan | None:
        """One scan view planned from q_current, or None (the scan is over: `stopped` says why)."""
        t0 = time.perf_counter()
        c = self.config.candidates
        Q = np.vstack([scan_candidates(self.q_home, c.n_candidates, self.rng, c), self.near_way(q_current)])
        n_way = len(Q)
        if self.config.n_back:
            if self._ik is None:
                self._ik = PandaIK(self.wm.kin)
            Q = np.vstack([Q, back_candidates(self.occ_of(), self.base, self.config, self._ik,
                                              np.asarray(q_current, dtype=np.float64), self.rng)])
        checker = self.wm.checker if self.checker_of is None else self.checker_of()
        ok = np.asarray(checker.are_valid(Q), dtype=bool)
        self.back_valid.append((int(len(Q) - n_way), int(ok[n_way:].sum())))
        Q = Q[ok]
        if len(Q) == 0:
            self.stopped = "no valid candidate"
            return None
        occ = self.occ_of()
        self._scratch = safe_box_map(occ, self.base + c.box_min, self.base + c.box_max, self._scratch)
        if detection is not None and len(np.asarray(detection.points_world).reshape(-1, 3)):
            pts = np.asarray(detection.points_world, dtype=np.float64).reshape(-1, 3)
            lo = np.clip(occ.world_to_voxel((pts.min(0) - self.config.target_margin)[None])[0], 0, occ.shape)
            hi = np.clip(occ.world_to_voxel((pts.max(0) + self.config.target_margin)[None])[0] + 1, 0, occ.shape)
            sl = tuple(slice(a, b) for a, b in zip(lo, hi))
            self._scratch.state[sl] = occ.state[sl]
        T = self.wm.kin.T_world_cam_batch(Q)
        gains = robot_view_gains(self.wm, self._scratch, Q, T, self.K, c.max_range, c.rays, self.image_size,
                                 self.config.self_occlusion)
        order = np.argsort(-gains, kind="stable")
        order = order[gains[order] >= self.config.min_gain][: self.config.n_goals]
        if len(order) == 0:
            self.stopped = f"best gain {int(gains.max())} < {self.config.min_gain}"
            return None
        res = plan(np.asarray(q_current, dtype=np.float64), Q[order], checker, self.config.planner, self.rng)
        if not res.success:
            self.stopped = "no path"
            return None
        gain = int(gains[order[res.goal_index]])
        self.gains.append(gain)
        return InspectPlan(res.path, gain, len(Q), time.perf_counter() - t0)

    def near_way(self, q_current: np.ndarray) -> np.ndarray:
        """(way_candidates, 7) [rad]: configurations next to random ones of the way moved
        (and q_current), within the joint limits."""
        n = self.config.way_candidates
        W = np.asarray(q_current, dtype=np.float64)[None]
        if self.way_of is not None:
            W = np.vstack([W, np.asarray(self.way_of(), dtype=np.float64).reshape(-1, 7)])
        if n == 0:
            return np.zeros((0, 7))
        Q = W[self.rng.integers(0, len(W), n)]
        scale = np.r_[np.full(4, self.config.way_sigma), np.full(3, self.config.wrist_sigma)]
        return np.clip(Q + self.rng.normal(0.0, 1.0, Q.shape) * scale, Q_MIN + 1e-3, Q_MAX - 1e-3)

    def way_back(self, q_current: np.ndarray) -> np.ndarray | None:
        """(m, 7) [rad]: the scan's own views' paths reversed, from q_current (the last one's end)
        back to where the scan started, or None (no view taken, already back, or the arm is not
        where the last view left it)."""
        if not self._paths or self._returned:
            return None
        if not np.allclose(np.asarray(q_current, dtype=np.float64), self._paths[-1][-1], atol=1e-6):
            return None
        W = np.vstack([p[::-1] for p in reversed(self._paths)])
        keep = np.r_[True, np.any(np.abs(np.diff(W, axis=0)) > 1e-9, axis=1)]
        return W[keep]

    def __call__(self, q_current: np.ndarray, detection) -> InspectPlan:
        if self.stopped is None and self.views < self.config.max_views:
            p = self.step(q_current, detection)
            if p is not None:
                self.views += 1
                self._paths.append(np.asarray(p.path, dtype=np.float64))
                return p
        elif self.stopped is None:
            self.stopped = "max_views"
        back = self.way_back(q_current) if self.config.return_back else None
        if back is not None:  # back along the way the scan came (the robot's own space), then INSPECT
            self._returned = True
            return InspectPlan(back, 0, 0, 0.0)
        if self.then is None:
            return InspectPlan(None, 0, 0, 0.0, planned=False)
        return self.then(q_current, detection)
