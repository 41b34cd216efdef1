"""The view search of the certification (`certify`): camera poses sampled around the target's
storey, in front of and inside the opening, their visibility of the target by ray casting
(coarse, refined exactly near the threshold) and their IK and collision checks. Ground truth:
for certification only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..geometry import look_at, make_T, rot_z
from .scenes import SceneSpec
from .world import World

if TYPE_CHECKING:
    from .certify import CertifyConfig


@dataclass(frozen=True, eq=False)
class Views:
    """The sampled camera poses, their visibility of the target and valid IK solutions."""

    poses: list  # sampled T_world_cam
    vis: np.ndarray  # (n,) visibility of each sampled pose
    q_full: list  # per pose: valid IK solutions (k,7) with all obstacles
    n_good_without: int  # good views (reachable + seeing) without the base obstacles, all poses


def _row_of(scene: SceneSpec) -> tuple[float, float]:
    z = scene.target.aabb()[0][2]
    for zf, zc in scene.cabinet.rows():
        if zf - 1e-6 <= z <= zc:
            return zf, zc
    lo, hi = scene.cabinet.interior_min, scene.cabinet.interior_max
    return lo[2], hi[2]


def sample_view_poses(scene: SceneSpec, n: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Camera poses T_world_cam around the target's storey, in front of and inside the
    opening, aimed near the target (ground truth: for certification only)."""
    o_lo, o_hi = scene.cabinet.opening()
    zf, zc = _row_of(scene)
    t = scene.target.pos
    x_front = o_lo[0]
    out = []
    while len(out) < n:
        x = rng.uniform(x_front - 0.3, max(x_front - 0.25, t[0] - 0.12))
        y = rng.uniform(o_lo[1] + 0.03, o_hi[1] - 0.03)
        inside = x > x_front - 0.03
        z = rng.uniform(zf + 0.03, zc - 0.03) if inside else rng.uniform(zf - 0.05, zc + 0.25)
        eye = np.array([x, y, z])
        aim = t + rng.normal(0.0, 0.015, 3)
        if np.linalg.norm(aim - eye) < 0.16:
            continue
        out.append(look_at(eye, aim) @ make_T(rot_z(rng.uniform(-np.pi / 2, np.pi / 2))))
    return out


#: Exact refinement margin at the severe levels, where most views see 0.15-0.45 of the target
#: (so view_refine_margin would refine nearly all): the largest coarse-to-exact difference
#: measured on 2,560 poses (docs/scenes.md, "Certification").
SEVERE_REFINE_MARGIN = 0.075
#: The inside poses are a search, not a statistic: IK stops after this many reachable good ones.
INSIDE_ENOUGH = 4


def inside_view_poses(scene: SceneSpec, n: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Camera poses T_world_cam inside or at the opening (at most `outside_views.AT_OPENING` in
    front of its plane, at least 0.14 m before the target), within 0.12 m of the target's y,
    from 7 cm below the target's top to 1 cm under its storey's ceiling, aimed near the target:
    where a severe level's good views are (over the occluder, looking down behind it). Searched
    for a good view at the severe levels only; not part of the uniform view statistics."""
    from .outside_views import AT_OPENING
    x_front = scene.cabinet.opening()[0][0]
    _, zc = _row_of(scene)
    t = np.asarray(scene.target.pos, float)
    top = float(scene.target.aabb()[1][2])
    out = []
    for _ in range(n):
        eye = np.array([rng.uniform(x_front - AT_OPENING, max(x_front - AT_OPENING + 0.01, t[0] - 0.14)),
                        t[1] + rng.uniform(-0.12, 0.12), rng.uniform(top - 0.07, max(top - 0.06, zc - 0.01))])
        aim = t + rng.normal(0.0, 0.015, 3)
        out.append(look_at(eye, aim) @ make_T(rot_z(rng.uniform(-np.pi / 2, np.pi / 2))))
    return out


def search_views(world: World, config: CertifyConfig, rng, ik, full, without) -> Views:
    """Visibility of n_view_poses sampled poses by ray casting (the dominant cost: through every
    view_stride-th pixel, then exactly, through every pixel, where the coarse estimate is
    within view_refine_margin of the threshold, at the severe levels within
    SEVERE_REFINE_MARGIN, the largest coarse-to-exact difference measured; `certify` checks the
    certified view exactly again); IK and collision checks for the first n_views (the uniform
    sample behind the statistics) and for every further pose that sees enough (the search for
    a good view). At the severe levels n_severe_inside_views poses inside or at the opening
    (`inside_view_poses`) follow: a search only, best first (refined exactly near the
    threshold, lazily) until INSIDE_ENOUGH reachable good ones, or, with base obstacles
    (`without` given), every inside pose that sees enough, each counted in n_good_without
    when reachable without the obstacles: at the severe levels the good views are these
    (the 160 sampled ones seldom see enough), so the views the obstacles remove are counted
    over them too."""
    home = np.asarray(world.robot.q_home)
    poses = sample_view_poses(world.scene, config.n_view_poses, rng)
    if world.scene.level in (2, 4):
        poses += inside_view_poses(world.scene, config.n_severe_inside_views, rng)
    vis = np.array([world.visibility_from(T, stride=config.view_stride, with_robot=False) for T in poses])
    margin = SEVERE_REFINE_MARGIN if world.scene.level in (2, 4) else config.view_refine_margin
    n = config.n_view_poses
    for i in np.nonzero(np.abs(vis[:n] - config.min_view_visibility) < margin)[0]:
        vis[i] = world.visibility_from(poses[i], with_robot=False)
    q_full, n_without = [], 0
    for i, T in enumerate(poses[:n]):
        if i >= config.n_views and vis[i] < config.min_view_visibility:
            q_full.append(np.zeros((0, 7)))
            continue
        S = ik.solve(T, "cam", home, config.n_q7, retry=False).solutions
        ok = full.are_valid(S) if len(S) else np.zeros(0, bool)
        q_full.append(S[ok])
        if without is not None and len(S) and vis[i] >= config.min_view_visibility and without.are_valid(S).any():
            n_without += 1
    q_full += [np.zeros((0, 7)) for _ in poses[n:]]
    found = 0  # the inside poses: best first, until INSIDE_ENOUGH reachable good views (all, with obstacles)
    for i in n + np.argsort(-vis[n:], kind="stable"):
        if (found >= INSIDE_ENOUGH and without is None) or vis[i] < config.min_view_visibility - margin:
            break
        if abs(vis[i] - config.min_view_visibility) < margin:  # exactly, lazily: close views have many pixels
            vis[i] = world.visibility_from(poses[i], with_robot=False)
        if vis[i] < config.min_view_visibility:
            continue
        S = ik.solve(poses[i], "cam", home, config.n_q7, retry=False).solutions
        q_full[i] = S[full.are_valid(S)] if len(S) else S
        found += len(q_full[i]) > 0
        if without is not None and len(S) and without.are_valid(S).any():
            n_without += 1
    return Views(poses, vis, q_full, n_without)


def best_exact_visibility(world: World, views: Views, reach: np.ndarray) -> float:
    """Exact visibility of the reachable sampled pose with the highest estimate (0 if none)."""
    if not reach.any():
        return 0.0
    i = int(np.flatnonzero(reach)[np.argmax(views.vis[reach])])
    return float(world.visibility_from(views.poses[i], with_robot=False))
