"""Inverse kinematics of the Panda for TCP, camera and flange poses, and "look at a point".

Analytic solutions come from `frankik.ik_full` (up to 4 per value of q7) over a sweep of q7,
given the flange (panda_link8) pose computed with the model's own 45 deg hand mount (frankik's
`FrankaHandTCPOffset` rounds it to 0.707, a 1e-4 error). Measured: frankik then agrees with our
FK to 1e-12 m. Each solution is still refined by damped least squares on our FK (a guard for
other MJCFs), kept if it reaches the target within tolerance and the joint limits,
deduplicated and ordered by joint distance to a reference configuration q_ref [rad].
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from functools import lru_cache

import numpy as np

from ..errors import CompassInputError, instance_of, real_number, check_field_types
from ..geometry import check_rigid, inv_T, look_at
from .ik_kernels import dedupe_kernel, refine_batch_kernel
from .kinematics import PandaKinematics
from .model import Q_MAX, Q_MIN, RobotConfig, check_q


@dataclass(frozen=True)
class IKConfig:
    """n_q7 q7 samples over its range (plus q_ref[6]), n_q7_retry samples when those give no
    solution (some poses admit only a narrow band of q7); refine_iters DLS iterations at most;
    damping [m] of DLS; tol_pos [m] / tol_rot [rad] acceptance; dedupe_tol [rad] max joint
    difference under which two solutions are the same."""

    n_q7: int = 16
    n_q7_retry: int = 128
    refine_iters: int = 20
    damping: float = 1e-4
    tol_pos: float = 1e-4
    tol_rot: float = 1e-4
    dedupe_tol: float = 1e-3

    def __post_init__(self) -> None:
        check_field_types(self)
        if not 1 <= self.n_q7 <= 1000:
            raise CompassInputError(f"n_q7 {self.n_q7} is not allowed; use 1..1000")
        if not 0 <= self.refine_iters <= 1000:
            raise CompassInputError(f"refine_iters {self.refine_iters} is not allowed; use 0..1000")
        if not (0 < self.tol_pos <= 0.01 and 0 < self.tol_rot <= 0.1):
            raise CompassInputError("tol_pos must be in (0, 0.01] m and tol_rot in (0, 0.1] rad")


class IKFailure(Enum):
    """Why IK returned no solution. IN_COLLISION: solutions exist but the validity checker
    rejected all of them. NOT_CONVERGED: analytic candidates existed but none refined to the
    tolerance. NO_ANALYTIC_SOLUTION: frankik found none for any sampled q7 (pose out of
    reach, or its q7 band was missed). Listed from the most to the least informative."""

    IN_COLLISION = "in_collision"
    NOT_CONVERGED = "not_converged"
    NO_ANALYTIC_SOLUTION = "no_analytic_solution"


@dataclass(frozen=True, eq=False)
class IKResult:
    """solutions (k,7) [rad] ordered by Euclidean joint distance to q_ref (k may be 0);
    pos_err (k,) [m] and rot_err (k,) [rad] of FK(solution) against its target;
    T_world_targets (k,4,4) the pose of `frame` each solution reaches ('tcp', 'cam', 'hand')."""

    solutions: np.ndarray
    pos_err: np.ndarray
    rot_err: np.ndarray
    T_world_targets: np.ndarray
    frame: str
    failure: IKFailure | None  # None: at least one solution

    @property
    def success(self) -> bool:
        return self.failure is None

    @property
    def best(self) -> np.ndarray | None:
        """The solution closest to q_ref, or None."""
        return self.solutions[0] if self.success else None


@lru_cache(maxsize=8)
def _default_kin(config: RobotConfig) -> PandaKinematics:
    return PandaKinematics(config)


class PandaIK:
    """IK solver bound to one robot (base pose, camera mount)."""

    def __init__(self, kinematics: PandaKinematics | None = None, config: IKConfig | None = None):
        import frankik

        self._frankik = frankik
        self.kin = kinematics or _default_kin(RobotConfig())
        self.config = config or IKConfig()
        L = self.kin.fk_links(np.clip(np.zeros(7), Q_MIN, Q_MAX))
        i8 = self.kin.tree.index("panda_link8")
        #: robot base (panda_link0) in the world
        self.T_base_world = inv_T(L[0])
        #: frankik's flange frame (panda_link8) in the hand frame: the 45 deg mount, from the model
        self.T_hand_link8 = inv_T(L[self.kin.hand_index]) @ L[i8]
        self._kernel_args = tuple(self.kin.kernel_args())
        #: frame -> hand flange, per frame name (the same inv_T as computed on each call)
        self._T_frame_hand = {f: inv_T(self.kin.T_hand_frame(f)) for f in ("tcp", "cam", "hand")}

    def solve(self, T_world_frame: np.ndarray, frame: str, q_ref: np.ndarray,
              n_q7: int | None = None, validity=None, retry: bool = True, cache: dict | None = None) -> IKResult:
        """All distinct IK solutions within limits putting `frame` ('tcp', 'cam', 'hand') at
        T_world_frame, ordered by Euclidean joint distance to q_ref [rad]. validity: anything
        with `are_valid(Q (N,7)) -> (N,) bool` (e.g. motion.validity.ValidityChecker) to keep
        only collision-free solutions. retry: sweep n_q7_retry values of q7 if n_q7 found none.
        cache: a dict the caller keeps; the q7 sweeps (before `validity`) are memoised in it by
        pose, q_ref and n_q7, so asking again (e.g. against another map) repeats no sweep."""
        config = self.config
        T_world_frame, q_ref, n_q7, T_world_hand, T_base_flange = self._query(T_world_frame, frame, q_ref, n_q7)
        S, pe, re, n_cand = self._sweep_cached(T_world_hand, T_base_flange, q_ref, n_q7, cache)
        if retry and S.shape[0] == 0 and config.n_q7_retry > n_q7:
            S, pe, re, n_cand = self._sweep_cached(T_world_hand, T_base_flange, q_ref, config.n_q7_retry, cache)
        failure = (None if len(S) else
                   IKFailure.NOT_CONVERGED if n_cand else IKFailure.NO_ANALYTIC_SOLUTION)
        if validity is not None and len(S):
            ok = np.asarray(validity.are_valid(S), bool)
            S, pe, re = S[ok], pe[ok], re[ok]
            failure = None if len(S) else IKFailure.IN_COLLISION
        T = np.broadcast_to(T_world_frame, (len(S), 4, 4))
        return _ordered(S, pe, re, T, q_ref, config.dedupe_tol, frame, failure)

    def nearest(self, T_world_frame: np.ndarray, frame: str, q_ref: np.ndarray, n_q7: int | None = None,
                validity=None, cache: dict | None = None, max_step: float | None = None) -> np.ndarray | None:
        """`solve(T_world_frame, frame, q_ref, n_q7, validity, retry=False, cache=cache).best`
        (7,) [rad] or None, without checking and ordering every solution: the sweep's solutions
        are ordered by their distance to q_ref and the nearest is checked alone, the rest only
        when it is invalid. With max_step [rad], None also when that solution moves a joint
        by more than max_step from q_ref (and at once, with no validity check, when every
        solution does)."""
        _, q_ref, n_q7, T_world_hand, T_base_flange = self._query(T_world_frame, frame, q_ref, n_q7)
        S = self._sweep_cached(T_world_hand, T_base_flange, q_ref, n_q7, cache)[0]
        if len(S) == 0:
            return None
        order = np.argsort(np.linalg.norm(S - q_ref, axis=1), kind="stable")
        step = np.max(np.abs(S - q_ref), axis=1)
        if max_step is not None and not np.any(step <= max_step):
            return None  # whichever solution is valid moves too far
        best = None
        if validity is None or np.asarray(validity.are_valid(S[order[:1]]), bool)[0]:
            best = order[0]
        elif len(order) > 1:
            ok = np.asarray(validity.are_valid(S[order[1:]]), bool)
            best = order[1:][np.argmax(ok)] if ok.any() else None
        if best is None or (max_step is not None and step[best] > max_step):
            return None
        return S[best].copy()

    def _query(self, T_world_frame, frame, q_ref, n_q7):
        """The checked inputs of `solve` / `nearest`: (T_world_frame, q_ref, n_q7, T_world_hand,
        T_base_flange), the hand in the world and frankik's flange in the robot base."""
        T_world_frame = check_rigid(T_world_frame, "T_world_frame")
        q_ref = check_q(q_ref, "q_ref")
        n_q7 = self.config.n_q7 if n_q7 is None else _whole(n_q7, "n_q7", 1, 1000)
        T_frame_hand = self._T_frame_hand.get(frame) if isinstance(frame, str) else None
        if T_frame_hand is None:  # not a frame name: T_hand_frame says what is allowed
            T_frame_hand = inv_T(self.kin.T_hand_frame(frame))
        T_world_hand = T_world_frame @ T_frame_hand
        return T_world_frame, q_ref, n_q7, T_world_hand, self.T_base_world @ T_world_hand @ self.T_hand_link8

    def _sweep_cached(self, T_world_hand, T_base_flange, q_ref, n_q7, cache):
        if cache is None:
            return self._sweep(T_world_hand, T_base_flange, q_ref, n_q7)
        key = (T_world_hand.tobytes(), q_ref.tobytes(), n_q7)
        if key not in cache:
            grid_key = ("q7 grid", T_world_hand.tobytes(), n_q7)  # the sweep's part that q_ref does not change
            if grid_key not in cache:
                cache[grid_key] = self._refined(T_world_hand, T_base_flange, q_ref, self._q7_grid(n_q7))
            S, pe, re, n = self._refined(T_world_hand, T_base_flange, q_ref, q_ref[6:7])
            G, gpe, gre, gn = cache[grid_key]
            cache[key] = (np.concatenate([S, G]), np.concatenate([pe, gpe]), np.concatenate([re, gre]), n + gn)
        return cache[key]

    @staticmethod
    def _q7_grid(n_q7):
        return np.linspace(Q_MIN[6], Q_MAX[6], n_q7 + 2)[1:-1]

    def _sweep(self, T_world_hand, T_base_flange, q_ref, n_q7):
        """Refined analytic solutions (k,7), pos_err (k,), rot_err (k,) over a q7 sweep (q_ref's
        q7, then n_q7 values across its range), and the number of analytic candidates within
        the limits. The candidates are refined in one compiled call (`refine_batch_kernel`:
        the same arithmetic as `refine_kernel` on each, tests/test_ik_batch.py), so the sweep
        is the concatenation of `_refined` over any split of its q7 values, in order: the
        cache keeps the q7 grid's part per pose (frankik's `ik_full` reads only q7 of q_ref,
        tests/test_ik_nearest.py)."""
        return self._refined(T_world_hand, T_base_flange, q_ref,
                             np.concatenate([[q_ref[6]], self._q7_grid(n_q7)]))

    def _refined(self, T_world_hand, T_base_flange, q_ref, q7s):
        """`_sweep`'s solutions for the q7 values q7s, in their order."""
        config = self.config
        ik_full = self._frankik.ik_full
        C = np.concatenate([ik_full(T_base_flange, q_ref, float(q7)) for q7 in q7s]).reshape(-1, 7)
        C = np.ascontiguousarray(C[np.isfinite(C).all(axis=1)], dtype=np.float64)
        Q, pe, re, ok = refine_batch_kernel(C, T_world_hand, self.kin.hand_index, *self._kernel_args, Q_MIN, Q_MAX,
                                            config.refine_iters, config.damping, config.tol_pos, config.tol_rot)
        return Q[ok].reshape(-1, 7), pe[ok], re[ok], len(C)


def _whole(value, name: str, low: int, high: int) -> int:
    """value as an int if it is a whole number in low..high, else CompassInputError."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise CompassInputError(f"{name} {value!r:.40} is not allowed; use a whole number {low}..{high}")
    return int(value)


def _ordered(S, pe, re, T, q_ref, tol, frame, failure) -> IKResult:
    order = np.argsort(np.linalg.norm(S - q_ref, axis=1), kind="stable")
    # greedy dedupe in that order: a solution is kept unless a kept one is within tol (max
    # joint difference, symmetric)
    k = dedupe_kernel(np.ascontiguousarray(S, dtype=np.float64).reshape(-1, 7), order.astype(np.int64), float(tol))
    return IKResult(S[k].reshape(-1, 7), pe[k], re[k], np.array(T)[k].reshape(-1, 4, 4), frame, failure)


@lru_cache(maxsize=8)
def _default_ik(config: RobotConfig) -> PandaIK:
    return PandaIK(_default_kin(config))


def _solver(robot_config: RobotConfig | None, ik: PandaIK | None) -> PandaIK:
    return ik or _default_ik(robot_config or RobotConfig())


def ik_tcp(T_world_tcp: np.ndarray, q_ref: np.ndarray, n_q7: int | None = None,
           robot_config: RobotConfig | None = None, ik: PandaIK | None = None, validity=None) -> IKResult:
    """IK for the TCP (between the fingertips) at T_world_tcp (see `PandaIK.solve`)."""
    return _solver(robot_config, ik).solve(T_world_tcp, "tcp", q_ref, n_q7, validity)


def ik_camera(T_world_cam: np.ndarray, q_ref: np.ndarray, n_q7: int | None = None,
              robot_config: RobotConfig | None = None, ik: PandaIK | None = None, validity=None) -> IKResult:
    """IK for the wrist camera's optical frame (OpenCV convention) at T_world_cam."""
    return _solver(robot_config, ik).solve(T_world_cam, "cam", q_ref, n_q7, validity)


def ik_look_at(point: np.ndarray, distance: float, q_ref: np.ndarray, rng: np.random.Generator | None = None,
               n_samples: int = 24, max_polar_deg: float = 80.0, n_q7: int = 6,
               robot_config: RobotConfig | None = None, ik: PandaIK | None = None, validity=None) -> IKResult:
    """Camera configurations looking at `point` [m] from `distance` [m].

    Viewing directions are sampled on the spherical cap within max_polar_deg of straight down
    (rng: explicit generator; None = a fixed Fibonacci pattern), each with 4 camera rolls;
    solutions from all views are merged and ordered by joint distance to q_ref.
    """
    try:
        point = np.asarray(point, np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"point must be 3 finite coordinates [m], got {point!r:.80}") from exc
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise CompassInputError(f"point must be 3 finite coordinates [m], got {point}")
    distance = real_number(distance, "distance", "0.05..2 m")
    if not (0.05 <= distance <= 2.0):
        raise CompassInputError(f"distance {distance} m is not allowed; use 0.05..2 m")
    n_samples = _whole(n_samples, "n_samples", 1, 10000)
    max_polar_deg = real_number(max_polar_deg, "max_polar_deg", "0..180 deg")
    if not 0.0 <= max_polar_deg <= 180.0:
        raise CompassInputError(f"max_polar_deg {max_polar_deg} is not allowed; use 0..180 deg")
    if rng is not None:
        instance_of(rng, np.random.Generator, "rng")
    q_ref = check_q(q_ref, "q_ref")
    solver = _solver(robot_config, ik)
    cosmax = math.cos(math.radians(max_polar_deg))
    if rng is None:
        i = np.arange(n_samples) + 0.5
        z = 1.0 - (1.0 - cosmax) * i / n_samples
        phi = math.pi * (1.0 + 5**0.5) * i
    else:
        z = rng.uniform(cosmax, 1.0, n_samples)
        phi = rng.uniform(0.0, 2.0 * math.pi, n_samples)
    s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    dirs = np.stack([s * np.cos(phi), s * np.sin(phi), z], 1)  # from the point up to the eye
    sols, pes, res, Ts, failures = [], [], [], [], set()
    for d in dirs:
        T0 = look_at(point + distance * d, point, up=(1.0, 0.0, 0.0) if d[2] > 0.99 else (0.0, 0.0, 1.0))
        for roll in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi):
            c, sn = math.cos(roll), math.sin(roll)
            Rz = np.array([[c, -sn, 0, 0], [sn, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
            r = solver.solve(T0 @ Rz, "cam", q_ref, n_q7, validity, retry=False)
            sols.append(r.solutions)
            pes.append(r.pos_err)
            res.append(r.rot_err)
            Ts.append(r.T_world_targets)
            failures.add(r.failure)
    # no failure if any view was solved, else the most informative failure of any view
    failure = None if None in failures else next(f for f in IKFailure if f in failures)
    return _ordered(np.vstack(sols), np.concatenate(pes), np.concatenate(res), np.concatenate(Ts),
                    q_ref, solver.config.dedupe_tol, "cam", failure)
