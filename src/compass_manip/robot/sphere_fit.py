"""Fitting collision spheres to the robot's collision geometry (MuJoCo's convex hulls).

Every hull vertex and every point of a subdivided hull face ends up inside a sphere of its
body; `SphereFitConfig` sets how far spheres may protrude beyond the hull.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..errors import CompassInputError
from ..geometry import quat_to_R


@dataclass(frozen=True)
class SphereFitConfig:
    """Fit parameters [m]. protrusion: how far a candidate sphere may reach beyond the hull
    (radius = depth of its centre below the hull surface + protrusion; larger = fewer, bigger
    spheres); fine_links use fine_protrusion (wrist and hand: they pass close to each other
    across joint 6 and reach into shelves and around objects); radius_max: largest radius;
    edge_max: surface triangle edges (a sphere holds whole triangles, so long edges make
    spheres bulge further beyond flat faces); fine_edge_max: edge_max of the fine_links (None:
    edge_max); grid: candidate centre spacing; padding: added to every radius;
    n_pair_samples / seed: configurations that find always-overlapping sphere pairs."""

    protrusion: float = 0.015
    fine_links: tuple[str, ...] = ("panda_link5", "panda_link6", "panda_link7", "hand/panda_hand",
                                   "hand/panda_leftfinger", "hand/panda_rightfinger")
    fine_protrusion: float = 0.006
    radius_max: float = 0.12
    edge_max: float = 0.01
    grid: float = 0.01
    padding: float = 0.001
    n_pair_samples: int = 2000
    seed: int = 0
    fine_edge_max: float | None = None

    def __post_init__(self) -> None:
        if not (0.001 <= self.protrusion <= 0.1 and 0.001 <= self.fine_protrusion <= 0.1):
            raise CompassInputError(
                f"protrusion {self.protrusion} / {self.fine_protrusion} m is not allowed; use 0.001..0.1 m"
            )
        for name, lo, hi in (("radius_max", 0.005, 0.5), ("edge_max", 0.001, self.radius_max),
                             ("grid", 0.002, self.radius_max), ("padding", 0.0, 0.05)):
            if not lo <= getattr(self, name) <= hi:
                raise CompassInputError(f"{name} {getattr(self, name)} m is not allowed; use {lo}..{hi} m")
        if self.fine_edge_max is not None and not 0.001 <= self.fine_edge_max <= self.radius_max:
            raise CompassInputError(
                f"fine_edge_max {self.fine_edge_max} m is not allowed; use 0.001..{self.radius_max} m")

    def key(self) -> str:
        """Text identifying the fit in cache keys (unchanged for fits without fine_edge_max)."""
        return repr(self).replace(", fine_edge_max=None", "")


#: Fit of the refinement sphere model used where the default spheres are too coarse
#: (MotionBenchMaker): 2 mm protrusion on the wrist, hand and fingers, 0.5 mm padding.
FINE_FIT = SphereFitConfig(fine_protrusion=0.002, fine_edge_max=0.004, padding=0.0005)


# --- geometry extraction ------------------------------------------------------------------
def collision_hulls(model, link_names: tuple[str, ...]) -> list[list[np.ndarray]]:
    """Per link: list of (V,3) point sets [m] in the link frame whose convex hulls collide."""
    import mujoco

    hulls: list[list[np.ndarray]] = [[] for _ in link_names]
    for g in range(model.ngeom):
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0:
            continue
        name = model.body(int(model.geom_bodyid[g])).name
        if name not in link_names:
            continue
        t = model.geom_type[g]
        if t == mujoco.mjtGeom.mjGEOM_MESH:
            k = int(model.geom_dataid[g])
            a, n = int(model.mesh_vertadr[k]), int(model.mesh_vertnum[k])
            P = np.asarray(model.mesh_vert[a : a + n], dtype=np.float64)
        elif t == mujoco.mjtGeom.mjGEOM_BOX:
            s = model.geom_size[g]
            P = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * s
        else:
            raise CompassInputError(f"collision geom type {int(t)} of {name} is not supported (mesh/box)")
        R = quat_to_R(model.geom_quat[g])
        hulls[link_names.index(name)].append(P @ R.T + model.geom_pos[g])
    return hulls


def _subdivide(P: np.ndarray, tris: np.ndarray, edge_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Longest-edge bisection until every triangle edge <= edge_max [m] (new points on the surface)."""
    while True:
        E = np.stack([np.linalg.norm(P[tris[:, (k + 1) % 3]] - P[tris[:, k]], axis=1) for k in range(3)], 1)
        k = E.argmax(axis=1)
        long = E[np.arange(len(k)), k] > edge_max
        if not np.any(long):
            return P, tris
        T, k = tris[long], k[long]
        r = np.arange(T.shape[0])
        a, b, c = T[r, k], T[r, (k + 1) % 3], T[r, (k + 2) % 3]  # longest edge a-b, opposite c
        mid = P.shape[0] + r
        P = np.vstack([P, 0.5 * (P[a] + P[b])])
        tris = np.vstack([tris[~long], np.stack([a, mid, c], 1), np.stack([mid, b, c], 1)])


def _voxel_representatives(P: np.ndarray, size: float) -> np.ndarray:
    """One point per occupied voxel of edge `size` [m] (the first point falling in it)."""
    keys = np.floor(P / size).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return P[np.sort(first)]


@nb.njit(cache=True)
def _depth_below(P, equations):
    """Distance [m] of points P (N,3) inside a convex hull to its surface (0 if outside);
    equations (F,4): outward facet planes n.x + d = 0 (scipy ConvexHull)."""
    out = np.empty(P.shape[0])
    for i in range(P.shape[0]):
        best = np.inf
        for f in range(equations.shape[0]):
            e = equations[f]
            d = -(e[0] * P[i, 0] + e[1] * P[i, 1] + e[2] * P[i, 2] + e[3])
            if d < best:
                best = d
        out[i] = max(best, 0.0)
    return out


@nb.njit(cache=True)
def _greedy_cover(C, rc, E, w):
    """Greedy weighted set cover of points E (M,3) (weights w) by candidate balls (C[k], rc[k]).

    Gains are kept incrementally: O(K*M) distance tests overall, no (K,M) matrix. Returns the
    chosen candidate indices, or an empty array if some point is out of every ball's reach.
    """
    K, M = C.shape[0], E.shape[0]
    gain = np.zeros(K)
    reached = np.zeros(M, np.bool_)
    for k in range(K):
        r2 = rc[k] * rc[k]
        for e in range(M):
            d2 = (C[k, 0] - E[e, 0]) ** 2 + (C[k, 1] - E[e, 1]) ** 2 + (C[k, 2] - E[e, 2]) ** 2
            if d2 <= r2:
                gain[k] += w[e]
                reached[e] = True
    if not reached.all():
        return np.empty(0, np.int64)
    covered = np.zeros(M, np.bool_)
    n_left = M
    out = []
    new = np.empty(M, np.int64)
    while n_left > 0:
        k = int(np.argmax(gain))
        out.append(k)
        r2 = rc[k] * rc[k]
        n_new = 0
        for e in range(M):
            if not covered[e]:
                d2 = (C[k, 0] - E[e, 0]) ** 2 + (C[k, 1] - E[e, 1]) ** 2 + (C[k, 2] - E[e, 2]) ** 2
                if d2 <= r2:
                    covered[e] = True
                    new[n_new] = e
                    n_new += 1
        n_left -= n_new
        for j in range(K):  # remove the newly covered points from every candidate's gain
            rj2 = rc[j] * rc[j]
            for t in range(n_new):
                e = new[t]
                d2 = (C[j, 0] - E[e, 0]) ** 2 + (C[j, 1] - E[e, 1]) ** 2 + (C[j, 2] - E[e, 2]) ** 2
                if d2 <= rj2:
                    gain[j] -= w[e]
    return np.array(out, np.int64)


def _fit_link(hulls: list[np.ndarray], fit: SphereFitConfig, protrusion: float | None = None,
              edge_max: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sphere cover of the hull surfaces and interiors of one link: (K,3) centres, (K,) radii [m].

    Greedy set cover of representative surface/interior points chooses the centres; the radii
    are then set exactly so that every subdivided hull triangle and interior point lies inside
    one sphere (the one needing the least growth).
    """
    from scipy.spatial import ConvexHull, Delaunay

    protrusion = fit.protrusion if protrusion is None else protrusion
    edge_max = fit.edge_max if edge_max is None else edge_max
    grid = min(fit.grid, protrusion)  # candidate spacing: finer for tighter fits
    corners, tris, interior, depth = [], [], [], []
    n = 0
    for P in hulls:
        h = ConvexHull(P)
        V, T = _subdivide(P[h.vertices], np.searchsorted(h.vertices, h.simplices), edge_max)
        corners.append(V)
        tris.append(T + n)
        n += V.shape[0]
        lo, hi = P.min(0), P.max(0)
        mid = 0.5 * (lo + hi)  # grid through the bounding-box centre (thin boxes get a mid-plane)
        axes = [mid[i] + grid * np.arange(-np.floor((mid[i] - lo[i]) / grid),
                                          np.floor((hi[i] - mid[i]) / grid) + 1) for i in range(3)]
        G = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        inside = G[Delaunay(P[h.vertices]).find_simplex(G) >= 0]
        if inside.shape[0] == 0:
            inside = P[h.vertices].mean(0, keepdims=True)
        interior.append(inside)
        depth.append(_depth_below(inside, h.equations))
    V, T, C, depth = np.vstack(corners), np.vstack(tris), np.vstack(interior), np.concatenate(depth)
    # centres: greedy set cover of representative surface / interior points by candidate spheres
    # centred on interior grid points, each with radius = its depth below the hull + protrusion
    Es, Ei = _voxel_representatives(V, 0.5 * grid), _voxel_representatives(C, 4.0 * grid)
    E = np.vstack([Es, Ei])
    w = np.concatenate([np.ones(len(Es)), np.full(len(Ei), 0.2)])
    rc = np.minimum(depth + protrusion, fit.radius_max)
    chosen = _greedy_cover(C, rc, E, w)
    if chosen.shape[0] == 0:
        raise CompassInputError("protrusion/radius_max too small to cover a link's geometry")
    centers, r_cand = C[chosen], rc[chosen]
    # exact radii: each triangle (all 3 corners) and interior point goes to the sphere that must
    # grow least beyond its candidate radius; a sphere's radius is the farthest element it owns
    dV = np.linalg.norm(V[:, None, :] - centers[None], axis=2)
    need = np.vstack([np.maximum(np.maximum(dV[T[:, 0]], dV[T[:, 1]]), dV[T[:, 2]]),
                      np.linalg.norm(C[:, None, :] - centers[None], axis=2)])
    owner = np.argmin(np.maximum(need - r_cand, 0.0) + 1e-6 * need, axis=1)
    radii = np.array([need[owner == k, k].max(initial=0.0) for k in range(len(centers))])
    # drop redundant spheres: everything they hold already lies inside the others
    keep = np.ones(len(centers), bool)
    for k in np.argsort(radii):
        others = keep.copy()
        others[k] = False
        if others.any() and np.all((need[:, others] <= radii[others]).any(axis=1)):
            keep[k] = False
    return centers[keep], radii[keep]


#: Decimals [m] kept when hashing geometry: compiled hulls and link transforms differ in
#: their last bits between machines, and a cache key must not.
HASH_DECIMALS = 6


def stable_bytes(a: np.ndarray, sort_rows: bool = False) -> bytes:
    """Bytes of an array for cache keys: floats rounded to HASH_DECIMALS (-0.0 folded into
    0.0), rows sorted when their order carries no meaning (hull vertices)."""
    a = np.asarray(a)
    if a.dtype.kind == "f":
        a = np.round(a.astype(np.float64), HASH_DECIMALS) + 0.0
    if sort_rows and a.ndim == 2 and len(a):
        a = a[np.lexsort(a.T[::-1])]
    return np.ascontiguousarray(a).tobytes()


def _geometry_hash(hulls: list[list[np.ndarray]], fit: SphereFitConfig) -> str:
    h = hashlib.sha256(fit.key().encode())
    for link in hulls:
        h.update(b"|")
        for P in link:
            h.update(stable_bytes(P, sort_rows=True))
    return h.hexdigest()[:16]
