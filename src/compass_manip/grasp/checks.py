"""The checks of one grasp selection against the map, on a finer grid.

The unsafe space (unknown or occupied, less the target's carve and the robot's own space,
`carve.grasp_unsafe_box`, computed only in a box holding the robot as it stands and the
target; outside the box is unsafe) becomes one distance field `field_upsample` times finer
than the map (`field.checked_field`). It is exact at the fine resolution where precision
pays (`exact_boxes`: the target and the wrist as it stands, between which the path to the
pre-grasp runs, and the base column) and elsewhere a sound bound from the map-grid
transform. In the exact part every unsafe map voxel is split into unsafe fine cells, or,
with a fine local occupancy map integrated from the same depth frames, the fine map's own
labels decide (`field.fine_unsafe_labels`). A checker's conservative bound (distance at the
nearest grid centre, minus the offset to it and half a grid diagonal) then loses at most
one fine voxel diagonal (8.7 mm at 5 mm) near the target. The hand (every link rigid with
the TCP) is checked on it at the grasp, along the approach and along the lift
(`hand_clear`, numba) before any IK; configurations and straight edges use the whole robot
on it, and the planned path to the pre-grasp (`plan`) keeps `plan_margin` more (a
free-space ray grazing a board's edge can mark a voxel free that the board still reaches
into; at most the clearance the robot has where it stands, so the start is valid) and has
the target itself, carved from the map for the fingers, back as an obstacle (`target_box`):
the hand must not sweep through it on its way to the pre-grasp.
"""
from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, prange

from ..geometry import make_T
from ..mapping.distance import DistanceField
from ..mapping.occupancy import OccupancyMap
from ..motion.primitives import DistanceGrid, PrimitiveSet
from ..motion.rrt_kernels import states_valid
from ..motion.validity import ValidityChecker, ValidityConfig
from ..robot.spheres import SphereModel, weld_groups
from .carve import grasp_unsafe_box
from .field import checked_field, coarse_distances, fine_labels_in_box, upsample_mask
from .target import TargetModel

#: Links of the base column (their neighbourhood gets the exact fine field: at the floor
#: the map-grid bound left their spheres with less than the plan's margin).
BASE_LINKS = ("panda_link1", "panda_link2")
#: Links rigid with the TCP (checked on the fine field before any IK).
HAND_LINKS = ("panda_link7", "panda_link8", "hand/panda_hand", "hand/panda_leftfinger", "hand/panda_rightfinger")


def rigid_hand_spheres(spheres: SphereModel) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of the links rigid with the TCP (link7, flange, hand, camera housing, open
    fingers) in the TCP frame: (centres (K,3) [m], radii (K,) [m]). They let a grasp pose
    be checked against the map before any IK is solved."""
    keep = _hand_mask(spheres)
    q = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785])
    C = spheres.sphere_centers(q[None])[0][keep]
    T = spheres.kinematics.T_world_tcp(q)
    return (C - T[:3, 3]) @ T[:3, :3], spheres.radii[keep].copy()


def hand_clear(field: DistanceField, T_world_tcp: np.ndarray, local: tuple[np.ndarray, np.ndarray],
               voxel_extent: bool = True) -> np.ndarray:
    """(M,) True where every rigid hand sphere at each TCP pose (M,4,4) clears unsafe space,
    with the validity checker's conservative bound (nearest voxel centre, its offset and
    half a voxel diagonal subtracted). One numba pass; a pose stops at its first sphere
    that does not clear."""
    C, r = local
    T = np.ascontiguousarray(np.asarray(T_world_tcp, dtype=np.float64).reshape(-1, 4, 4))
    half = 0.5 * math.sqrt(3.0) * field.resolution if voxel_extent else 0.0
    return _hand_clear(field.distances, np.asarray(field.grid_min, dtype=np.float64), float(field.resolution), T,
                       np.ascontiguousarray(C, dtype=np.float64), np.ascontiguousarray(r, dtype=np.float64), half)


@njit(cache=True, parallel=True)
def _hand_clear(dist, grid_min, res, T, C, r, half):
    nx, ny, nz = dist.shape
    out = np.ones(T.shape[0], dtype=np.bool_)
    for m in prange(T.shape[0]):
        for k in range(C.shape[0]):
            off = 0.0
            idx = np.empty(3, np.int64)
            ok = True
            for a in range(3):
                w = T[m, a, 0] * C[k, 0] + T[m, a, 1] * C[k, 1] + T[m, a, 2] * C[k, 2] + T[m, a, 3]
                f = (w - grid_min[a]) / res - 0.5
                i = int(math.floor(f + 0.5))
                n = nx if a == 0 else (ny if a == 1 else nz)
                if i < 0 or i >= n:
                    ok = False
                    break
                idx[a] = i
                off += (f - i) * (f - i)
            if not ok or dist[idx[0], idx[1], idx[2]] - math.sqrt(off) * res - half - r[k] < 0.0:
                out[m] = False
                break
    return out


def first_clear(field: DistanceField, T_world_tcp: np.ndarray, local: tuple[np.ndarray, np.ndarray],
                steps, voxel_extent: bool = True) -> np.ndarray:
    """(M,) per TCP pose (M,4,4) the value of the first step (value, back [m], up [m],
    fractions) whose hand poses all clear unsafe space (`hand_clear`): the TCP moved by
    f * back along its approach and f * up along world z, for every f of fractions; NaN
    where no step does. `pregrasp_steps` / `lift_steps` give the selection's steps."""
    T_all = np.asarray(T_world_tcp, dtype=np.float64).reshape(-1, 4, 4)
    out = np.full(len(T_all), np.nan)
    for value, back, up, fracs in steps:
        todo = np.isnan(out)
        ok = np.ones(int(todo.sum()), dtype=bool)
        for f in fracs:
            T = T_all[todo].copy()
            T[:, :3, 3] += f * back * T[:, :3, 2] + np.array([0.0, 0.0, f * up])
            ok &= hand_clear(field, T, local, voxel_extent)
        out[np.nonzero(todo)[0][ok]] = value
    return out


def pregrasp_steps(distances) -> list:
    """`first_clear` steps of the straight approach: each pre-grasp distance d [m] (longest
    first) checked at 1, 3/4, 1/2 and 1/4 of the way back along the approach."""
    return [(d, -d, 0.0, (1.0, 0.75, 0.5, 0.25)) for d in distances]


def lift_steps(heights) -> list:
    """`first_clear` steps of the lift: each height h [m] (highest first) checked every
    2.5 cm up to h and at h."""
    return [(h, 0.0, h, (*(np.arange(0.025, h + 1e-9, 0.025) / max(h, 1e-9)), 1.0)) for h in heights]


def offset_pose(T: np.ndarray, along_approach: float = 0.0, up: float = 0.0) -> np.ndarray:
    """T moved by along_approach [m] along its z and by up [m] along world z."""
    return make_T(T[:3, :3], T[:3, 3] + along_approach * T[:3, 2] + np.array([0.0, 0.0, up]))


def target_box(target: TargetModel, grow: float = 0.005) -> PrimitiveSet:
    """The target model's box along its principal axes (seen and completed points), grown
    by `grow` [m], as a primitive obstacle."""
    R = np.array(target.axes, dtype=np.float64)
    if np.linalg.det(R) < 0:
        R[:, 2] = -R[:, 2]
    proj = target.points @ R
    lo, hi = proj.min(0), proj.max(0)
    T = make_T(R, R @ (0.5 * (lo + hi)))
    return PrimitiveSet.from_lists(boxes=[(T, 0.5 * (hi - lo) + grow)])


def exact_boxes(occ: OccupancyMap, a: np.ndarray, b: np.ndarray, target: TargetModel, spheres: SphereModel,
                cur: np.ndarray | None, inner_margin: float, base_margin: float):
    """Map-voxel index ranges (relative to the checked box [a, b)) where the checked field is
    exact at the fine resolution: (ia, ib) the target's points grown by inner_margin [m]
    together with the wrist and hand as they stand (cur: sphere centres at q_current, or
    None), grown by base_margin [m] (the planned way to the pre-grasp runs between them),
    and the base column's box (None without cur): near the floor the map-grid bound left
    its spheres less than the plan's margin."""
    lo, hi = target.points.min(0) - inner_margin, target.points.max(0) + inner_margin
    base = None
    if cur is not None:
        wrist = _hand_mask(spheres) | (spheres.body_index == spheres.link_names.index("panda_link6"))
        lo = np.minimum(lo, (cur[wrist] - spheres.radii[wrist, None]).min(0) - base_margin)
        hi = np.maximum(hi, (cur[wrist] + spheres.radii[wrist, None]).max(0) + base_margin)
        col = np.isin(spheres.body_index, [spheres.link_names.index(k) for k in BASE_LINKS])
        blo = (cur[col] - spheres.radii[col, None]).min(0) - base_margin
        bhi = (cur[col] + spheres.radii[col, None]).max(0) + base_margin
        base = (np.clip(occ.world_to_voxel(blo[None])[0] - a, 0, b - a),
                np.clip(occ.world_to_voxel(bhi[None])[0] + 1 - a, 0, b - a))
    ia = np.clip(occ.world_to_voxel(lo[None])[0] - a, 0, b - a)
    ib = np.clip(occ.world_to_voxel(hi[None])[0] + 1 - a, 0, b - a)
    return ia, ib, base


def tight_link_boxes(coarse: np.ndarray, a: np.ndarray, b: np.ndarray, occ: OccupancyMap, spheres: SphereModel,
                     cur: np.ndarray, near: float, grow: float) -> list:
    """Map-voxel index ranges (relative to the checked box [a, b)), one per moving link of the robot
    as it stands (cur: sphere centres (S,3) [m] at q_current) with a sphere whose map-grid
    clearance bound (coarse: the box's map-grid distances, less the offset to the voxel
    centre, half a voxel diagonal and the radius) is below `near` [m]: that link's spheres
    grown by `grow` [m]. There the checked field is made exact: on the map-grid bound the
    robot's own start can keep almost none of the plan's margin (measured: 0.1 mm, level 3
    scene 2), and the planner's fine-step check then finds no edge out of it."""
    res = occ.resolution
    origin = occ.grid_min + np.asarray(a) * res
    rel = (cur - origin) / res
    idx = np.floor(rel).astype(np.int64)
    shape = np.asarray(coarse.shape)
    inside = np.all((idx >= 0) & (idx < shape), axis=1)
    bound = np.full(len(cur), -np.inf)
    ii = idx[inside]
    off = np.linalg.norm((rel[inside] - ii - 0.5) * res, axis=1)
    bound[inside] = coarse[ii[:, 0], ii[:, 1], ii[:, 2]] - off - 0.5 * math.sqrt(3.0) * res
    g = weld_groups(spheres.kinematics)
    moving = g[spheres.body_index] != g[0]  # the base (welded to the world) is never checked against the map
    tight = moving & (bound - spheres.radii < near)
    out = []
    for link in np.unique(spheres.body_index[tight]):
        m = spheres.body_index == link
        lo = (cur[m] - spheres.radii[m, None]).min(0) - grow
        hi = (cur[m] + spheres.radii[m, None]).max(0) + grow
        out.append((np.clip(occ.world_to_voxel(lo[None])[0] - a, 0, b - a),
                    np.clip(occ.world_to_voxel(hi[None])[0] + 1 - a, 0, b - a)))
    return out


def _hand_mask(spheres: SphereModel) -> np.ndarray:
    return np.isin(spheres.body_index, [spheres.link_names.index(k) for k in HAND_LINKS if k in spheres.link_names])


class SequentialValidity:
    """`are_valid` of a `ValidityChecker` in one sequential compiled call (`states_valid`):
    the same answers as its parallel batch, without a thread team's start-up, which costs
    more than the work on the 10-70 IK solutions of one grasp pose (measured: 267 calls of
    one selection 45-48 ms against 66-106 ms)."""

    def __init__(self, checker: ValidityChecker):
        self.checker = checker

    def are_valid(self, Q: np.ndarray) -> np.ndarray:
        Q = np.ascontiguousarray(np.asarray(Q, dtype=np.float64).reshape(-1, 7))
        if not np.all(np.isfinite(Q)):
            return self.checker.are_valid(Q)  # its input check raises the usual error
        return states_valid(Q, self.checker.kernel_args())


class GraspChecks:
    """Per-selection context (module doc): `fine` field near the target, `full` checker
    (whole robot, map grid), `valid` / `edge_valid` for grasp configurations, IK helpers."""

    def __init__(self, occ: OccupancyMap, target: TargetModel, spheres: SphereModel, ik, config,
                 safe_spheres: tuple[np.ndarray, np.ndarray], extra_safe: np.ndarray | None = None,
                 q_current: np.ndarray | None = None, box_margin: float = 0.25,
                 fine_map: OccupancyMap | None = None, inner_margin: float = 0.2, base_margin: float = 0.05,
                 exact_everywhere: bool = False, reuse: GraspChecks | None = None,
                 tight_margin: float | None = 0.01, ik_sweeps=None):
        """reuse: a GraspChecks built with the same arguments (all but exact_everywhere): its
        unsafe box, fine labels and map-grid transform are taken as they are (the exact
        fallback's second field needs only its own fine transform). tight_margin [m]: the
        field is also exact around each link of the robot as it stands with a sphere whose
        map-grid clearance bound is below it (`tight_link_boxes`; None: not). ik_sweeps: a
        `grasp.ik_memo.IKSweeps` whose memoised IK sweeps this selection reads and adds to
        (None: its own, as before; the answers are the same)."""
        self.ik, self.target, self.config = ik, target, config
        self.times: dict[str, float] = {}
        t = time.perf_counter()
        u = config.field_upsample
        cur = None if q_current is None else spheres.sphere_centers(np.asarray(q_current, dtype=np.float64)[None])[0]
        if reuse is not None:
            self._parts = parts = reuse._parts
            a, b, unsafe, robot = parts["a"], parts["b"], parts["unsafe"], parts["robot"]
        else:
            pts = target.points
            if cur is not None:  # the box holds the robot as it stands and the target
                pts = np.vstack([pts, cur])
            shape = np.asarray(occ.shape)
            a = np.clip(occ.world_to_voxel((pts.min(0) - box_margin)[None])[0], 0, shape - 1)
            b = np.clip(occ.world_to_voxel((pts.max(0) + box_margin)[None])[0], 0, shape - 1) + 1
            unsafe, robot, _ = grasp_unsafe_box(occ, target, config.clearance, a, b, safe_spheres, extra_safe)
            self._parts = parts = {"a": a, "b": b, "unsafe": unsafe, "robot": robot,
                                   "ik": {} if ik_sweeps is None else ik_sweeps.for_solver(ik)}
        self.times["unsafe_s"] = time.perf_counter() - t
        t = time.perf_counter()
        ia, ib, base_box = exact_boxes(occ, a, b, target, spheres, cur, inner_margin, base_margin)
        if exact_everywhere:  # the whole box exact (slower)
            ia, ib, base_box = np.zeros(3, np.int64), b - a, None
        flab = None
        if fine_map is not None:  # the fine local map's own labels where it reaches into the inner box
            if "fine_labels" not in parts:
                parts["fine_labels"] = fine_labels_in_box(occ, fine_map, target, config.clearance, u, a, b, unsafe, robot)
            flab = parts["fine_labels"]

        def box_unsafe(ba, bb):
            """The fine unsafe cells of the box [ba, bb) (relative to a): the map's unsafe voxels
            split, with the fine local map's labels where it reaches."""
            fu = upsample_mask(unsafe[ba[0]:bb[0], ba[1]:bb[1], ba[2]:bb[2]], u)
            if flab is not None and flab[2] is not None:
                lo, hi = np.maximum(flab[0], a + ba), np.minimum(flab[1], a + bb)
                if np.all(hi > lo):
                    src = tuple(slice(int(u * (lo[k] - flab[0][k])), int(u * (hi[k] - flab[0][k]))) for k in range(3))
                    dst = tuple(slice(int(u * (lo[k] - a[k] - ba[k])), int(u * (hi[k] - a[k] - ba[k])))
                                for k in range(3))
                    fu[dst] = flab[2][src]
            return fu

        fine_unsafe = None if fine_map is None else box_unsafe(ia, ib)
        own = None if cur is None else (cur, spheres.radii + config.robot_clearance)
        boxes = () if base_box is None else (base_box,)
        if "coarse" not in parts:
            parts["coarse"] = coarse_distances(unsafe, occ.resolution)
        if cur is not None and not exact_everywhere and tight_margin is not None:
            # exact also around the links standing close to unsafe space (their own fine labels)
            tight = tight_link_boxes(parts["coarse"], a, b, occ, spheres, cur, tight_margin, base_margin)
            boxes = boxes + tuple((ta, tb, box_unsafe(ta, tb)) for ta, tb in tight)
        self.fine = checked_field(unsafe, occ.grid_min + a * occ.resolution, occ.resolution, ia, ib, u, fine_unsafe,
                                  own, boxes, coarse=parts["coarse"])
        self.times["field_s"] = time.perf_counter() - t
        grid = DistanceGrid.from_distance_field(self.fine)
        vc = ValidityConfig(voxel_extent=config.voxel_extent)
        # a second field reuses the first one's packed robot spheres (`with_grid`)
        self.full = ValidityChecker(spheres, grid=grid, config=vc) if reuse is None else reuse.full.with_grid(grid)
        margin = config.plan_margin
        if q_current is not None:  # the robot stands at q_current: the path keeps the margin, or what the start has
            margin = float(min(margin, max(0.0, self.full.clearance(np.asarray(q_current, dtype=np.float64)) - 1e-4)))
        self.plan_margin = margin
        if reuse is not None and reuse.plan_margin == margin:
            self.plan = reuse.plan.with_grid(grid)
        else:
            self.plan = ValidityChecker(spheres, grid=grid, obstacles=target_box(target),
                                        config=ValidityConfig(voxel_extent=config.voxel_extent, margin=margin))
        self._full_seq, self._plan_seq = SequentialValidity(self.full), SequentialValidity(self.plan)

    def valid(self, Q: np.ndarray) -> np.ndarray:
        """(N,) configurations free of the map and of self-collision."""
        return self._full_seq.are_valid(Q)

    def are_valid(self, Q: np.ndarray) -> np.ndarray:  # the IK solver's validity interface
        return self.valid(Q)

    def edge_valid(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        return bool(self.full.edge_valid(q0, q1))

    def held_target_clear(self, lift_height: float) -> bool:
        """The target's points stay in safe space all along a lift of lift_height [m] (1 cm steps)."""
        steps = np.arange(0.0, lift_height + 1e-9, 0.01)[1:]
        if len(steps) == 0:
            return True
        pts = (self.target.points[None] + steps[:, None, None] * np.array([0.0, 0.0, 1.0])).reshape(-1, 3)
        return bool(np.all(self.fine.distance_at(pts) >= 0.5 * self.fine.resolution))

    def ik_first(self, T: np.ndarray, q_current: np.ndarray):
        """All IK solutions of the TCP pose T from q_current, unchecked (`check`'s first step)."""
        return self.ik.solve(T, "tcp", q_current, self.config.n_q7, None, cache=self._parts["ik"])

    def near(self, T: np.ndarray, q_ref: np.ndarray, validity) -> np.ndarray | None:
        """The IK solution of T nearest q_ref (7,) [rad] among those valid for `validity`
        (None: all), or None when there is none or it moves a joint by more than
        `config.max_joint_step` (`PandaIK.nearest`: the nearest checked first)."""
        return self.ik.nearest(T, "tcp", q_ref, self.config.n_q7, validity, cache=self._parts["ik"],
                               max_step=self.config.max_joint_step)

    def check(self, T: np.ndarray, q_current: np.ndarray, pre: float, lift: float, lift_clear,
              solved=None):
        """((q_grasp, q_pregrasp, q_lift), None) for one candidate pose with its pre-grasp
        distance and lift height [m] (the hand already checked on the fine field), or
        (None, the `select.Rejection` name); `check_shorter` with its distances dropped."""
        qs, why, _, _ = self.check_shorter(T, q_current, pre, lift, lift_clear, solved)
        return qs, why

    def check_shorter(self, T: np.ndarray, q_current: np.ndarray, pre: float, lift: float, lift_clear,
                      solved=None):
        """(qs, why, pre, lift) as `check`, trying after the pre-grasp distance `pre` [m] the
        shorter ones of `config.pregrasp_distances`, and after the lift height `lift` [m] the
        lower ones of `config.lift_heights`, per grasp configuration: where the arm cannot stand
        at the hand's longest free pre-grasp, it may at a shorter one (the straight approach
        from it is checked with the whole robot, `edge_valid`). The pre-grasp configuration
        must be valid for the planner's checker (`plan`: its margin, the target's box), whose
        goal it is. lift_clear: whether the held
        target stays free along a lift, a bool for `lift` or a dict height -> bool.
        solved: the IK result of T from q_current (`ik_first`), when the caller has it (it
        does not depend on the map). Returns the distances used (nan on failure)."""
        config = self.config
        pres = [pre] + [d for d in config.pregrasp_distances if d < pre]
        lifts = [lift] + [h for h in config.lift_heights if h < lift]
        clear = (lambda h: bool(lift_clear.get(h, False))) if isinstance(lift_clear, dict) \
            else (lambda h: bool(lift_clear) if h == lift else False)
        r = self.ik_first(T, q_current) if solved is None else solved
        if not r.success:
            return None, "NO_IK", math.nan, math.nan
        free = self.valid(r.solutions)
        if not free.any():
            return None, "IK_IN_COLLISION", math.nan, math.nan
        reason = "PREGRASP_BLOCKED"
        for q_g in r.solutions[free][: config.max_ik_solutions]:
            found = None
            for d in pres:
                # the pre-grasp is the planner's goal: free with the plan's margin (and clear of the
                # target's box), else the planner refuses it at once (GOAL_INVALID)
                q_pre = self.near(offset_pose(T, -d), q_g, self._plan_seq)
                if q_pre is None:
                    continue
                if not self.edge_valid(q_pre, q_g):
                    reason = "APPROACH_BLOCKED"
                    continue
                found = (q_pre, d)
                break
            if found is None:
                continue
            reason = "LIFT_BLOCKED"
            for h in lifts:
                if not clear(h):
                    continue
                q_lift = self.near(offset_pose(T, up=h), q_g, self)
                if q_lift is None or not self.edge_valid(q_g, q_lift):
                    continue
                return (q_g, found[0], q_lift), None, found[1], h
        return None, reason, math.nan, math.nan
