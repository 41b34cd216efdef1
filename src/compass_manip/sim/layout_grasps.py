"""The grasp search of the certification's obstacle levels, computed once per layout.

At levels 3 and 4 up to `certify.OBSTACLE_DRAWS` candidate scenes share one layout (cabinet,
objects, target) and differ only in their base obstacles, and certification step 4/6
(`certify._grasps`) evaluates every grasp candidate of each of them three times: with the
MuJoCo world, with the sphere model and the obstacles, and without the obstacles. Most of
that work does not depend on the obstacles: the candidates' IK solutions, the pre-grasp and
lift solutions near each, and every collision check against the layout's own geometry.

`LayoutGrasps` keeps that part per layout (lazily: a check runs the first time some draw
needs it) and answers `oracle.first_valid_grasp` for any base obstacles exactly: a
configuration (or a straight joint segment) is valid for the sphere model with the
obstacles iff it is valid without them and clear of the obstacles alone (the checker's
verdict is an AND over its primitives, `motion.validity`), so the first valid solution with
obstacles is the first one that is valid without them (cached) and clear of the obstacles
(`oracle.obstacle_checker`, a few boxes). A solution invalid without obstacles is never
valid with them, which also skips the candidates without any valid solution at once.
The aiming's arm samples (`aimed_obstacles.arm_samples`) read the same per-solution chains.
Ground truth: for certification only.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ..motion.validity import ValidityChecker
from ..robot.model import GRIPPER_MAX_WIDTH
from . import oracle
from .scenes import SceneSpec

#: Layouts kept (the aiming samples one layout, then its draws are certified; levels 3/4 move
#: to the next layout after at most OBSTACLE_DRAWS sub-seeds).
KEEP_LAYOUTS = 2


def layout_key(scene: SceneSpec) -> tuple:
    """What decides a scene's geometry apart from its base obstacles (equal for the draws of
    one layout)."""
    return (scene.cabinet, scene.target, scene.clutter, tuple(scene.robot_base_pos), float(scene.robot_base_yaw),
            float(scene.floor_z))


class LayoutGrasps:
    """Grasp chains of one layout without base obstacles: per candidate pose T_world_tcp its IK
    solutions (`oracle.grasp_solutions`, nearest to q_ref first) and, per solution, the
    pre-grasp and lift solutions and whether the chain (grasp, pre-grasp, lift and the straight
    segments pre-grasp -> grasp -> lift) is valid for the sphere model grown by margin [m]."""

    def __init__(self, scene: SceneSpec, ik, q_ref: np.ndarray, n_q7: int, margin: float):
        layout = scene if not scene.base_obstacles else _without_obstacles(scene)
        self.ik, self.q_ref, self.n_q7, self.margin = ik, np.asarray(q_ref, float), int(n_q7), float(margin)
        self.full = oracle.ground_truth_checker(layout, margin=margin)
        self.no_target = oracle.ground_truth_checker(layout, exclude_target=True, margin=margin)
        self._sols: dict[bytes, np.ndarray] = {}
        self._chain: dict[tuple[bytes, int], tuple | None] = {}
        self._first: dict[bytes, int] = {}
        self._mask: dict[bytes, np.ndarray] = {}

    def solutions(self, T: np.ndarray) -> np.ndarray:
        key = T.tobytes()
        if key not in self._sols:
            self._sols[key] = oracle.grasp_solutions(self.ik, T, self.q_ref, self.n_q7)
        return self._sols[key]

    def chain(self, T: np.ndarray, i: int) -> tuple | None:
        """(q_grasp, q_pregrasp, q_lift) of solution i of T when its chain is valid without
        obstacles, else None: `oracle.first_valid_grasp` on that one solution."""
        key = (T.tobytes(), int(i))
        if key not in self._chain:
            sols = self.solutions(T)
            self._chain[key] = (oracle.grasp_chain(self.ik, T, sols[i], self.full, self.no_target)
                                if self._free(T)[i] else None)
        return self._chain[key]

    def _free(self, T: np.ndarray) -> np.ndarray:
        """(k,) whether each solution of T is valid for the layout without the target (one batch)."""
        key = T.tobytes()
        if key not in self._mask:
            sols = self.solutions(T)
            self._mask[key] = self.no_target.are_valid(sols) if len(sols) else np.zeros(0, bool)
        return self._mask[key]

    def first_valid(self, T: np.ndarray) -> int:
        """Index of the first solution of T whose chain is valid without obstacles (-1: none)."""
        key = T.tobytes()
        if key not in self._first:
            self._first[key] = next((i for i in range(len(self.solutions(T))) if self.chain(T, i) is not None), -1)
        return self._first[key]

    def first_valid_with(self, T: np.ndarray, obstacles: ValidityChecker | None, world=None):
        """`oracle.first_valid_grasp` of T on the layout with the base obstacles of the
        obstacle-only checker `obstacles` (None: without any) and, with a world, free of its
        ground-truth contacts with the fingers open: the same (q, pre, lift) or None."""
        start = self.first_valid(T)
        if start < 0:
            return None
        sols = self.solutions(T)
        for i in range(start, len(sols)):
            c = self.chain(T, i)
            if c is None:
                continue
            q, pre, lift = c
            if obstacles is not None and not (obstacles.is_valid(q) and obstacles.is_valid(pre)
                                              and obstacles.edge_valid(pre, q) and obstacles.is_valid(lift)
                                              and obstacles.edge_valid(q, lift)):
                continue
            if world is not None and world.in_collision(q, GRIPPER_MAX_WIDTH, include_self=True):
                continue
            return c
        return None


def _without_obstacles(scene: SceneSpec) -> SceneSpec:
    from dataclasses import replace

    return replace(scene, base_obstacles=())


_LAYOUTS: "OrderedDict[tuple, LayoutGrasps]" = OrderedDict()


def layout_grasps(scene: SceneSpec, ik, q_ref: np.ndarray, n_q7: int, margin: float) -> LayoutGrasps:
    """The `LayoutGrasps` of scene's layout for these settings, shared (the KEEP_LAYOUTS most
    recently used are kept)."""
    key = (layout_key(scene), np.asarray(q_ref, float).tobytes(), int(n_q7), float(margin), id(ik))
    lg = _LAYOUTS.get(key)
    if lg is None or lg.ik is not ik:
        lg = _LAYOUTS[key] = LayoutGrasps(scene, ik, q_ref, n_q7, margin)
    _LAYOUTS.move_to_end(key)
    while len(_LAYOUTS) > KEEP_LAYOUTS:
        _LAYOUTS.popitem(last=False)
    return lg
