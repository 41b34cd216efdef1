"""Looks at the arm's space outside the confined space: INSPECT's hypotheses aim them, their own
budget pays for them, and the arm then goes back the way it came.

At GRASP, COMPASS's selection refuses feasible hands because their arms pass through unknown
space beside and in front of the robot's base (the elbow of a low horizontal grasp stands there;
docs/grasping_log.md, "IG and COMPASS at GRASP" and "Beside the base"). No INSPECT view sees it:
INSPECT aims at the hypotheses' voxels from along their approach, and the near-field scan's
views are scored by the box around the base. Camera poses in front of the base looking back at
that space are valid for the method's own checker (branch e2eq's `TrialScanConfig.n_back`), but
taken inside the scan's 8 views they cost the target's views.

`BaseLooks` wraps the trial's `trial.grasp_views.GraspInspector`: INSPECT runs as before; when it
ends (no view left to take), its last hypotheses' needed voxels are recounted on the map and, when at least
`min_outside` of their weight lies outside the confined space (its interior box grown by
`opening` [m] along `outward` and `side` [m] across: beside and in front of the base), up to
`max_looks` looks are taken: camera poses looking at those voxels (drawn by weight) from eye
points in front of the base (`eye`, relative to the base in its yaw frame), solved by camera IK,
kept when valid for the method's checker, scored by the weighted needed voxels they see
(`trial.grasp_views.weighted_gain`) and planned with the shared planner on the same checker.
Then the arm goes back along the looks' own executed paths (the robot's own space) to where
INSPECT left it, and INSPECT is asked once more on the new map; the GRASP stage starts from
where it would have. The machine charges each call its fixed planning charge and each motion its
duration (`trial.machine.TrialMachine._inspect`). Nothing here reads ground truth.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types
from ..exploration.viewpoints import view_pose
from ..motion.planner import DEFAULT_MAX_CHECKS, PlannerConfig
from .grasp_views import weighted_gain, weighted_voxels
from .inspect import InspectPlan, plan_to_best


@dataclass(frozen=True)
class BaseLookConfig:
    """max_looks looks at most (0: off); min_outside: the share of the hypotheses' needed weight
    outside the confined space (`outside_space`) from which looks are taken; opening / side [m]:
    the interior box grown along `outward` / across that still counts as inside; n_poses camera
    poses a look, each at a needed voxel outside (drawn by weight) from a random eye point in
    `eye` ((lo, hi) [m] relative to the base, in its yaw frame), distance within `distance` [m],
    random roll; n_q7 camera IK samples, up to n_solutions a pose kept (the nearest to the
    current configuration first); min_fraction of the
    outside weight a look must see; n_goals best looks handed to the planner; eye_from_way: the
    eye points are instead the cameras of configurations next to the way the arm moved
    (INSPECT's `more_candidates`, `NearFieldScanner.near_way`), where the hand has been."""

    max_looks: int = 0
    min_outside: float = 0.5
    opening: float = 0.15
    side: float = 0.05
    n_poses: int = 96
    eye: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.25, -0.35, 0.55), (0.6, 0.35, 1.05))
    distance: tuple[float, float] = (0.25, 0.9)
    n_q7: int = 4
    n_solutions: int = 2
    min_fraction: float = 0.05
    n_goals: int = 5
    eye_from_way: bool = False
    planner: PlannerConfig = field(default_factory=lambda: PlannerConfig(max_checks=2 * DEFAULT_MAX_CHECKS))

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if isinstance(self.max_looks, bool) or not isinstance(self.max_looks, int) or not 0 <= self.max_looks <= 10:
            raise CompassInputError(f"max_looks {self.max_looks!r} is not allowed; use an integer 0..10")
        if not 0.0 <= self.min_outside <= 1.0 or not 0.0 <= self.min_fraction <= 1.0:
            raise CompassInputError(f"min_outside {self.min_outside} / min_fraction {self.min_fraction} "
                                    "not allowed; use 0..1")
        if not 0.0 <= self.opening <= 0.5 or not 0.0 <= self.side <= 0.5:
            raise CompassInputError(f"opening {self.opening} / side {self.side} m not allowed; use 0..0.5 m")
        if not 1 <= self.n_poses <= 2000 or not 1 <= self.n_goals <= 100 or not 1 <= self.n_q7 <= 64 \
                or not 1 <= self.n_solutions <= 64:
            raise CompassInputError(f"n_poses {self.n_poses} / n_goals {self.n_goals} / n_q7 {self.n_q7} / "
                                    f"n_solutions {self.n_solutions} not allowed; use 1..2000, 1..100, 1..64 "
                                    "and 1..64")
        lo, hi = self.distance
        if not 0.05 <= lo <= hi <= 2.0 or np.any(np.asarray(self.eye[0]) > np.asarray(self.eye[1])):
            raise CompassInputError(f"distance {self.distance} m / eye {self.eye} m not allowed; "
                                    "use 0.05 <= lo <= hi <= 2 and eye lo <= hi")


def outside_space(points: np.ndarray, space, opening: float, side: float) -> np.ndarray:
    """(N,) bool: world points (N,3) [m] outside the confined space's interior box (a
    `task.ConfinedSpace`) grown by `opening` [m] along its outward axis (on the open side) and
    by `side` [m] along the other two axes."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    lo, hi = np.asarray(space.interior_min, float), np.asarray(space.interior_max, float)
    out = np.asarray(space.outward, float)
    grow = np.where(np.abs(out) > 0.5, 0.0, side)
    lo = lo - grow + np.minimum(out * opening, 0.0)
    hi = hi + grow + np.maximum(out * opening, 0.0)
    return ~np.all((p >= lo) & (p <= hi), axis=1)


def look_poses(looks: np.ndarray, weights: np.ndarray, base: np.ndarray, base_yaw: float, config: BaseLookConfig,
               rng: np.random.Generator, eyes: np.ndarray | None = None) -> np.ndarray:
    """(M,4,4) camera poses (M <= n_poses): each looks at one of `looks` (N,3) [m] drawn in
    proportion to `weights` (N,) from a uniform eye point of config.eye (relative to `base` (3,)
    [m], rotated by base_yaw [rad]); draws whose distance falls outside config.distance are
    dropped; random rolls."""
    looks = np.asarray(looks, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if len(looks) == 0 or w.sum() <= 0:
        return np.zeros((0, 4, 4))
    c, s = np.cos(base_yaw), np.sin(base_yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    eye = np.asarray(base, float) + rng.uniform(config.eye[0], config.eye[1], (config.n_poses, 3)) @ R.T
    if eyes is not None and len(eyes):  # given eye points (N,3) [m], drawn uniformly
        eyes = np.asarray(eyes, dtype=np.float64).reshape(-1, 3)
        eye = eyes[rng.integers(0, len(eyes), config.n_poses)]
    pick = looks[rng.choice(len(looks), config.n_poses, p=w / w.sum())]
    lo, hi = config.distance
    out = []
    for e, p in zip(eye, pick):
        d = float(np.linalg.norm(p - e))
        if lo <= d <= hi:
            out.append(view_pose(p, (p - e) / d, d, rng.uniform(-np.pi, np.pi)))
    return np.array(out).reshape(-1, 4, 4)


def way_back(paths: list[np.ndarray], q_current: np.ndarray) -> np.ndarray | None:
    """(m,7) [rad]: the executed paths (each (n,7), in order) reversed, from q_current (the last
    one's end) to the first one's start, repeated configurations dropped; None when there is no
    path or the arm is not where the last one ended."""
    if not paths:
        return None
    if not np.allclose(np.asarray(q_current, dtype=np.float64), paths[-1][-1], atol=1e-6):
        return None
    W = np.vstack([np.asarray(p, dtype=np.float64)[::-1] for p in reversed(paths)])
    keep = np.r_[True, np.any(np.abs(np.diff(W, axis=0)) > 1e-9, axis=1)]
    return W[keep]


class BaseLooks:
    """INSPECT with looks at the arm's space outside the confined space (module doc). inspector:
    the trial's `GraspInspector` (its world model, IK, hypotheses and `InspectConfig` are
    used); task: the Task (space, robot base); config: `BaseLookConfig`; rng: an explicit
    generator; inner_budget: `inner_budget()` -> the calls INSPECT may have before the looks are
    taken anyway (the machine's INSPECT budget left to it; None: no limit, the looks come when
    INSPECT ends). Call with (q_current (7,) [rad], detection) -> `trial.inspect.InspectPlan`.
    `looks` counts the looks taken, `returned` whether the way back was taken, `log` what each
    look step saw (outside share, candidates, valid ones, best gain) and `stopped` why the looks
    ended. `pinned` / `ik_sweeps` are the inspector's (the GRASP stage reads them)."""

    def __init__(self, inspector, task, config: BaseLookConfig, rng: np.random.Generator,
                 inner_budget=None) -> None:
        if not isinstance(rng, np.random.Generator):
            raise CompassInputError(f"rng {rng!r:.40} is not allowed; give an explicit np.random.Generator")
        self.inspector, self.task, self.config, self.rng = inspector, task, config, rng
        self.base = np.asarray(task.robot_base_pos, dtype=np.float64)
        self.looks, self.returned, self.stopped = 0, False, None
        self.log: list[dict] = []
        self._paths: list[np.ndarray] = []
        self._looking = False
        self._done = config.max_looks == 0
        self.inner_budget, self.inner_calls = inner_budget, 0

    @property
    def pinned(self):
        return self.inspector.pinned

    @property
    def ik_sweeps(self):
        return self.inspector.ik_sweeps

    def __call__(self, q_current: np.ndarray, detection) -> InspectPlan:
        if not self._looking:
            spent = self.inner_budget is not None and self.inner_calls >= self.inner_budget()
            if spent and not self._done:  # INSPECT had all its calls: look now
                p = InspectPlan(None, 0, 0, 0.0, planned=False)
            else:
                p = self.inspector(q_current, detection)
                self.inner_calls += 1
                if (p.planned and p.path is not None) or self._done:
                    return p
            self._looking, self._end = True, p  # INSPECT has ended: look outside, then back
        if self.looks < self.config.max_looks:
            p = self.look(q_current, detection)
            if p is not None:
                self.looks += 1
                self._paths.append(np.asarray(p.path, dtype=np.float64))
                return p
        elif self.stopped is None:
            self.stopped = "max_looks"
        self._looking, self._done = False, True
        back = way_back(self._paths, q_current)
        if back is not None:  # back along the looks' own way, then INSPECT once more on the new map
            self.returned = True
            return InspectPlan(back, 0, 0, 0.0)
        return self._end

    def look(self, q_current: np.ndarray, detection) -> InspectPlan | None:
        """One look planned from q_current, or None (`stopped` says why)."""
        t0 = time.perf_counter()
        ins, config = self.inspector, self.config
        wm, occ = ins.wm, ins.wm.occ
        q = np.asarray(q_current, dtype=np.float64)
        hyps = list(ins.last_hypotheses)  # INSPECT's last hypotheses (no new draw), their voxels on the map now
        needed = ins.needs(q, detection, hyps=hyps)[1] if hyps else []
        counts = [len(n) for n in needed]
        rec: dict = {"n_hypotheses": len(hyps), "needed": counts}
        self.log.append(rec)
        if not hyps or min(counts) <= ins.config.done_unknown:
            self.stopped = "no hypothesis" if not hyps else "a hypothesis needs nothing"
            return None
        w_h = np.array([h.score for h in hyps])
        vox, w = weighted_voxels(occ, needed, w_h / np.maximum(counts, 1))
        out = outside_space(vox, self.task.space, config.opening, config.side)
        share = float(w[out].sum() / w.sum())
        rec["outside"] = round(share, 3)
        if share < config.min_outside:
            self.stopped = f"outside share {share:.2f} < {config.min_outside}"
            return None
        pts, wo = vox[out], w[out]
        eyes = None
        if config.eye_from_way and getattr(ins, "more_candidates", None) is not None:
            eyes = wm.kin.T_world_cam_batch(np.asarray(ins.more_candidates(q)).reshape(-1, 7))[:, :3, 3]
        T = look_poses(pts, wo, self.base, float(self.task.robot_base_yaw), config, self.rng, eyes)
        Q = np.array([s for Tc in T for s in ins.ik.solve(Tc, "cam", q, config.n_q7, retry=False).solutions[:config.n_solutions]])
        Q = Q.reshape(-1, 7)
        ok = np.asarray(wm.checker.are_valid(Q), dtype=bool) if len(Q) else np.zeros(0, bool)
        rec.update(n_poses=len(T), n_ik=len(Q), n_valid=int(ok.sum()))
        Q = Q[ok]
        if len(Q) == 0:
            self.stopped = "no valid look"
            return None
        gain = weighted_gain(occ, wm.kin.T_world_cam_batch(Q), ins.K, pts, wo, ins.config, self.rng)
        gain = 1000.0 * gain / wo.sum()  # per mille of the outside weight seen
        rec["best_gain"] = round(float(gain.max()), 1)
        p = plan_to_best(q, Q, gain, 1000.0 * config.min_fraction, config.n_goals, wm.checker, config.planner,
                         self.rng, t0)
        if not p.planned or p.path is None:
            self.stopped = "no look sees enough" if not p.planned else "no path"
            return None
        rec["gain"] = p.gain
        return p
