"""Level 4's base obstacles aimed at the arm's space of the good views and grasps.

Drawn blind, the base obstacles of the severe layout removed none of its good views in most
draws and all or none of its 1-3 neck grasps (seed 0: views / grasps removed min 0.00 / 0.00,
both >= 30 % in 4/20 scenes): near the base, where the home shell keeps obstacles >= 11.7 cm
from the arm, the arm's ways to the views and to the grasps pass the same space. Aiming
measures that space once per layout (the arm's sphere centres of every good view's and
every valid dense neck grasp's collision-free IK solutions, without obstacles:
`arm_samples`) and keeps the first of up to AIM_DRAWS obstacle draws (the level's own family,
`levels.draw_base_obstacles`, so the variant stays the one stratified by index) that keeps
the home shell free and is predicted to remove >= the certification's threshold of each kind
and not all of either (`predicted_removal`). The certification then checks the scene as
always: the prediction only chooses among draws; it can be wrong (its view poses are its own
sample) and a wrong one is rejected like any candidate.
Ground truth: for certification only.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ..motion.primitives import PrimitiveSet
from ..robot.model import GRIPPER_MAX_WIDTH
from ..robot.spheres import panda_sphere_model
from . import oracle
from .home_clearance import required_clearances
from .layout_grasps import layout_grasps
from .levels import draw_base_obstacles, generate_scene
from .scenes import SceneSpec
from .view_search import inside_view_poses, sample_view_poses
from .world import World

#: Levels whose obstacles are aimed, and the obstacle draws tried per candidate sub-seed.
AIMED_LEVELS = (4,)
AIM_DRAWS = 48


@dataclass(frozen=True, eq=False)
class ArmSamples:
    """The arm without base obstacles: per good view pose the sphere centres (k,S,3) [m] of
    its collision-free camera IK solutions; per valid grasp candidate those (k,3,S,3) of its
    valid (grasp, pre-grasp, lift) solutions; sphere radii (S,) [m]."""

    views: tuple
    grasps: tuple
    radii: np.ndarray
    grasp_margin: float
    home: np.ndarray  # (S,3) sphere centres [m] at home (fingers open)


def arm_samples(layout: SceneSpec, rng: np.random.Generator, n_view_poses: int = 160, n_inside: int = 60,
                min_visibility: float = 0.3, margin: float = 0.0, grasp_margin: float = 0.01,
                n_q7_view: int = 6, n_q7_grasp: int = 12) -> ArmSamples:
    """Sample the arm's space of `layout`'s good views (the certification's view families,
    coarse visibility) and of its valid dense neck grasps (`oracle.dense_neck_candidates`,
    the sphere model grown by grasp_margin [m]), without base obstacles."""
    scene = replace(layout, base_obstacles=())
    world = World(scene)
    try:
        ik = oracle.robot_ik(world.robot)
        home = np.asarray(world.robot.q_home)
        sm = panda_sphere_model(world.robot, GRIPPER_MAX_WIDTH)
        chains = layout_grasps(scene, ik, home, n_q7_grasp, margin + grasp_margin)  # shared with `certify`
        grasps = []
        for T, _ in oracle.dense_neck_candidates(scene):
            triples = [g for i in range(len(chains.solutions(T))) if (g := chains.chain(T, i)) is not None]
            if triples:
                grasps.append(np.stack([sm.sphere_centers(np.stack(g)) for g in triples]))
        views_free = oracle.ground_truth_checker(scene, margin=margin)
        poses = sample_view_poses(scene, n_view_poses, rng) + inside_view_poses(scene, n_inside, rng)
        views = []
        for T in poses:
            if world.visibility_from(T, stride=3, with_robot=False) < min_visibility:
                continue
            S = ik.solve(T, "cam", home, n_q7_view, retry=False).solutions
            S = S[views_free.are_valid(S)] if len(S) else S
            if len(S):
                views.append(sm.sphere_centers(S))
        return ArmSamples(tuple(views), tuple(grasps), np.asarray(sm.radii, float), grasp_margin,
                          sm.sphere_centers(home[None])[0])
    finally:
        world.close()


def _blocked(centres: np.ndarray, radii: np.ndarray, prims: PrimitiveSet, margin: float) -> np.ndarray:
    """Per configuration of centres (..., S, 3): whether a sphere reaches within margin [m]."""
    d = prims.distance(centres.reshape(-1, 3)).reshape(centres.shape[:-1]) - radii
    return (d < margin).any(axis=-1)


def _home_shell_free(samples: ArmSamples, obstacles) -> bool:
    """The obstacles' half of the home-clearance gate (`home_clearance`: the base obstacles
    keep the start shell's outside margin from the spheres at home); the cabinet's half does
    not depend on them and is checked by the certification."""
    prims = PrimitiveSet.from_shapes(list(obstacles))
    return bool(np.min(prims.distance(samples.home) - samples.radii) >= required_clearances()[1])


def predicted_removal(samples: ArmSamples, obstacles) -> tuple[float, float]:
    """(views, grasps) the obstacles would remove: a view pose (grasp candidate) counts as
    removed when every solution sampled without obstacles reaches into one (a grasp solution
    when its grasp, pre-grasp or lift does, within the grasp margin); 0 when none is sampled.
    Straight segments are not checked: the certification does."""
    prims = PrimitiveSet.from_shapes(list(obstacles))
    v = [bool(_blocked(c, samples.radii, prims, 0.0).all()) for c in samples.views]
    g = [bool(_blocked(c, samples.radii, prims, samples.grasp_margin).any(axis=-1).all()) for c in samples.grasps]
    return (float(np.mean(v)) if v else 0.0, float(np.mean(g)) if g else 0.0)


@lru_cache(maxsize=4)
def layout_samples(seed: int, level: int, index: int, layout: int) -> ArmSamples:
    """`arm_samples` of the layout of sub-seeds (seed, level, index, layout * OBSTACLE_DRAWS
    ...), cached: the draws of one layout share it."""
    scene = generate_scene(level, index, np.random.default_rng([seed, level, index, layout]))
    return arm_samples(scene, np.random.default_rng([seed, level, index, layout, 7919]))


def aim(scene: SceneSpec, samples: ArmSamples, rng: np.random.Generator, min_removal: float = 0.3,
        draws: int = AIM_DRAWS) -> SceneSpec | None:
    """`scene` with the first of `draws` obstacle draws from rng that keeps the home shell
    free and is predicted to remove >= min_removal and < all of the good views and, on its own,
    of the grasps (`extra["aim_draws"]`: draws used); None when none is (or when the layout has
    at most one of either: removing >= 30 % would leave none)."""
    if len(samples.views) < 2 or len(samples.grasps) < 2:
        return None
    for k in range(draws):
        cand = replace(scene, base_obstacles=draw_base_obstacles(scene, rng))
        if not _home_shell_free(samples, cand.base_obstacles):
            continue
        v, g = predicted_removal(samples, cand.base_obstacles)
        if min_removal <= v < 1.0 and min_removal <= g < 1.0:
            return replace(cand, extra={**cand.extra, "aim_draws": k + 1})
    return None
