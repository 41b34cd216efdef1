"""Configuration validity: joint limits, self-collision, the map's distance field, known obstacles.

The robot is the `SphereModel` (conservative spheres fitted to the collision geometry). The map
is a `DistanceGrid` of unsafe space (occupied or unknown), checked conservatively; known
geometry (floor, table, MotionBenchMaker primitives) is a `PrimitiveSet`. Checks run in numba:
single, batch (prange) and edge (linear joint interpolation at a fixed joint step [rad]).
Bounding spheres per link and per cluster of <= CLUSTER_SIZE spheres within a link prune
most sphere tests (a link is clear when its bounding sphere is, or each of its clusters'
bounding spheres is, or each sphere is). The base link is fixed to the world and is only
tested for self-collision, never against the environment it stands on.
"""
from __future__ import annotations

import copy
import weakref
import math
from dataclasses import dataclass, field, replace

import numba as nb
import numpy as np

from ..errors import CompassInputError, real_number
from ..robot.kinematics import check_Q, fk_links_kernel
from ..robot.model import Q_MAX, Q_MIN, check_q
from ..robot.spheres import SphereModel, weld_groups
from .kernel_data import GridData, KernelArgs, RobotSpheres
from .edge_bounds import edge_valid_adaptive_kernel, motion_bounds
from .primitives import DistanceGrid, PrimitiveSet, grid_clearance, primitives_distance

__all__ = ["DistanceGrid", "ValidityChecker", "ValidityConfig", "config_valid_kernel", "batch_valid_kernel",
           "edge_valid_kernel", "edge_valid_from_kernel", "edge_first_invalid_kernel", "clearance_kernel"]


#: Largest number of spheres under one intermediate bounding sphere (link -> cluster -> sphere).
CLUSTER_SIZE = 8


@dataclass(frozen=True)
class ValidityConfig:
    """margin [m]: clearance required from the environment; self_margin [m]: between robot
    spheres; outside_grid_free: space outside the grid is free (default: unsafe, so the
    robot never leaves the mapped workspace); voxel_extent: unsafe voxels are cubes
    (subtract half a voxel diagonal), not points; check_self: test self-collision;
    edge_resolution [rad]: largest joint step on edges."""

    margin: float = 0.0
    self_margin: float = 0.0
    outside_grid_free: bool = False
    voxel_extent: bool = True
    check_self: bool = True
    edge_resolution: float = 0.01

    def __post_init__(self) -> None:
        for name in ("margin", "self_margin", "edge_resolution"):
            real_number(getattr(self, name), f"ValidityConfig.{name}")
        if not (0.0 <= self.margin <= 0.5 and 0.0 <= self.self_margin <= 0.5):
            raise CompassInputError(f"margins {self.margin}, {self.self_margin} m must be in 0..0.5 m")
        if not 1e-4 <= self.edge_resolution <= 0.5:
            raise CompassInputError(f"edge_resolution {self.edge_resolution} rad must be in 1e-4..0.5 rad")


@dataclass(frozen=True, eq=False)
class _Packed:
    """Kernel arguments (tuples of arrays) of one checker."""

    kin: tuple
    robot: tuple
    grid: tuple
    prims: tuple
    limits: tuple
    params: np.ndarray = field(default_factory=lambda: np.zeros(4))


def _pack_robot(sm: SphereModel, check_self: bool) -> RobotSpheres:
    """Sphere arrays + per-link bounding spheres + self pairs grouped by link pair."""
    L = sm.kinematics.n_links
    bi, c, r = sm.body_index, sm.centers_local, sm.radii
    link_c = np.zeros((L, 3))
    link_r = np.full(L, -1.0)
    start = np.zeros(L + 1, np.int64)
    order = np.argsort(bi, kind="stable")
    if not np.array_equal(order, np.arange(len(bi))):
        raise CompassInputError("SphereModel spheres must be sorted by body_index")
    for i in range(L):
        sel = bi == i
        start[i + 1] = start[i] + int(sel.sum())
        if sel.any():
            lo, hi = (c[sel] - r[sel, None]).min(0), (c[sel] + r[sel, None]).max(0)
            link_c[i] = 0.5 * (lo + hi)
            link_r[i] = float(np.max(np.linalg.norm(c[sel] - link_c[i], axis=1) + r[sel]))
    g = weld_groups(sm.kinematics)
    env_link = (g != g[0]) & (link_r > 0)  # links moving with the arm
    pairs = np.sort(sm.self_collision_pairs, axis=1) if check_self else np.zeros((0, 2), np.int64)
    pb = np.sort(bi[pairs], axis=1) if len(pairs) else np.zeros((0, 2), np.int64)
    keyorder = np.lexsort((pairs[:, 1], pairs[:, 0], pb[:, 1], pb[:, 0])) if len(pairs) else np.zeros(0, np.int64)
    pairs, pb = pairs[keyorder], pb[keyorder]
    # link pairs -> runs of equal first sphere u -> partner spheres v
    lp, lp_run = np.zeros((0, 2), np.int64), np.zeros(1, np.int64)
    run_u, run_start = np.zeros(0, np.int64), np.zeros(1, np.int64)
    if len(pairs):
        new_lp = np.r_[True, np.any(pb[1:] != pb[:-1], axis=1)]
        new_run = new_lp | np.r_[True, pairs[1:, 0] != pairs[:-1, 0]]
        lp = pb[new_lp]
        runs = np.nonzero(new_run)[0]
        run_u = pairs[runs, 0].astype(np.int64)
        run_start = np.r_[runs, len(pairs)].astype(np.int64)
        lp_run = np.r_[np.searchsorted(runs, np.nonzero(new_lp)[0]), len(runs)].astype(np.int64)
    partner = np.ascontiguousarray(pairs[:, 1].astype(np.int64)) if len(pairs) else np.zeros(0, np.int64)
    clusters = _clusters(c, r, start)
    return RobotSpheres(bi.astype(np.int64), np.ascontiguousarray(c), np.ascontiguousarray(r), start, link_c, link_r,
                        env_link, np.ascontiguousarray(lp), lp_run, run_u, run_start, partner, *clusters)


#: per sphere model (weakly held) and check_self: its packed spheres and motion bounds
_PACKED: "weakref.WeakKeyDictionary[SphereModel, dict]" = weakref.WeakKeyDictionary()


def _packed_robot(sm: SphereModel, check_self: bool) -> tuple[RobotSpheres, tuple]:
    """(`_pack_robot(sm, check_self)`, `motion_bounds` of it), computed once per sphere model
    (a model's arrays are never changed after it is built): a grasp selection or a map update
    builds several checkers of one robot, and packing costs ~15-20 ms each time."""
    per = _PACKED.setdefault(sm, {})
    if check_self not in per:
        robot = _pack_robot(sm, check_self)
        per[check_self] = (robot, motion_bounds(sm, robot))
    return per[check_self]


def _bounding_sphere(c: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (AABB centre) and radius of a sphere enclosing spheres (c, r)."""
    lo, hi = (c - r[:, None]).min(0), (c + r[:, None]).max(0)
    m = 0.5 * (lo + hi)
    return m, float(np.max(np.linalg.norm(c - m, axis=1) + r))


def _clusters(c: np.ndarray, r: np.ndarray, start: np.ndarray, size: int = CLUSTER_SIZE) -> tuple:
    """Per link, its spheres split by recursive median cuts along the longest axis into
    clusters of at most `size`, each with a bounding sphere (link frame): (clu_start (L+1,)
    first cluster of each link, clu_c (K,3), clu_r (K,), mem_start (K+1,), members (S,)
    sphere indices)."""
    clu_start, clu_c, clu_r, mem_start, members = [0], [], [], [0], []

    def split(idx: np.ndarray) -> None:
        if len(idx) <= size:
            m, rad = _bounding_sphere(c[idx], r[idx])
            clu_c.append(m)
            clu_r.append(rad)
            members.extend(int(k) for k in idx)
            mem_start.append(len(members))
            return
        axis = int(np.argmax(np.ptp(c[idx], axis=0)))
        order = idx[np.argsort(c[idx, axis], kind="stable")]
        split(order[: len(order) // 2])
        split(order[len(order) // 2:])

    for i in range(len(start) - 1):
        if start[i + 1] > start[i]:
            split(np.arange(start[i], start[i + 1]))
        clu_start.append(len(clu_r))
    return (np.array(clu_start, np.int64), np.ascontiguousarray(np.reshape(clu_c, (-1, 3))),
            np.array(clu_r, np.float64), np.array(mem_start, np.int64), np.array(members, np.int64))


class ValidityChecker:
    """Validity of arm configurations q (7,) [rad] for one robot, map and obstacle set.

    grid: DistanceGrid of unsafe space or None (no map); obstacles: PrimitiveSet of known
    geometry (floor/table, benchmark primitives) or None. Joint vectors with NaN/inf or
    outside the limits raise CompassInputError in the Python API.
    """

    def __init__(self, sphere_model: SphereModel, grid: DistanceGrid | None = None,
                 obstacles: PrimitiveSet | None = None, config: ValidityConfig | None = None):
        self.sphere_model = sphere_model
        self.grid = grid
        self.obstacles = obstacles or PrimitiveSet.empty()
        self.config = config or ValidityConfig()
        config = self.config
        if grid is None:
            g = GridData(np.zeros((1, 1, 1), np.float32), np.zeros(3), 1.0, False, False)
        else:
            g = GridData(grid.dist, grid.origin, grid.resolution, True, config.outside_grid_free)
        half_diag = 0.5 * math.sqrt(3.0) * grid.resolution if (grid is not None and config.voxel_extent) else 0.0
        robot, self._bounds = _packed_robot(sphere_model, config.check_self)
        self._p = _Packed(
            kin=sphere_model.kinematics.kernel_args(),
            robot=robot,
            grid=g,
            prims=self.obstacles.arrays(),
            limits=(Q_MIN.copy(), Q_MAX.copy()),
            params=np.array([config.margin, config.self_margin, half_diag, 0.0]),
        )

    def with_grid(self, grid: DistanceGrid) -> "ValidityChecker":
        """This checker on another distance grid (a map update), reusing the packed robot
        spheres (packing them costs ~15 ms): a checker built without a grid takes any grid,
        one built with a grid only grids of its resolution."""
        if not isinstance(grid, DistanceGrid) or (self.grid is not None and grid.resolution != self.grid.resolution):
            raise CompassInputError("with_grid needs a DistanceGrid, of the checker's grid resolution if it has "
                                    "one; build a new ValidityChecker otherwise")
        out = copy.copy(self)
        out.grid = grid
        half_diag = 0.5 * math.sqrt(3.0) * grid.resolution if self.config.voxel_extent else 0.0
        params = self._p.params.copy()
        params[2] = half_diag
        out._p = replace(self._p, grid=GridData(grid.dist, grid.origin, grid.resolution, True,
                                                self.config.outside_grid_free), params=params)
        return out

    def grid_cap_m(self, resolution: float) -> float:
        """A distance [m] above which a grid of this resolution can read the same for this
        checker's verdicts: every environment test compares the grid's clearance bound
        (`grid_clearance`: the voxel's distance less at most a voxel diagonal) with a
        link's, cluster's or sphere's radius plus the margin. A field capped at this value
        (`mapping.distance_incremental`) gives the same valid / invalid answers."""
        rs = self._p.robot
        radius = max(float(np.max(rs.link_r)), float(np.max(rs.clu_r, initial=0.0)), float(np.max(rs.radii)))
        return radius + self.config.margin + math.sqrt(3.0) * float(resolution)

    def kernel_args(self) -> KernelArgs:
        """(kin, robot, grid, prims, limits, params) for `config_valid_kernel` and friends."""
        p = self._p
        return KernelArgs(p.kin, p.robot, p.grid, p.prims, p.limits, p.params)

    def edge_kernel_args(self) -> tuple:
        """`kernel_args()` + (motion bounds,) for `edge_valid_adaptive_kernel`."""
        return (*self.kernel_args(), self._bounds)

    def is_valid(self, q: np.ndarray) -> bool:
        """True if q is collision-free (self, map, obstacles)."""
        q = check_q(q)
        L = self.sphere_model.kinematics.n_links
        S = self.sphere_model.n_spheres
        return bool(config_valid_kernel(q, *self.kernel_args(), np.empty((L, 4, 4)), np.empty((S, 3))))

    def are_valid(self, Q: np.ndarray) -> np.ndarray:
        """(N,) bool validity of Q (N,7) [rad] (parallel)."""
        Q = check_Q(Q)
        return batch_valid_kernel(Q, *self.kernel_args())

    def first_invalid(self, q0: np.ndarray, q1: np.ndarray, resolution: float | None = None) -> float | None:
        """Interpolation parameter s in [0,1] of the first invalid state on the straight joint
        segment q0 -> q1 (scanned from q0 in joint steps <= resolution [rad]); None if all valid."""
        q0, q1 = check_q(q0, "q0"), check_q(q1, "q1")
        n = _n_steps(q0, q1, self.config.edge_resolution if resolution is None else resolution)
        k = edge_first_invalid_kernel(q0, q1, n, *self.kernel_args())
        return None if k < 0 else k / n

    def edge_valid(self, q0: np.ndarray, q1: np.ndarray, resolution: float | None = None,
                   adaptive: bool = False) -> bool:
        """True if every state on the segment q0 -> q1 at joint steps <= resolution [rad]
        (both ends included) is valid. States are tested in bisection order (fails fast).
        adaptive: skip states proven valid by a checked neighbour's clearance (`edge_bounds`;
        the same answer; faster on long edges away from obstacles, slower close to them)."""
        q0, q1 = check_q(q0, "q0"), check_q(q1, "q1")
        n = _n_steps(q0, q1, self.config.edge_resolution if resolution is None else resolution)
        if adaptive:
            return bool(edge_valid_adaptive_kernel(q0, q1, n, *self.edge_kernel_args()))
        return bool(edge_valid_kernel(q0, q1, n, *self.kernel_args()))

    def path_valid(self, path: np.ndarray, resolution: float | None = None) -> bool:
        """True if all segments of a (M,7) path are valid."""
        P = check_Q(path, "path")
        if P.shape[0] == 1:
            return self.is_valid(P[0])
        return all(self.edge_valid(P[i], P[i + 1], resolution) for i in range(P.shape[0] - 1))

    def clearance(self, q: np.ndarray) -> float:
        """Smallest environment clearance [m] over the arm's spheres (negative = penetration;
        inf without obstacles), with the grid's conservative lookup."""
        q = check_q(q)
        return float(clearance_kernel(q, *self.kernel_args()))


def _n_steps(q0: np.ndarray, q1: np.ndarray, resolution: float) -> int:
    resolution = real_number(resolution, "edge resolution", "1e-4..0.5 rad")
    if not 1e-4 <= resolution <= 0.5:
        raise CompassInputError(f"edge resolution {resolution} rad must be in 1e-4..0.5 rad")
    return max(1, int(math.ceil(float(np.max(np.abs(q1 - q0))) / resolution)))


@nb.njit(cache=True, inline="always")
def _env_clearance(p, grid, prims, half_diag, stop_below):
    c = grid_clearance(p, grid, half_diag)
    if c < stop_below:
        return c
    return min(c, primitives_distance(p, prims, stop_below))


@nb.njit(cache=True, inline="always")
def _transform_point(links, i, C, s, out):
    """out[s] = links[i] @ C[s] (homogeneous point), by scalar indexing (no array views)."""
    for r in range(3):
        out[s, r] = links[i, r, 0] * C[s, 0] + links[i, r, 1] * C[s, 1] + links[i, r, 2] * C[s, 2] + links[i, r, 3]


@nb.njit(cache=True, inline="always")
def _link_spheres(links, i, cl, start, W):
    """World centres of link i's spheres into W."""
    for s in range(start[i], start[i + 1]):
        _transform_point(links, i, cl, s, W)


@nb.njit(cache=True, inline="always")
def config_valid_kernel(q, kin, robot, grid, prims, limits, params, links, W):
    """Validity of q (7,): limits (NaN is invalid), environment (grid + primitives), then
    self-collision. links (L,4,4) and W (S,3) are scratch arrays. Sphere centres are computed
    only for links whose bounding sphere is near an obstacle or another link."""
    return _config_valid(q, kin, robot, grid, prims, limits, params, links, W, None)


@nb.njit(cache=True, inline="always")
def _config_valid(q, kin, robot, grid, prims, limits, params, links, W, known):
    """`config_valid_kernel`; known (L,) bool or None: links whose placement equals that of a
    configuration found valid (on this checker) are not checked against the environment,
    nor pairs of two such links against each other (their distances are the same)."""
    qmin, qmax = limits
    for j in range(7):
        if not (qmin[j] <= q[j] <= qmax[j]):
            return False
    finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor = kin
    cl, rad, start, link_c, link_r = robot.centers, robot.radii, robot.start, robot.link_c, robot.link_r
    env_link, lp, lp_run = robot.env_link, robot.link_pairs, robot.pair_run
    run_u, run_start, partner = robot.run_u, robot.run_start, robot.partner
    clu_start, clu_c, clu_r, mem_start = robot.clu_start, robot.clu_c, robot.clu_r, robot.mem_start
    members = robot.members
    margin, self_margin, half_diag = params[0], params[1], params[2]
    fk_links_kernel(q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, links)
    L = link_r.shape[0]
    bc = np.empty((L, 3))
    done = np.zeros(L, np.bool_)  # sphere centres of link i in W (transformed lazily)
    p = np.empty(3)
    for i in range(L):
        if link_r[i] < 0.0:
            continue
        _transform_point(links, i, link_c, i, bc)
        if not env_link[i] or (known is not None and known[i]):
            continue
        need = link_r[i] + margin
        for r in range(3):
            p[r] = bc[i, r]
        if _env_clearance(p, grid, prims, half_diag, need) >= need:
            continue  # the whole link is clear
        for k in range(clu_start[i], clu_start[i + 1]):
            for r in range(3):
                p[r] = (links[i, r, 0] * clu_c[k, 0] + links[i, r, 1] * clu_c[k, 1] + links[i, r, 2] * clu_c[k, 2]
                        + links[i, r, 3])
            need_k = clu_r[k] + margin
            if _env_clearance(p, grid, prims, half_diag, need_k) >= need_k:
                continue  # the whole cluster is clear
            for m in range(mem_start[k], mem_start[k + 1]):
                s = members[m]
                _transform_point(links, i, cl, s, W)
                need_s = rad[s] + margin
                for r in range(3):
                    p[r] = W[s, r]
                if _env_clearance(p, grid, prims, half_diag, need_s) < need_s:
                    return False
    for li in range(lp.shape[0]):
        a, b = lp[li, 0], lp[li, 1]
        if known is not None and known[a] and known[b]:
            continue
        d2 = (bc[a, 0] - bc[b, 0]) ** 2 + (bc[a, 1] - bc[b, 1]) ** 2 + (bc[a, 2] - bc[b, 2]) ** 2
        if d2 >= (link_r[a] + link_r[b] + self_margin) ** 2:
            continue
        for i in (a, b):
            if not done[i]:
                _link_spheres(links, i, cl, start, W)
                done[i] = True
        for run in range(lp_run[li], lp_run[li + 1]):
            u = run_u[run]  # on link a; prune against link b's bounding sphere
            d2 = (W[u, 0] - bc[b, 0]) ** 2 + (W[u, 1] - bc[b, 1]) ** 2 + (W[u, 2] - bc[b, 2]) ** 2
            if d2 >= (rad[u] + link_r[b] + self_margin) ** 2:
                continue
            for k in range(run_start[run], run_start[run + 1]):
                v = partner[k]
                d2 = (W[u, 0] - W[v, 0]) ** 2 + (W[u, 1] - W[v, 1]) ** 2 + (W[u, 2] - W[v, 2]) ** 2
                if d2 < (rad[u] + rad[v] + self_margin) ** 2:
                    return False
    return True


@nb.njit(cache=True, parallel=True)
def batch_valid_kernel(Q, kin, robot, grid, prims, limits, params):
    """(N,) validity of Q (N,7), in parallel chunks."""
    N = Q.shape[0]
    out = np.empty(N, np.bool_)
    L, S = kin.parent.shape[0], robot.radii.shape[0]
    chunk = 256
    for c in nb.prange((N + chunk - 1) // chunk):
        links = np.empty((L, 4, 4))
        W = np.empty((S, 3))
        for n in range(c * chunk, min(N, (c + 1) * chunk)):
            out[n] = config_valid_kernel(Q[n], kin, robot, grid, prims, limits, params, links, W)
    return out


@nb.njit(cache=True, inline="always")
def _edge_states_valid(q0, q1, n, check_start, kin, robot, grid, prims, limits, params):
    """Validity of the states q0 + (q1-q0) * k/n, k = 0..n (k = 0 only if check_start), in
    bisection order: k = n, k = 0, then halving steps. One loop with one call of the
    (inlined) state check: written with two, each edge kernel compiled two copies of it
    (about 66 s of CPU apiece on a cold numba cache)."""
    L, S = kin.parent.shape[0], robot.radii.shape[0]
    links = np.empty((L, 4, 4))
    W = np.empty((S, 3))
    q = np.empty(7)
    step = 1
    while step < n:  # smallest power of two >= n
        step *= 2
    half = step // 2
    k = half
    phase = 0  # 0: the end state k = n, 1: the start k = 0, 2: the halving steps
    while True:
        if phase == 0:
            kk = n
            phase = 1
        elif phase == 1:
            phase = 2
            if not check_start:
                continue
            kk = 0
        else:
            if step <= 1:
                return True
            if k >= n:  # this step's states are done: halve it
                step = half
                half = step // 2
                k = half
                continue
            kk = k
            k += step
        for j in range(7):
            q[j] = q0[j] + (q1[j] - q0[j]) * (kk / n)
        if not config_valid_kernel(q, kin, robot, grid, prims, limits, params, links, W):
            return False


@nb.njit(cache=True)
def edge_valid_kernel(q0, q1, n, kin, robot, grid, prims, limits, params):
    """Validity of the n+1 states q0 + (q1-q0) * k/n, k = 0..n, tested in bisection order."""
    return _edge_states_valid(q0, q1, n, True, kin, robot, grid, prims, limits, params)


@nb.njit(cache=True)
def edge_valid_from_kernel(q0, q1, n, kin, robot, grid, prims, limits, params):
    """`edge_valid_kernel` for a q0 known to be valid on this checker (a planner tree's node):
    the states k = 1..n only (k = 0 is q0 itself, exactly: q0 + d * 0 == q0), so the answer
    is the same and one state check cheaper."""
    return _edge_states_valid(q0, q1, n, False, kin, robot, grid, prims, limits, params)


@nb.njit(cache=True)
def edge_first_invalid_kernel(q0, q1, n, kin, robot, grid, prims, limits, params):
    """Index k of the first invalid state q0 + (q1-q0) * k/n scanning k = 0..n, or -1. Once
    q0 is valid, the links no changing joint moves (their placement is q0's at every state,
    bit for bit: q0[j] + 0 * (k/n) == q0[j]) are not checked again (`_config_valid`)."""
    L, S = kin.parent.shape[0], robot.radii.shape[0]
    links = np.empty((L, 4, 4))
    W = np.empty((S, 3))
    q = np.empty(7)
    parent, joint_index = kin.parent, kin.joint_index
    still = np.empty(L, np.bool_)
    for i in range(L):  # parents come before their children
        j = joint_index[i]
        still[i] = (parent[i] < 0 or still[parent[i]]) and (j < 0 or q1[j] - q0[j] == 0.0)
    if not config_valid_kernel(q0 + (q1 - q0) * 0.0, kin, robot, grid, prims, limits, params, links, W):
        return 0
    for k in range(1, n + 1):
        for j in range(7):
            q[j] = q0[j] + (q1[j] - q0[j]) * (k / n)
        if not _config_valid(q, kin, robot, grid, prims, limits, params, links, W, still):
            return k
    return -1


@nb.njit(cache=True)
def clearance_kernel(q, kin, robot, grid, prims, limits, params):
    """Smallest (environment distance - radius) [m] over the spheres of moving links."""
    finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor = kin
    cl, rad, start, link_c, link_r = robot.centers, robot.radii, robot.start, robot.link_c, robot.link_r
    env_link, lp, lp_run = robot.env_link, robot.link_pairs, robot.pair_run
    run_u, run_start, partner = robot.run_u, robot.run_start, robot.partner
    links = np.empty((link_r.shape[0], 4, 4))
    fk_links_kernel(q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, links)
    W = np.empty((cl.shape[0], 3))
    best = np.inf
    for i in range(link_r.shape[0]):
        if not env_link[i]:
            continue
        for s in range(start[i], start[i + 1]):
            _transform_point(links, i, cl, s, W)
            best = min(best, _env_clearance(W[s], grid, prims, params[2], -np.inf) - rad[s])
    return best
