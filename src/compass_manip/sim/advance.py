"""Conservative advancement of the executor's ground-truth contact checks.

The executor tests the robot against the scene every `check_step` of joint motion. While
the arm is far from everything most of those tests cannot find anything: this module proves
which samples of a motion are contact-free without testing them, so that the contact
reports stay exactly those of a test at every sample.

The proof. A point p of a robot geom moves with the arm's joints j (those between the base
and the geom's body) at speed |dp/dt| <= sum_j |dq_j/dt| * |p - a_j| (a_j: the anchor of
joint j on its axis). |p - a_j| is bounded independently of q by the chain of rigid
distances a_j -> a_{j+1} -> ... -> a_k (the geom's last arm joint) -> the geom's centre,
plus its bounding radius (`geom_rates`, in m per rad). Along a piecewise-linear joint path
the geom therefore moves at most its rate vector dotted with the joints' summed |dq| (the
cumulative bound of `MotionBound`). At an anchor sample the exact signed distances (MuJoCo's
`mj_geomDistance`, capped at `cap_m`) of every robot geom to every scene geom it can collide
with, and of every robot pair the executor's self-contact test keeps, give each geom and
pair a clearance; the samples after the anchor whose motion bound stays below the clearance
less a slack (`slack_m`, far above the distance routines' numerical error) cannot touch
anything. The base link does not move: its contacts do not change along a motion and are
those of the motion's first sample, which is always tested (its floor contact is never one).
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import CompassInputError, check_field_types

N_ARM = 7


@dataclass(frozen=True)
class AdvanceConfig:
    """slack_m [m] kept between the proven bound and the clearance; cap_m [m] the largest
    distance computed (farther geoms count as cap_m away); backoff_max: samples tested one
    by one, at most, before the next clearance is computed when the last gave no skip
    (doubling from 1)."""

    slack_m: float = 0.002
    cap_m: float = 0.25
    backoff_max: int = 8

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if not (1e-4 <= self.slack_m <= 0.05 and self.slack_m < self.cap_m <= 2.0):
            raise CompassInputError(f"AdvanceConfig slack_m {self.slack_m} m / cap_m {self.cap_m} m not allowed; "
                                    "use 1e-4 <= slack_m <= 0.05 m and slack_m < cap_m <= 2 m")
        if not 1 <= int(self.backoff_max) <= 1000:
            raise CompassInputError(f"AdvanceConfig.backoff_max {self.backoff_max} not allowed; use 1..1000")


def _can_collide(m: mujoco.MjModel, g1: int, g2: int) -> bool:
    return bool((m.geom_contype[g1] & m.geom_conaffinity[g2]) or (m.geom_contype[g2] & m.geom_conaffinity[g1]))


class ClearanceModel:
    """The robot geoms, scene geoms and self pairs of one world's contact test, their
    clearances at the world's current state and the geoms' motion rates (module docstring).
    `world` is a `sim.world.World`; include_self as in `World.contacts`."""

    def __init__(self, world, include_self: bool, config: AdvanceConfig | None = None):
        self.world, self.config = world, config or AdvanceConfig()
        m = world.model
        if m.npair or m.nexclude:
            raise CompassInputError("conservative advancement needs a model without explicit contact pairs")
        colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self.arm_joints = np.array([m.joint(f"panda_joint{i + 1}").id for i in range(N_ARM)])
        self.arm_bodies = m.jnt_bodyid[self.arm_joints]
        moving = np.array([self._last_arm_joint(m.geom_bodyid[g]) >= 0 for g in range(m.ngeom)])
        self.robot = np.flatnonzero(world.is_robot_geom & colliding & moving)
        scene = np.flatnonzero(~world.is_robot_geom & colliding)
        # (robot geom index into self.robot, scene geom) pairs that MuJoCo may test
        self.scene_pairs = np.array([(i, o) for i, g in enumerate(self.robot) for o in scene
                                     if _can_collide(m, g, o)], dtype=np.int64).reshape(-1, 2)
        self_pairs = []
        if include_self:
            robot_all = np.flatnonzero(world.is_robot_geom & colliding)
            index = {int(g): i for i, g in enumerate(self.robot)}
            for a, g1 in enumerate(robot_all):
                for g2 in robot_all[a + 1:]:
                    b1, b2 = m.geom_bodyid[g1], m.geom_bodyid[g2]
                    if b1 == b2 or not _can_collide(m, g1, g2) or world._self_pair_ignored(b1, b2):  # noqa: SLF001
                        continue
                    if int(g1) in index or int(g2) in index:  # a pair of two fixed geoms never changes
                        self_pairs.append((int(g1), int(g2)))
        self.self_pairs = np.array(self_pairs, dtype=np.int64).reshape(-1, 2)
        self.planes = np.flatnonzero(m.geom_type[self.scene_pairs[:, 1]] == mujoco.mjtGeom.mjGEOM_PLANE)
        row = {int(g): i for i, g in enumerate(self.robot)}
        # rows of a pair's geoms in the rate matrix (-1: a fixed geom, rate 0)
        self.self_rows = np.array([[row.get(int(g), -1) for g in p] for p in self.self_pairs],
                                  dtype=np.int64).reshape(-1, 2)
        self._fromto = np.zeros(6)

    def _last_arm_joint(self, body: int) -> int:
        """Index 0..6 of the last arm joint moving `body` (-1: none, e.g. the base)."""
        m = self.world.model
        best = -1
        while body > 0:
            hit = np.flatnonzero(self.arm_bodies == body)
            if len(hit):
                best = max(best, int(hit[0]))
            body = m.body_parentid[body]
        return best

    def geom_rates(self) -> np.ndarray:
        """(n_robot, 7) [m/rad]: a bound on how far any point of each robot geom moves per rad
        of each arm joint, at any configuration (the fingers' state as now)."""
        m, d = self.world.model, self.world.data
        anchors = d.xanchor[self.arm_joints]
        links = np.linalg.norm(np.diff(anchors, axis=0), axis=1)  # rigid: a_j, a_{j+1} share a body
        rates = np.zeros((len(self.robot), N_ARM))
        for i, g in enumerate(self.robot):
            k = self._last_arm_joint(m.geom_bodyid[g])
            reach = np.linalg.norm(d.geom_xpos[g] - anchors[k]) + m.geom_rbound[g]
            for j in range(k, -1, -1):
                rates[i, j] = reach
                if j > 0:
                    reach += links[j - 1]
        return rates

    def scene_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """World-axis bounding boxes (lo, hi) (n_scene_pairs, 3) [m] of the scene geom of each
        scene pair at the current state (planes: unbounded); the scene does not move while
        the arm does, so a motion computes them once."""
        m, d = self.world.model, self.world.data
        o, inverse = np.unique(self.scene_pairs[:, 1], return_inverse=True)
        R = d.geom_xmat[o].reshape(-1, 3, 3)
        c = d.geom_xpos[o] + np.einsum("nij,nj->ni", R, m.geom_aabb[o, :3])
        h = np.einsum("nij,nj->ni", np.abs(R), m.geom_aabb[o, 3:])
        h[m.geom_type[o] == mujoco.mjtGeom.mjGEOM_PLANE] = np.inf
        return (c - h)[inverse], (c + h)[inverse]

    def lower_bounds(self, boxes: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Lower bounds [m] on the distance of each scene pair (a robot geom's bounding sphere
        against the scene geom's box, or its height above a plane) and of each self pair (two
        bounding spheres) at the current state; boxes: `scene_boxes()`."""
        m, d = self.world.model, self.world.data
        lo, hi = boxes
        rows = self.scene_pairs[:, 0]
        c, rb = d.geom_xpos[self.robot], m.geom_rbound[self.robot]
        gap = np.maximum(np.maximum(lo - c[rows], c[rows] - hi), 0.0)
        gap[~np.isfinite(gap)] = 0.0
        lower = np.linalg.norm(gap, axis=1) - rb[rows]
        if len(self.planes):
            p, o = self.planes, self.scene_pairs[self.planes, 1]
            normal = d.geom_xmat[o].reshape(-1, 3, 3)[:, :, 2]
            lower[p] = np.einsum("ni,ni->n", c[rows[p]] - d.geom_xpos[o], normal) - rb[rows[p]]
        g1, g2 = self.self_pairs[:, 0], self.self_pairs[:, 1]
        pairs = np.linalg.norm(d.geom_xpos[g1] - d.geom_xpos[g2], axis=1) - m.geom_rbound[g1] - m.geom_rbound[g2]
        return lower, pairs

    def geom_distance(self, i: int, lower: np.ndarray) -> float:
        """Least distance [m] of robot geom `i` (index into `robot`) to the scene, capped at
        cap_m: exact (`mj_geomDistance`) for its pairs in the order of their lower bounds
        until the next bound reaches the least distance so far."""
        m, d, best = self.world.model, self.world.data, self.config.cap_m
        mine = np.flatnonzero(self.scene_pairs[:, 0] == i)
        g = int(self.robot[i])
        for p in mine[np.argsort(lower[mine], kind="stable")]:
            if lower[p] >= best:
                break
            best = min(best, mujoco.mj_geomDistance(m, d, g, int(self.scene_pairs[p, 1]), best, self._fromto))
        return best

    def pair_distance(self, p: int) -> float:
        """Distance [m] of self pair `p`, capped at cap_m."""
        g1, g2 = self.self_pairs[p]
        return mujoco.mj_geomDistance(self.world.model, self.world.data, int(g1), int(g2), self.config.cap_m,
                                      self._fromto)

    def clearances(self, boxes: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """(per robot geom: its least distance [m] to the scene, per self pair: its
        distance [m]) at the current state, each capped at cap_m, all exact."""
        lower, _ = self.lower_bounds(boxes)
        geom = np.array([self.geom_distance(i, lower) for i in range(len(self.robot))])
        pairs = np.array([self.pair_distance(p) for p in range(len(self.self_pairs))])
        return geom, pairs


class MotionBound:
    """The executor's samples qs (n, 7) [rad] of one motion: `proven_until(k)` is the last
    sample index that the clearances at sample k prove contact-free (k itself when none).

    Each robot geom and self pair is a column: its motion bound accumulated along the
    samples (non-decreasing) against its clearance at k. The clearances start as the
    bounding-volume lower bounds (valid, cheap); the column that ends the proof first is
    made exact (`mj_geomDistance`) until that column is exact: the exact distances are
    computed only where they decide the result. An exact distance found at an earlier
    sample of the motion, less the column's bound since, is a lower bound too."""

    def __init__(self, model: ClearanceModel, qs: np.ndarray):
        self.model = model
        steps = np.abs(np.diff(np.asarray(qs, float), axis=0))  # (n-1, 7) [rad]
        rates = model.geom_rates()
        cum = np.vstack([np.zeros((1, len(rates))), np.cumsum(steps @ rates.T, axis=0)])  # (n, n_robot) [m]
        padded = np.hstack([cum, np.zeros((len(cum), 1))])  # row -1: a fixed geom
        rows = model.self_rows
        self.cum = np.hstack([cum, padded[:, rows[:, 0]] + padded[:, rows[:, 1]]])  # (n, n_robot + n_pairs)
        self.boxes = model.scene_boxes()
        # an exact distance d found at sample a bounds the column at k >= a by d - (cum[k] - cum[a]):
        # kept as d + cum[a] (-inf: none yet)
        self.base = np.full(self.cum.shape[1], -np.inf)
        self.n_exact = 0  # exact distances computed (for the tests and figures)

    def proven_until(self, k: int) -> int:
        model, cum = self.model, self.cum
        n_robot, cap, slack = len(model.robot), model.config.cap_m, model.config.slack_m
        lower, pairs = model.lower_bounds(self.boxes)
        geom = np.full(n_robot, cap)
        np.minimum.at(geom, model.scene_pairs[:, 0], lower)
        clear = np.minimum(np.maximum(np.concatenate([geom, pairs]), self.base - cum[k]), cap)
        exact = np.zeros(len(clear), dtype=bool)
        end = len(cum)
        while True:
            window = cum[k:end] - cum[k] >= clear - slack  # (rows, columns): not proven
            first = np.where(window.any(axis=0), np.argmax(window, axis=0), end - k)
            col = int(np.argmin(first))
            if exact[col] or first[col] == end - k:
                return k + max(int(first[col]) - 1, 0)
            clear[col] = model.geom_distance(col, lower) if col < n_robot else model.pair_distance(col - n_robot)
            exact[col] = True
            self.base[col] = clear[col] + cum[k, col]
            self.n_exact += 1


_MODELS: dict = {}


def clearance_model(world, include_self: bool, config: AdvanceConfig) -> ClearanceModel:
    """The world's `ClearanceModel` (built once per world, include_self and config)."""
    key = (id(world), bool(include_self), config)
    cached = _MODELS.get(key)
    if cached is None or cached.world is not world:
        if len(_MODELS) > 16:  # worlds come and go with trials: keep the few recent ones
            _MODELS.clear()
        cached = _MODELS[key] = ClearanceModel(world, include_self, config)
    return cached
