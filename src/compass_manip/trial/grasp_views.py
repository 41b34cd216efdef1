"""Grasp-aware INSPECT: a next-best-view loop for the grasp, in the method's world only.

One call (`GraspInspector.__call__`, one INSPECT step): (1) the target model from the
detection and the method's map; (2) grasp hypotheses, the grasps that pass the selection's
checks with unknown space free (`grasp.hypotheses`), and per hypothesis the unknown voxels
its whole arm occupies along pre-grasp -> grasp -> lift that the strict selection counts as
unsafe; (3) when some hypothesis needs no unknown voxel any more (`done_unknown`), or none
exists, INSPECT stops without planning; otherwise camera poses are sampled on and around
the hypotheses' approach axes (backed off `view_distance` [m], looking at the voxels each
hypothesis needs) and around the target, solved by camera IK and kept when valid for the
method's checker (its own rules for unknown space), plus configurations sampled near the
current one; each is scored by the needed voxels it sees, inside its frustum and not
behind a voxel seen occupied (a voxel weighs s_h / N_h summed over the hypotheses h that
need it, s_h the score, N_h the number of voxels h needs: the gain is the score-weighted
fraction of each hypothesis seen, so a view that completes one grasp beats one that sees a
little of many), and the shared planner
plans on the same checker to the best few (`InspectPlan.gain`: per mille of the
hypotheses' weight the chosen view sees; at least `min_fraction` of it). The machine moves there, integrates the frames
along the way, and calls again: the hypotheses are recomputed on the new map.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..errors import CompassInputError
from ..exploration.escape import EscapeConfig, escape_path
from ..exploration.viewpoints import sample_direction_in_cone, view_pose
from ..grasp.candidates import AntipodalProposer, GraspCandidates, PinnedProposer
from ..grasp.hypotheses import grasp_hypotheses, needed_voxels, strict_unsafe_mask
from ..grasp.ik_memo import IKSweeps
from ..grasp.robot_space import base_volume_mask
from ..grasp.target import build_target_model
from ..mapping.occupancy import OccupancyMap
from ..robot.ik import PandaIK
from ..robot.model import Q_MAX, Q_MIN

#: Height [m] of the Panda's shoulder (joint 2) above its base: where `up_candidates`' second
#: family looks from.
SHOULDER_HEIGHT = 0.333
from .inspect import InspectConfig, InspectPlan, frustum_mask, plan_to_best, seen_counts


def weighted_voxels(occ: OccupancyMap, needed: list[np.ndarray], weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Union of the hypotheses' needed voxels: centres (N,3) [m] and weights (N,) (the sum
    of the weights of the hypotheses needing each voxel)."""
    if not needed or sum(len(n) for n in needed) == 0:
        return np.zeros((0, 3)), np.zeros(0)
    shape = np.asarray(occ.shape)
    flat = np.concatenate([np.ravel_multi_index(n.T, shape) for n in needed])
    w = np.concatenate([np.full(len(n), wt) for n, wt in zip(needed, weights)])
    u, inv = np.unique(flat, return_inverse=True)
    return occ.voxel_to_world(np.stack(np.unravel_index(u, shape), axis=1)), np.bincount(inv, weights=w)


def near_target_first(occ: OccupancyMap, needed: list[np.ndarray], points: np.ndarray,
                      margin: float) -> list[np.ndarray]:
    """Per hypothesis, its needed voxel indices (K,3) inside the box of the detection's
    points (N,3) [m] grown by margin [m], when some hypothesis needs a voxel there (the
    hand's way in: unknown space next to the target that no assumption covers and only a
    view into the confined space sees); otherwise `needed` unchanged (margin 0: unchanged)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if margin <= 0.0 or len(pts) == 0 or not needed:
        return needed
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    near = []
    for n in needed:
        c = occ.voxel_to_world(np.asarray(n).reshape(-1, 3)) if len(n) else np.zeros((0, 3))
        near.append(np.asarray(n).reshape(-1, 3)[np.all((c >= lo) & (c <= hi), axis=1)])
    return near if any(len(n) for n in near) else needed


def view_candidates(hyp_axes: list[tuple[np.ndarray, np.ndarray]], centre: np.ndarray, around: np.ndarray,
                    config: InspectConfig, rng: np.random.Generator) -> np.ndarray:
    """(M,4,4) camera poses: n_per_axis around each (approach z (3,), look point (3,)) in
    hyp_axes (directions within axis_cone of the approach, backed off view_distance), and
    n_around looking at `centre` from within around_cone of `around`; random rolls."""
    out = []
    lo, hi = config.view_distance
    for z, look in hyp_axes:
        for _ in range(config.n_per_axis):
            d = sample_direction_in_cone(z, config.axis_cone, rng)
            out.append(view_pose(look, d, rng.uniform(lo, hi), rng.uniform(-np.pi, np.pi)))
    for _ in range(config.n_around if len(centre) else 0):
        d = sample_direction_in_cone(around, config.around_cone, rng)
        out.append(view_pose(centre, d, rng.uniform(lo, hi), rng.uniform(-np.pi, np.pi)))
    return np.array(out).reshape(-1, 4, 4)


def up_candidates(looks: np.ndarray, approach: np.ndarray, shoulder: np.ndarray, config: InspectConfig,
                  rng: np.random.Generator) -> np.ndarray:
    """(n_up,4,4) camera poses looking up at the look points (L,3) [m] (taken in turn), backed
    off view_distance [m]: even ones with optical axes within up_cone of the horizontal part of
    `approach` (3,) raised by up_elevation, odd ones within up_cone of the direction from
    `shoulder` (3,) [m] (the robot's) to the point, so the camera stands below and in front of
    the voxels, where it sees past a rail that hides them from the views along the approach;
    random rolls."""
    looks = np.asarray(looks, dtype=np.float64).reshape(-1, 3)
    if len(looks) == 0 or config.n_up == 0:
        return np.zeros((0, 4, 4))
    h = np.asarray(approach, dtype=np.float64) * np.array([1.0, 1.0, 0.0])
    h = h / np.linalg.norm(h) if np.linalg.norm(h) > 1e-6 else np.array([1.0, 0.0, 0.0])
    up = np.cos(config.up_elevation) * h + np.array([0.0, 0.0, np.sin(config.up_elevation)])
    lo, hi = config.view_distance
    out = []
    for i in range(config.n_up):
        look = looks[(i // 2) % len(looks)]
        back = look - np.asarray(shoulder, dtype=np.float64)
        axis = up if i % 2 == 0 or np.linalg.norm(back) < 1e-6 else back
        d = sample_direction_in_cone(axis, config.up_cone, rng)
        out.append(view_pose(look, d, rng.uniform(lo, hi), rng.uniform(-np.pi, np.pi)))
    return np.array(out)


def weighted_gain(occ: OccupancyMap, T_world_cam: np.ndarray, K: np.ndarray, pts: np.ndarray, w: np.ndarray,
                  config: InspectConfig, rng: np.random.Generator, groups: np.ndarray | None = None) -> np.ndarray:
    """(M,) weight of the points (N,3) [m] each camera sees: frustum-weighted for all, the
    best n_occlusion (of each group: `groups` (M,) labels, None: one group) re-scored with
    occlusion on n_rays points drawn in proportion to w (the rest score 0)."""
    gain = frustum_mask(T_world_cam, K, pts, config.max_range).astype(np.float64) @ w
    if not config.occlusion or len(pts) == 0:
        return gain
    groups = np.zeros(len(gain), dtype=np.int64) if groups is None else np.asarray(groups)
    order = np.argsort(-gain, kind="stable")
    top = np.sort(np.concatenate([order[groups[order] == g][: config.n_occlusion] for g in np.unique(groups)]))
    top = top[np.argsort(-gain[top], kind="stable")]
    sub = pts[rng.choice(len(pts), config.n_rays, replace=True, p=w / w.sum())]
    seen = seen_counts(occ, T_world_cam[top], K, sub, config.max_range)
    out = np.zeros_like(gain)
    out[top] = seen * w.sum() / config.n_rays
    return out


class GraspInspector:
    """The INSPECT step of a trial (module doc), bound to the method's world model `wm`
    (occ, checker, kin, spheres, swept), the camera intrinsics K (3,3), the Task, the grasp
    stage's `grasp.target.TargetConfig` and `grasp.select.GraspSelectConfig`, the
    `InspectConfig` and an explicit generator; near_body: `near_body(occ)` -> voxels the
    grasp stage takes as free (or None). Call with (q_current (7,) [rad], detection) ->
    InspectPlan. more_candidates: `more_candidates(q_current)` -> (m, 7) [rad] further
    configurations to score (e.g. `trial.grasp_scan.NearFieldScanner.near_way`: next to the
    way the arm moved, where the method's checker accepts about half of them), or None.
    strict_safe: `strict_safe(occ)` -> the voxels (occ's shape) the GRASP stage's selection
    will take as the robot's own space (its `extra_safe` less the near-body voxels), when that
    is not `wm.swept`: a hypothesis's needed voxels are the unknown ones that selection
    counts as unsafe, so INSPECT does not stop on a grasp the selection then refuses (None:
    `wm.swept`, the trial's GRASP with `method_swept`). `ik_sweeps` (`grasp.ik_memo.IKSweeps`)
    keeps the IK its steps solved, for the next steps and the GRASP stage's selection."""

    def __init__(self, wm, K: np.ndarray, task, target_config, select_config, config: InspectConfig,
                 rng: np.random.Generator, near_body=None, more_candidates=None, strict_safe=None) -> None:
        if not isinstance(rng, np.random.Generator):
            raise CompassInputError(f"rng {rng!r:.40} is not allowed; give an explicit np.random.Generator")
        self.wm, self.K, self.task, self.rng = wm, np.asarray(K, dtype=np.float64), task, rng
        self.target_config, self.select_config, self.config = target_config, select_config, config
        self.ik = PandaIK(wm.kin)
        self.near_body = near_body
        self.more_candidates = more_candidates
        self.strict_safe = strict_safe
        self.last: dict = {}  # what the last step saw (hypotheses, needed voxels, views), for diagnosis
        self.last_hypotheses: list = []  # the last step's hypotheses
        self.stats: dict = {}
        self.pinned = GraspCandidates.empty()  # every hypothesis found so far (`pin`), newest first
        self.ik_sweeps = IKSweeps()  # IK solved at any step, kept for the next ones and the GRASP stage

    def pin(self, hyps) -> None:
        """Keep the hypotheses' candidates (newest first, at most `config.max_pinned`, exact
        repeats once): the next step checks them again whatever the proposer draws, so the
        views bought for one grasp are not lost to a new random draw, and the GRASP stage
        gets them (`pinned`) for its selection."""
        if self.config.max_pinned == 0:
            return
        new = [h.candidate for h in hyps if h.candidate is not None]
        both = GraspCandidates.concat(new + [self.pinned])
        if len(both) == 0:
            return
        key = np.round(both.T_world_tcp[:, :3, :].reshape(len(both), -1), 6)
        _, first = np.unique(key, axis=0, return_index=True)
        self.pinned = both.take(np.sort(first)[: self.config.max_pinned])

    def needs(self, q_current: np.ndarray, detection, occ: OccupancyMap | None = None, hyps=None):
        """(hypotheses, needed voxels per hypothesis) on `occ` (default the method's map);
        given `hyps`, only their needed voxels are recounted on occ."""
        wm = self.wm
        occ = wm.occ if occ is None else occ
        q = np.asarray(q_current, dtype=np.float64)
        pts = np.asarray(detection.points_world, dtype=np.float64).reshape(-1, 3)
        target = build_target_model(pts, detection.T_world_cam[:3, 3], self.task.target, occ, self.target_config)
        cur = wm.spheres.sphere_centers(q[None])[0]
        safe = (cur, wm.spheres.radii + self.select_config.robot_clearance)
        base = base_volume_mask(wm.spheres, occ)  # the base column's space (constant: computed once)
        near = None if self.near_body is None else self.near_body(occ)
        extra = (wm.swept if near is None else (wm.swept | near)) | base
        own = extra if self.strict_safe is None else np.asarray(self.strict_safe(occ), dtype=bool) | base
        if self.strict_safe is not None and near is not None:
            own = own | near
        strict = strict_unsafe_mask(occ, target, self.select_config.clearance, safe, own)
        if hyps is None:
            self.stats = {}
            proposer = PinnedProposer(AntipodalProposer(self.select_config.candidates), self.pinned)
            fine = wm.fine_map(pts) if hasattr(wm, "fine_map") else None
            hyps = grasp_hypotheses(target, occ, self.task, q, wm.spheres, self.select_config, self.config.hypotheses,
                                    self.rng, safe, extra, self.ik, proposer, stats=self.stats, fine_map=fine,
                                    ik_sweeps=self.ik_sweeps)
            self.pin(hyps)
        return hyps, needed_voxels(occ, hyps, wm.spheres, strict, self.config.hypotheses)

    def __call__(self, q_current: np.ndarray, detection) -> InspectPlan:
        t0 = time.perf_counter()
        wm, config, rng = self.wm, self.config, self.rng
        q = np.asarray(q_current, dtype=np.float64)
        occ = wm.occ
        hyps, needed = self.needs(q, detection)
        self.last_hypotheses = hyps  # for `trial.grasp_looks.BaseLooks`, which recounts their voxels
        counts = [len(n) for n in needed]
        self.last = {"n_hypotheses": len(hyps), "needed": counts, "optimistic_rejections": dict(self.stats)}
        if not hyps or min(counts) <= config.done_unknown:
            return InspectPlan(None, 0, 0, time.perf_counter() - t0, planned=False)
        needed = near_target_first(occ, needed, detection.points_world, config.near_first)
        counts = [len(n) for n in needed]  # the voxels the views aim at (the stop rule counted all)
        self.last["aimed"] = counts
        w_h = np.array([h.score for h in hyps])  # each hypothesis weighs its score, spread over its voxels
        vox, w = weighted_voxels(occ, needed, w_h / np.maximum(counts, 1))
        axes = []
        for k in np.argsort(-w_h, kind="stable")[: config.n_axes]:
            if counts[k]:
                look = occ.voxel_to_world(needed[k]).mean(axis=0)
                axes.append((hyps[k].T_world_tcp[:3, 2], look))
        around = np.mean([h.T_world_tcp[:3, 2] for h in hyps], axis=0)
        centre = (w[:, None] * vox).sum(0) / w.sum()
        T = view_candidates(axes, centre, around, config, rng)
        shoulder = np.asarray(self.task.robot_base_pos, dtype=np.float64) + np.array([0.0, 0.0, SHOULDER_HEIGHT])
        T_up = up_candidates(np.array([centre] + [look for _, look in axes]), around, shoulder, config, rng)
        Q = [s for Tc in T for s in self.ik.solve(Tc, "cam", q, config.n_q7, retry=False).solutions[:2]]
        Q_up = [s for Tc in T_up for s in self.ik.solve(Tc, "cam", q, config.n_q7, retry=False).solutions[:2]]
        scale = np.r_[np.full(4, config.sigma), np.full(3, config.wrist_sigma)]
        near = np.clip(q + rng.normal(0.0, 1.0, (config.n_samples, 7)) * scale, Q_MIN + 1e-3, Q_MAX - 1e-3)
        n_ik = len(Q)
        Q = np.vstack([np.array(Q).reshape(-1, 7), near] + ([] if self.more_candidates is None
                                                             else [np.asarray(self.more_candidates(q)).reshape(-1, 7)])
                      + [np.array(Q_up).reshape(-1, 7)])
        up = np.arange(len(Q)) >= len(Q) - len(Q_up)  # the looks from below: re-scored as a group of their own
        ok = np.asarray(wm.checker.are_valid(Q), dtype=bool)
        Q, up = Q[ok], up[ok]
        if len(Q) == 0:
            return InspectPlan(None, 0, 0, time.perf_counter() - t0)
        gain = weighted_gain(occ, wm.kin.T_world_cam_batch(Q), self.K, vox, w, config, rng, groups=up)
        gain = 1000.0 * gain / w.sum()  # per mille of the hypotheses' weight seen
        self.last.update(n_valid=len(Q), n_ik_views=n_ik, n_up_valid=int(np.count_nonzero(up)),
                         best_gain=round(float(gain.max()), 1),
                         best_up_gain=round(float(gain[up].max()), 1) if up.any() else 0.0)
        q_from, way_out = q, None
        if config.escape and not wm.checker.is_valid(q):  # a frame saw something within the margin of the arm
            way_out = escape_path(wm.checker, q, EscapeConfig(), rng)
            self.last["escaped"] = way_out is not None
            if way_out is None:
                return InspectPlan(None, 0, len(Q), time.perf_counter() - t0, n_calls=0)
            q_from = way_out[-1]
        p = plan_to_best(q_from, Q, gain, 1000.0 * config.min_fraction, config.n_goals, wm.checker, config.planner,
                         rng, t0, n_groups=config.plan_groups)
        if p.path is not None and way_out is not None:
            p = replace(p, path=np.vstack([way_out[:1], np.asarray(p.path)]))
        if p.path is not None:
            self.last["chosen_up"] = bool(up[np.argmin(np.abs(Q - np.asarray(p.path)[-1]).sum(axis=1))])
        self.last["n_plan_calls"] = p.n_calls
        return p
