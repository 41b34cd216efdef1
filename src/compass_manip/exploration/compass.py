"""COMPASS exploration (paper Algorithm 1, lines 1-13): NFA scan, then MUE-RRT decisions.

Points of interest P_h (the paper leaves them open; NOTES.md): from the Task, the confined
space's centre and its four lower back corners and two upper ones (inset by `prior_inset`
[m]); from the detector, the centroids of partial matches of the target query. When
partial matches exist they replace the Task priors (they are the stronger evidence).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..robot.ik import PandaIK
from ..robot.model import RobotConfig
from ..task import Task
from ..types import Observation
from .base import Decision, Phase, StopReason
from .escape import EscapeConfig, escape_decision
from .mue_rrt import TreeConfig, UtilityWeights, grow_tree, score_tree, validated_path
from .nfa import NFAConfig, nfa_step, safe_box_map
from .world_model import WorldModel, WorldModelConfig


#: The box [m, relative to the base] in front of the robot that the fallback gain counts
#: (`CompassConfig.fallback_box`): x 0..1.2, |y| <= 0.6, z 0..1.15.
FRONT_OF_BASE = ((0.0, -0.6, 0.0), (1.2, 0.6, 1.15))


@dataclass(frozen=True)
class CompassConfig:
    """world: map and validity; nfa: the near-field scan; tree: MUE-RRT sampling; weights:
    utility weights; verify_resolution [rad]: joint step of the final path check;
    max_attempts: best nodes tried when a path fails re-validation; retry_iterations_factor:
    a second, larger tree when the first has no node worth going to (before that, and
    again after it, nodes are rescored with the gain of all unknown voxels when the
    confined space offers none from the tree: seeing more of the surroundings frees space
    to move in); prior_inset [m];
    hint_memory: partial-match points kept (most recent); escape: the short motion out of a
    configuration a new frame made invalid on the map (`escape.py`); near_field_unsafe:
    unknown space inside Omega_safe (the NFA's box around the base) stays unsafe for this
    method's motions until seen (`WorldModelConfig.near_base_box`; the shared default,
    which the baselines keep, lets unknown space outside the confined space count as free);
    tree_on_guard / scan_on_guard: grow the tree and shortcut its paths / pull the near-field
    candidates back on `WorldModel.guarded_checker` (the creep guard's voxels unsafe), so
    that the views offered are those the guard admits (False: on the checker, the guard
    refusing paths afterwards); guard_screen: before planning, test up to this many of the
    best nodes' tree paths against the creep guard and plan only to those it admits, and pass
    over near-field candidates it refuses the same way (0: off; the guard then refuses planned
    paths, each a failed plan); fallback_box ((min), (max)) [m] relative to the base: when the
    confined space offers no gain from the tree, count the unknown voxels of this box (seen
    obstacles outside it still stop the rays) instead of all unknown voxels (None). Both
    defaults (20; x 0..1.2, |y| <= 0.6, z 0..1.15 m) were measured on the development trials
    (docs/compass_loop.md, "The gain and the arm's own body")."""

    world: WorldModelConfig = field(default_factory=WorldModelConfig)
    nfa: NFAConfig = field(default_factory=NFAConfig)
    tree: TreeConfig = field(default_factory=TreeConfig)
    weights: UtilityWeights = field(default_factory=UtilityWeights)
    verify_resolution: float = 0.005
    max_attempts: int = 3
    retry_iterations_factor: int = 3
    prior_inset: float = 0.06
    hint_memory: int = 20
    escape: EscapeConfig = field(default_factory=EscapeConfig)
    near_field_unsafe: bool = True
    tree_on_guard: bool = False
    guard_screen: int = 20
    fallback_box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = FRONT_OF_BASE
    scan_on_guard: bool = False

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, verify_resolution=(1e-4, 0.5, "rad"), prior_inset=(-0.5, 0.5, "m"),
                     max_attempts=(1, 1000, ""), retry_iterations_factor=(1, 100, ""), guard_screen=(0, 100000, ""))
        # check_field_types has checked the box's shape and numbers (its default is a box)
        if self.fallback_box is not None and not (np.subtract(*self.fallback_box) < 0).all():
            raise CompassInputError(f"CompassConfig.fallback_box = {self.fallback_box!r:.60} is not allowed; "
                                    "use None or ((x, y, z) min, (x, y, z) max) [m] with min < max")


def near_field_world(config: CompassConfig) -> WorldModelConfig:
    """The world model config COMPASS plans on: the shared one, with unknown space inside
    Omega_safe unsafe when config.near_field_unsafe (and no box is set already)."""
    if not config.near_field_unsafe or config.world.near_base_box is not None:
        return config.world
    return replace(config.world, near_base_box=(tuple(config.nfa.safe_box_min), tuple(config.nfa.safe_box_max)))


def task_priors(task: Task, inset: float) -> np.ndarray:
    """Points of interest (7, 3) [m] from the confined space's outer geometry: its centre,
    the four lower corners' back half and two upper back corners, inset from the walls."""
    lo = np.asarray(task.space.interior_min, float) + inset
    hi = np.asarray(task.space.interior_max, float) - inset
    out = -np.asarray(task.space.outward, float)  # into the space
    back = np.where(out > 0, hi, lo)  # far side along each axis the opening faces
    c = (lo + hi) / 2
    axis = int(np.argmax(np.abs(out)))
    pts = [c]
    for y in (lo[1], hi[1]):
        for z in (lo[2], hi[2]):
            p = np.array([0.0, y, z]) if axis == 0 else np.array([lo[0], y, z])
            p[axis] = back[axis]
            pts.append(p)
    for y in (lo[1], hi[1]):
        p = np.array([c[0], y, lo[2]])
        pts.append(p)
    return np.array(pts)


class CompassMethod:
    """The COMPASS exploration method (see the module docstring)."""

    def __init__(self, task: Task, config: CompassConfig, rng: np.random.Generator, q_start: np.ndarray,
                 K: np.ndarray, name: str = "compass", robot: RobotConfig | None = None) -> None:
        self.name, self.task, self.config, self.rng = name, task, config, rng
        self.robot = robot or RobotConfig(base_pos=task.robot_base_pos, base_yaw=task.robot_base_yaw)
        self.world = WorldModel(q_start, near_field_world(config), self.robot, task)
        self.ik = PandaIK(self.world.kin)
        self.K = np.asarray(K, float)
        self.q_body = np.asarray(q_start, float).copy()
        self.priors = task_priors(task, config.prior_inset)
        self.hints = np.zeros((0, 3))
        self.t_prev: np.ndarray | None = None
        self.nfa_views = 0
        self.phase = Phase.NFA if config.nfa.enabled and config.nfa.max_views > 0 else Phase.EXPLORE
        self._scratch = None
        self._gain_map = None
        self._fallback = None
        self._checker_ms = 0.0
        self.history: list[np.ndarray] = []  # executed paths, for backtracking
        self._backtracking = False

    # ---------------------------------------------------------------- inputs
    @property
    def occupancy(self):
        return self.world.occ

    def observe(self, obs: Observation) -> None:
        self.world.observe(obs)

    def add_points_of_interest(self, points_world: np.ndarray) -> None:
        p = np.asarray(points_world, float).reshape(-1, 3)
        if len(p):
            self.hints = np.vstack([self.hints, p])[-self.config.hint_memory:]

    def executed(self, path: np.ndarray) -> None:
        self.world.add_swept(path)
        if self._backtracking:
            self._backtracking = False
        else:
            self.history.append(np.asarray(path, float).copy())

    @property
    def points_of_interest(self) -> np.ndarray:
        return self.hints if len(self.hints) else self.priors

    @property
    def _tree_checker(self):
        """The checker the viewpoint tree grows on (`CompassConfig.tree_on_guard`)."""
        return self.world.guarded_checker if self.config.tree_on_guard else self.world.checker

    @property
    def _scan_checker(self):
        """The checker near-field candidates are pulled back on (`CompassConfig.scan_on_guard`)."""
        return self.world.guarded_checker if self.config.scan_on_guard else self.world.checker

    # ---------------------------------------------------------------- decisions
    def decide(self) -> Decision:
        t0 = time.perf_counter()
        self.world.checker  # rebuild the distance field / validity checker on the new map
        self._tree_checker, self._scan_checker  # and the guarded one (its own field, updated where it changed)
        self._checker_ms = 1000 * (time.perf_counter() - t0)
        escape = escape_decision(self.world.checker, self.world.q, self.config.escape, self.rng, self.phase)
        if escape is not None:
            return _timed(escape, t0)
        if self.phase is Phase.NFA:
            d = self._nfa()
            if d is not None:
                return _timed(d, t0)
            self.phase = Phase.EXPLORE
        d = self._explore()
        if d.stop is not None:
            d = self._rescan(d)
        return _timed(d, t0)

    def _rescan(self, stuck: Decision) -> Decision:
        """No view worth going to: one more near-field step at the current body posture
        (its views of unknown Omega_safe free space to move in), else back along the last
        executed path (backtracking: the same configurations in reverse, re-checked on the
        map, replayed as they were when the map now puts them within its margin), else the
        stop. Without the near-field scan (`compass-no-nfa`) only the backtracking."""
        path, gain, att, ok = None, 0, 0, 0
        if self.config.nfa.enabled:
            path, gain, att, ok, self._scratch = nfa_step(self.world, self.world.q, np.asarray(self.task.robot_base_pos),
                                                          self.config.nfa, self.K, self.rng, self._scratch,
                                                          self._scan_checker, self.config.guard_screen > 0)
        att, ok = att + stuck.plans_attempted, ok + stuck.plans_succeeded
        stats = {**stuck.stats, "rescan_gain": gain}
        if path is None and self.history:
            # backtracking: back along the last executed path (swept, so free unless seen
            # otherwise), to grow the next tree from where there were other views
            att += 1
            back = self.history.pop()[::-1]
            path = validated_path(back, self.world.checker, self.config.verify_resolution)
            if path is None:
                # frames seen on the way put obstacles within the checker's margin of it; the
                # arm occupied exactly these configurations a moment ago (the executed path
                # stays on its straight segments) and the scene is static: replay it
                path = back
                stats["replay"] = 1
            if path is not None:
                ok += 1
                self._backtracking = True
                stats["backtrack"] = 1
        if path is None:
            return Decision(None, stuck.stop, Phase.EXPLORE, att, ok, stats=stats)
        return Decision(path, None, Phase.EXPLORE, att, ok, stats=stats)

    def _nfa(self) -> Decision | None:
        config = self.config.nfa
        if self.nfa_views >= config.max_views:
            return None
        path, gain, att, ok, self._scratch = nfa_step(self.world, self.q_body, np.asarray(self.task.robot_base_pos),
                                                      config, self.K, self.rng, self._scratch, self._scan_checker,
                                                      self.config.guard_screen > 0)
        if path is None:
            return None
        self.nfa_views += 1
        return Decision(path, None, Phase.NFA, att, ok, stats={"gain": gain, "nfa_view": self.nfa_views})

    def _explore(self) -> Decision:
        config = self.config
        t1 = time.perf_counter()
        frontiers = self.world.frontiers
        points = self.points_of_interest
        outward = np.asarray(self.task.space.outward, float)
        attempted = succeeded = 0
        scored = None
        gain_map = None
        if config.tree.gain_in_space:
            m = config.tree.space_margin
            self._gain_map = safe_box_map(self.world.occ, np.asarray(self.task.space.interior_min) - m,
                                          np.asarray(self.task.space.interior_max) + m, self._gain_map,
                                          keep_occupied=True)
            gain_map = self._gain_map
        gain_scope = "space" if gain_map is not None else "all"
        for factor in (1, config.retry_iterations_factor):
            tree_cfg = config.tree if factor == 1 else _scaled(config.tree, factor)
            tree = grow_tree(self.world, self.ik, frontiers, points, outward, tree_cfg, self.rng,
                             hinted=len(self.hints) > 0, checker=self._tree_checker)
            scored = score_tree(self.world, tree, self.K, self.t_prev, points, config.weights, tree_cfg, gain_map)
            if np.isfinite(scored.U).any():
                break
            if gain_map is not None:  # nothing new inside the space from here: open up the near field
                scored = score_tree(self.world, tree, self.K, self.t_prev, points, config.weights, tree_cfg,
                                    self._fallback_map())
                if np.isfinite(scored.U).any():
                    gain_scope = "all"
                    break
        stats = {"tree_nodes": int(scored.tree.count), "frontiers": len(frontiers), "gain_scope": gain_scope,
                 "checker_ms": self._checker_ms, "nbv_ms": 1000 * (time.perf_counter() - t1)}
        if not np.isfinite(scored.U).any():
            stop = StopReason.EXPLORED if not frontiers else StopReason.NO_REACHABLE_VIEW
            return Decision(None, stop, Phase.EXPLORE, stats=stats, debug=tree_debug(scored))
        checker = self._tree_checker
        order = np.argsort(-scored.U, kind="stable")
        order = order[np.isfinite(scored.U[order])]
        if config.guard_screen:
            order = self._guard_screened(scored, order, stats)
            if len(order) == 0:
                attempted = 1  # a view was asked for and none the guard admits was found: a failed plan
        for k in order[: config.max_attempts]:
            attempted += 1
            raw = scored.tree.path_to(int(k))
            path = validated_path(raw, checker, config.verify_resolution)
            if path is None:
                continue
            if not (config.guard_screen and path is raw) and self.world.creeps(path):  # into unknown space
                # the arm has not covered (`world_model`); a screened raw tree path was tested already
                if config.guard_screen and path is not raw and checker.path_valid(raw, config.verify_resolution):
                    path = raw  # the shortcut crept; the screened tree path does not
                else:
                    stats["creep_rejected"] = stats.get("creep_rejected", 0) + 1
                    continue
            succeeded += 1
            self.t_prev = scored.T_world_cam[0, :3, 3].copy()
            stats.update(node=int(k), G=float(scored.G[k]), D=float(scored.D[k]), M=float(scored.M[k]),
                         H=float(scored.H[k]), C=float(scored.C[k]), U=float(scored.U[k]))
            return Decision(path, None, Phase.EXPLORE, attempted, succeeded, stats=stats,
                            debug=tree_debug(scored, int(k)))
        return Decision(None, StopReason.PLANNING_FAILED, Phase.EXPLORE, attempted, succeeded, stats=stats,
                        debug=tree_debug(scored))

    def _fallback_map(self):
        """The map the fallback gain is counted on: the world's, or its unknown voxels in
        `CompassConfig.fallback_box` only."""
        if self.config.fallback_box is None:
            return None
        base = np.asarray(self.task.robot_base_pos, float)
        lo, hi = np.asarray(self.config.fallback_box, float)
        self._fallback = safe_box_map(self.world.occ, base + lo, base + hi, self._fallback, keep_occupied=True)
        return self._fallback

    def _guard_screened(self, scored, order: np.ndarray, stats: dict) -> np.ndarray:
        """The nodes of order (best first) whose tree paths the creep guard admits, tested
        until max_attempts of them are found or guard_screen nodes were tested: views the
        method may not go to are not planned to (`CompassConfig.guard_screen`)."""
        keep = []
        for k in order[: self.config.guard_screen]:
            if self.world.creeps(scored.tree.path_to(int(k))):
                stats["creep_screened"] = stats.get("creep_screened", 0) + 1
            else:
                keep.append(int(k))
                if len(keep) >= self.config.max_attempts:
                    break
        return np.asarray(keep, dtype=np.int64)


def tree_debug(scored, chosen: int | None = None) -> dict:
    """`Decision.debug` of a scored viewpoint tree (copies: viewers may keep them)."""
    n = len(scored.U)
    return {"tree_cam_world": scored.T_world_cam[:, :3, 3].copy(), "tree_view_dir": scored.T_world_cam[:, :3, 2].copy(),
            "tree_parent": np.asarray(scored.tree.parent[:n]).copy(), "tree_utility": scored.U.copy(),
            "chosen_node": chosen}


def _scaled(tree: TreeConfig, factor: int) -> TreeConfig:
    return replace(tree, iterations=tree.iterations * factor, capacity=max(tree.capacity, tree.capacity * factor))


def _timed(d: Decision, t0: float) -> Decision:
    return replace(d, compute_s=time.perf_counter() - t0)
