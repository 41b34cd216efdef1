"""Collision spheres of the Panda, hand, fingers and camera housing, fitted to the model.

The spheres are generated from the collision geometry of the compiled robot-only MuJoCo model
(geoms with contype or conaffinity set: link meshes, hand mesh, camera_housing box, finger
boxes). MuJoCo collides meshes through their convex hulls, so each hull (or box) is
triangulated and subdivided to edges <= `edge_max` [m]. Candidate spheres sit on interior
grid points with radius = depth below the hull surface + `protrusion` [m]; a greedy set cover
picks centres, then each sphere's radius is set exactly so that every subdivided triangle
(all three corners) and interior grid point lies inside one sphere: the whole hull surface is
inside the union (a ball is convex). `padding` [m] is then added to every radius. Results are
cached in .npz/.npy files keyed by a hash of the geometry and the fit parameters
(COMPASS_CACHE_DIR, default ~/.cache/compass_manip); a cold fit takes a few seconds.
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from functools import lru_cache

import numba as nb
import numpy as np

from .kinematics import PandaKinematics, check_Q, fk_links_kernel
from .sphere_fit import FINE_FIT, SphereFitConfig, stable_bytes, _fit_link, _geometry_hash, collision_hulls  # noqa: F401
from .model import GRIPPER_MAX_WIDTH, Q_HOME, Q_MAX, Q_MIN, RobotConfig, build_robot_spec, check_q


@dataclass(frozen=True, eq=False)
class SphereModel:
    """Spheres attached to link frames of `kinematics` (index = `kinematics.link_names`).

    body_index (S,) link index; centers_local (S,3) [m] in the link frame; radii (S,) [m];
    self_collision_pairs (P,2) sphere indices to test against each other (non-adjacent links,
    not overlapping at Q_HOME nor in every sampled configuration).
    """

    kinematics: PandaKinematics
    body_index: np.ndarray
    centers_local: np.ndarray
    radii: np.ndarray
    self_collision_pairs: np.ndarray

    @property
    def n_spheres(self) -> int:
        return int(self.radii.shape[0])

    @property
    def link_names(self) -> tuple[str, ...]:
        return self.kinematics.link_names

    def kernel_args(self) -> tuple:
        """Arguments after Q for `sphere_centers_kernel`."""
        return (*self.kinematics.kernel_args(), self.body_index, self.centers_local)

    def sphere_centers(self, Q: np.ndarray) -> np.ndarray:
        """World sphere centres (N,S,3) [m] for Q (N,7) [rad]."""
        Q = check_Q(Q)
        out = np.empty((Q.shape[0], self.n_spheres, 3))
        if Q.shape[0] == 1:  # one configuration (e.g. a frame's self filter): no parallel launch
            args = self.kernel_args()
            sphere_centers_one(Q[0], *args, np.empty((args[1].shape[0], 4, 4)), out[0])
            return out
        return sphere_centers_kernel(Q, *self.kernel_args(), out)


@nb.njit(cache=True)
def sphere_centers_one(q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor,
                       body_index, centers_local, links, out):
    """World centres (S,3) of one configuration q (7,); links (L,4,4) is scratch space."""
    fk_links_kernel(q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, links)
    for s in range(body_index.shape[0]):
        T = links[body_index[s]]
        c = centers_local[s]
        for r in range(3):
            out[s, r] = T[r, 0] * c[0] + T[r, 1] * c[1] + T[r, 2] * c[2] + T[r, 3]
    return out


@nb.njit(cache=True, parallel=True)
def sphere_centers_kernel(Q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor,
                          body_index, centers_local, out):
    """World centres (N,S,3) for Q (N,7)."""
    L = parent.shape[0]
    for n in nb.prange(Q.shape[0]):
        links = np.empty((L, 4, 4))
        sphere_centers_one(Q[n], finger_pos, parent, T_parent_link, joint_kind, joint_index, axis,
                           anchor, body_index, centers_local, links, out[n])
    return out


def sphere_centers(sphere_model: SphereModel, Q: np.ndarray) -> np.ndarray:
    """World sphere centres (N,S,3) [m] for Q (N,7) [rad] (numba, parallel over N)."""
    return sphere_model.sphere_centers(Q)


def sphere_centers_world(sphere_model: SphereModel, q: np.ndarray) -> np.ndarray:
    """World sphere centres (S,3) [m] for one configuration q (7,) [rad]."""
    q = check_q(q)
    return sphere_model.sphere_centers(q[None])[0]


#: Fits shipped with the package (made by `python -m compass_manip.robot.spheres`), so a
#: fresh machine does not spend minutes fitting; names carry the hash of the geometry and
#: fit parameters, so a changed model never picks up a stale file.
SHIPPED_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
_USED_NAMES: set[str] = set()


def _cached(name: str, compute) -> dict:
    """Arrays saved as COMPASS_CACHE_DIR/name.npz (default ~/.cache/compass_manip), computed
    by compute() -> dict of arrays when missing; written atomically (skipped if not writable).
    A file of that name shipped in SHIPPED_DIR is used first."""
    folder = os.environ.get("COMPASS_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "compass_manip"))
    path = os.path.join(folder, f"{name}.npz")
    _USED_NAMES.add(name)
    for candidate in (os.path.join(SHIPPED_DIR, f"{name}.npz"), path):
        if os.path.isfile(candidate):
            with np.load(candidate) as z:
                return {k: z[k] for k in z.files}
    arrays = compute()
    try:
        os.makedirs(folder, exist_ok=True)
        tmp = f"{path}.{os.getpid()}.tmp.npz"
        np.savez(tmp, **arrays)
        os.replace(tmp, path)
    except OSError:  # read-only home: keep the result in memory only
        pass
    return arrays


def fit_spheres(kin: PandaKinematics, fit: SphereFitConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(body_index, centers_local, radii incl. padding) for the robot of `kin`, cached on disk."""
    hulls = collision_hulls(build_robot_spec(kin.robot_config, actuators=False).compile(), kin.link_names)

    def compute() -> dict:
        bi, cs, rs = [], [], []
        for i, link in enumerate(hulls):
            if link:
                fine = kin.link_names[i] in fit.fine_links
                c, r = _fit_link(link, fit, fit.fine_protrusion if fine else fit.protrusion,
                                 fit.fine_edge_max if fine else None)
                bi.append(np.full(len(r), i, np.int64))
                cs.append(c)
                rs.append(r + fit.padding)
        return {"body_index": np.concatenate(bi), "centers_local": np.vstack(cs), "radii": np.concatenate(rs)}

    z = _cached(f"panda_spheres_{_geometry_hash(hulls, fit)}", compute)
    return z["body_index"], z["centers_local"], z["radii"]


def weld_groups(kin: PandaKinematics) -> np.ndarray:
    """Group id per link: links without an arm joint belong to their parent's group
    (fingers join the hand: they only move with the gripper)."""
    t = kin.tree
    g = np.arange(t.n_links)
    for i in range(t.n_links):
        if t.joint_kind[i] != 1 and t.parent[i] >= 0:
            g[i] = g[t.parent[i]]
    return g


def self_collision_pairs(kin: PandaKinematics, body_index: np.ndarray, centers: np.ndarray,
                         radii: np.ndarray, fit: SphereFitConfig) -> np.ndarray:
    """Sphere pairs on non-adjacent link groups that are apart at Q_HOME and in some sample."""
    t = kin.tree
    g = weld_groups(kin)
    gb = g[body_index]
    gp = np.where(t.parent >= 0, g[np.maximum(t.parent, 0)], -1)  # parent group of each link
    parent_group = {int(g[i]): int(gp[i]) for i in range(t.n_links) if t.joint_kind[i] == 1}
    ii, jj = np.triu_indices(len(radii), k=1)
    a, b = gb[ii], gb[jj]
    adjacent = (a == b) | np.array([parent_group.get(int(x)) == int(y) or parent_group.get(int(y)) == int(x)
                                    for x, y in zip(a, b)], bool)
    ii, jj = ii[~adjacent], jj[~adjacent]
    rng = np.random.default_rng(fit.seed)
    Q = np.vstack([Q_HOME, rng.uniform(Q_MIN, Q_MAX, (fit.n_pair_samples, 7))])
    out = np.empty((Q.shape[0], len(radii), 3))
    W = sphere_centers_kernel(Q, *kin.kernel_args(), body_index, centers, out)
    n_overlap = _count_overlaps(W[1:], radii, ii, jj)
    at_home = _count_overlaps(W[:1], radii, ii, jj) > 0
    keep = ~at_home & (n_overlap < W.shape[0] - 1)
    return np.stack([ii[keep], jj[keep]], 1).astype(np.int64)


@nb.njit(cache=True)
def _count_overlaps(W, radii, ii, jj):
    """Per pair (ii[p], jj[p]): number of configurations in W (N,S,3) where the spheres overlap."""
    out = np.zeros(ii.shape[0], np.int64)
    for n in range(W.shape[0]):
        for p in range(ii.shape[0]):
            a, b = ii[p], jj[p]
            d2 = (W[n, a, 0] - W[n, b, 0]) ** 2 + (W[n, a, 1] - W[n, b, 1]) ** 2 + (W[n, a, 2] - W[n, b, 2]) ** 2
            if d2 < (radii[a] + radii[b]) ** 2:
                out[p] += 1
    return out


@lru_cache(maxsize=8)
def _cached_model(config: RobotConfig, finger_width: float, fit: SphereFitConfig) -> SphereModel:
    kin = PandaKinematics(config, finger_width)
    bi, c, r = fit_spheres(kin, fit)
    # self-collision pairs do not depend on the base pose: cache them keyed by everything else
    t = kin.tree
    h = hashlib.sha256(f"({fit.key()}, {kin.finger_pos!r})".encode())
    for a in (bi, c, r, t.T_parent_link[1:], t.axis, t.anchor, t.parent, t.joint_kind):
        h.update(stable_bytes(a))
    pairs = _cached(f"panda_selfpairs_{h.hexdigest()[:16]}",
                    lambda: {"pairs": self_collision_pairs(kin, bi, c, r, fit)})["pairs"]
    for a in (bi, c, r, pairs):
        a.setflags(write=False)
    return SphereModel(kin, bi, c, r, pairs)


def panda_sphere_model(robot_config: RobotConfig | None = None, finger_width: float = GRIPPER_MAX_WIDTH,
                       fit: SphereFitConfig | None = None) -> SphereModel:
    """Sphere model of the Panda + hand (fingers at finger_width [m]) + camera housing."""
    return _cached_model(robot_config or RobotConfig(), float(finger_width), fit or SphereFitConfig())


def _ship_fits() -> None:
    """Write the fits the package uses (default model at 0.08 and 0.13 m finger openings,
    MotionBenchMaker's fine model at 0.13 m) to SHIPPED_DIR, compressed; fits missing from
    the user cache are computed first."""
    _cached_model.cache_clear()
    _USED_NAMES.clear()
    for width, fit in ((GRIPPER_MAX_WIDTH, None), (0.13, None), (0.13, FINE_FIT)):
        panda_sphere_model(finger_width=width, fit=fit)
    folder = os.environ.get("COMPASS_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "compass_manip"))
    os.makedirs(SHIPPED_DIR, exist_ok=True)
    for name in sorted(_USED_NAMES):
        target = os.path.join(SHIPPED_DIR, f"{name}.npz")
        if not os.path.isfile(target):
            with np.load(os.path.join(folder, f"{name}.npz")) as z:
                np.savez_compressed(target, **{k: z[k] for k in z.files})


if __name__ == "__main__":
    _ship_fits()
