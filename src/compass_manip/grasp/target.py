"""The target as the grasp planner sees it: surface points with outward normals, its
principal axes, and a symmetry completion of the side the camera has not seen.

Points come from the detection view (the target's pixels back-projected with depth) and,
beyond the paper (which uses that one view), from the map's occupied voxels in the target's
region over all views. A single view sees about half of the object; the unseen half is
completed by mirroring the seen points through a vertical plane across the viewing
direction (Bohg et al., "Mind the gap", ICRA 2011), placed so that the object's depth along
the view matches the query's size where the view itself does not show it. Normals: PCA of
the k nearest neighbours, oriented away from the estimated object centre (the targets are
convex household objects).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..errors import CompassInputError, check_field_types
from ..mapping.occupancy import OccupancyMap, VoxelState
from ..task import TargetQuery


@dataclass(frozen=True)
class TargetConfig:
    """voxel [m]: points are thinned to one per cube of this edge; normal_k neighbours for
    PCA normals; fuse_map: add the map's occupied voxel centres in the target's region;
    fuse_margin [m]: that region is the detection points' box grown by this (never
    downwards: the support stays out); mirror: complete the unseen side by symmetry;
    grow_up: with a query, the region also grows upwards over the layers of the map that hold
    an occupied voxel above the points' footprint, layer by layer from the points' top, up to
    the lowest point plus the query's height (+ fuse_margin): a detector's mask may miss a
    thin top part (a bottle's neck: on trial (1, 1) of seed 303 the detection ended 3.7 cm
    below the true top), and the part's voxels then blocked every hand as an obstacle; the
    first layer without an occupied voxel ends the growth, so a board above a gap stays out;
    round_axis: a round target (`ROUND_SHAPES`, by the query) is mirrored through its own
    axis, found from its horizontal slices of `slice` [m] (`round_axis`)."""

    voxel: float = 0.004
    normal_k: int = 10
    fuse_map: bool = True
    fuse_margin: float = 0.01
    mirror: bool = True
    grow_up: bool = True
    round_axis: bool = True
    slice: float = 0.01

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if not 0.0005 <= self.voxel <= 0.05:
            raise CompassInputError(f"TargetConfig.voxel = {self.voxel} m is not allowed; use 0.0005..0.05 m")
        if not 4 <= self.normal_k <= 100:
            raise CompassInputError(f"TargetConfig.normal_k = {self.normal_k} is not allowed; use 4..100")
        if not 0.002 <= self.slice <= 0.1:
            raise CompassInputError(f"TargetConfig.slice = {self.slice} m is not allowed; use 0.002..0.1 m")
        if not 0.0 <= self.fuse_margin <= 0.1:
            raise CompassInputError(f"TargetConfig.fuse_margin = {self.fuse_margin} m is not allowed; use 0..0.1 m")


@dataclass(frozen=True, eq=False)
class TargetModel:
    """points (N,3) [m] world surface points; normals (N,3) outward unit normals; observed
    (N,) True for sensed points, False for symmetry-completed ones; centre (3,) [m]
    estimated object centre; axes (3,3) principal axes as columns, largest spread first;
    extents (3,) [m] full extents of the points along those axes; view_dir (3,) unit
    horizontal direction from the detection camera towards the target."""

    points: np.ndarray
    normals: np.ndarray
    observed: np.ndarray
    centre: np.ndarray
    axes: np.ndarray
    extents: np.ndarray
    view_dir: np.ndarray

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def bottom_z(self) -> float:
        """Lowest point [m] (the support surface lies below)."""
        return float(self.points[:, 2].min())


def backproject(depth: np.ndarray, K: np.ndarray, T_world_cam: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """World points (M,3) [m] of the masked pixels with a valid (finite, > 0) depth [m]."""
    depth = np.asarray(depth)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != depth.shape:
        raise CompassInputError(f"mask shape {mask.shape} must equal the depth image's {depth.shape}")
    v, u = np.nonzero(mask & np.isfinite(depth) & (depth > 0))
    z = depth[v, u].astype(np.float64)
    pc = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z], axis=1)
    return pc @ T_world_cam[:3, :3].T + T_world_cam[:3, 3]


def thin(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point (the mean) per occupied cube of edge `voxel` [m], in a deterministic order."""
    keys = np.floor(points / voxel).astype(np.int64)
    _, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.ravel()
    sums = np.zeros((inv.max() + 1, 3))
    np.add.at(sums, inv, points)
    return sums / np.bincount(inv)[:, None]


def pca_normals(points: np.ndarray, k: int) -> np.ndarray:
    """Unit normals (N,3) (unoriented): smallest principal direction of each point's k
    nearest neighbours."""
    k = min(k, len(points))
    _, idx = cKDTree(points).query(points, k=k)
    nb = points[idx]  # (N,k,3)
    d = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", d, d)
    _, vec = np.linalg.eigh(cov)
    return vec[:, :, 0]


def normal_cones(points: np.ndarray, normals: np.ndarray, idx: np.ndarray, radius: float, k: int,
                 edge_angle: float) -> np.ndarray:
    """(M,k,3) the normal cones of the points `idx` (M,) of a model (points (N,3) [m],
    outward unit normals (N,3)): a point is on an edge when a neighbour within `radius` [m]
    (its k - 1 nearest) has a normal more than `edge_angle` [rad] from its own, and its cone
    is then its own normal and those of its neighbours within radius that face its side
    (within 90 deg: not the far face of a thin part); elsewhere the cone is its own normal
    alone (repeated). PCA normals blend the faces that meet at an edge (a can's top rim:
    39 deg off the true side normal on level 3 scene 0 of seed 0); its neighbours' normals
    span the faces on both sides, so a contact there is force-closure (`quality.
    required_mu_cones`) only where the faces' normals allow it."""
    P = np.asarray(points, dtype=np.float64)
    Nm = np.asarray(normals, dtype=np.float64)
    idx = np.asarray(idx, dtype=np.int64)
    k = max(1, min(int(k), len(P)))
    own = Nm[idx]
    cones = np.repeat(own[:, None, :], k, axis=1)
    if len(idx) == 0 or k == 1:
        return cones
    dist, nb = cKDTree(P).query(P[idx], k=k)
    nbn = Nm[nb]  # (M,k,3)
    cos = np.einsum("mkj,mj->mk", nbn, own)
    near = dist <= radius
    edge = np.any(near & (cos < np.cos(edge_angle)), axis=1)
    use = near & (cos > 0.0) & edge[:, None]
    cones[use] = nbn[use]
    return cones


def principal_axes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal axes (3,3) as columns, largest spread first (right-handed), and the full
    extents (3,) [m] of the points along them."""
    c = points.mean(axis=0)
    w, vec = np.linalg.eigh(np.cov((points - c).T))
    axes = vec[:, ::-1].copy()
    axes[:, 2] = np.cross(axes[:, 0], axes[:, 1])
    proj = (points - c) @ axes
    return axes, proj.max(axis=0) - proj.min(axis=0)


def map_points_in_region(occ: OccupancyMap, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Centres (M,3) [m] of the map's occupied voxels whose centres lie in the box [lo, hi]."""
    i0 = np.clip(occ.world_to_voxel(np.asarray(lo)[None])[0], 0, np.array(occ.shape) - 1)
    i1 = np.clip(occ.world_to_voxel(np.asarray(hi)[None])[0], 0, np.array(occ.shape) - 1)
    sub = occ.state[i0[0]:i1[0] + 1, i0[1]:i1[1] + 1, i0[2]:i1[2] + 1] == VoxelState.OCCUPIED
    ijk = np.argwhere(sub) + i0
    pts = occ.grid_min + (ijk + 0.5) * occ.resolution
    return pts[np.all((pts >= lo) & (pts <= hi), axis=1)]


def grow_top(occ: OccupancyMap, lo: np.ndarray, hi: np.ndarray, z_max: float, shrink: float = 0.0) -> float:
    """The box lo..hi (3,) [m] grown upwards one map layer at a time while the next layer holds
    an occupied voxel (centre) within the box's x-y footprint, never above z_max [m]; the new
    top z [m] (hi[2] when nothing grows). A layer without an occupied voxel ends the growth
    only when its core (the footprint shrunk by `shrink` [m]: the points' own x-y box) is
    all seen free; one with unknown voxels there is passed over (the top is raised only by
    the occupied layers above it): an occluder in front can hide a band of the target from
    every view (a bottle's shoulder on trial (3, 1) of seed 101: two unknown layers between
    its detected body and its neck's occupied voxels, the space in front of the neck seen
    free)."""
    top = float(hi[2])
    shape = np.array(occ.shape) - 1
    i0 = np.clip(occ.world_to_voxel(np.asarray(lo)[None])[0], 0, shape)
    i1 = np.clip(occ.world_to_voxel(np.asarray(hi)[None])[0], 0, shape)
    c0 = np.clip(occ.world_to_voxel((np.asarray(lo) + shrink)[None])[0], i0, i1)
    c1 = np.clip(occ.world_to_voxel((np.asarray(hi) - shrink)[None])[0], c0, i1)
    # the first layer to test is the lowest whose centre lies above the box: the layer
    # holding hi[2] counts as inside only when its centre does (`map_points_in_region`
    # takes voxel centres), else its occupied voxels - a bottle's top 1.3 cm above the
    # detection - would stay outside the model and block the hands as an obstacle
    k = int(i1[2]) - (1 if occ.grid_min[2] + (int(i1[2]) + 0.5) * occ.resolution > top else 0)
    while True:
        k += 1
        zc = occ.grid_min[2] + (k + 0.5) * occ.resolution
        if k >= occ.shape[2] or zc > z_max:
            return top
        if np.any(occ.state[i0[0]:i1[0] + 1, i0[1]:i1[1] + 1, k] == VoxelState.OCCUPIED):
            top = min(zc + 0.5 * occ.resolution, z_max)
        elif np.all(occ.state[c0[0]:c1[0] + 1, c0[1]:c1[1] + 1, k] == VoxelState.FREE):
            return top


#: Shape classes whose horizontal cross-sections are round (`round_plane`).
ROUND_SHAPES = ("can", "bottle", "cylinder")


def round_axis(pts: np.ndarray, view: np.ndarray, slice_m: float) -> tuple[float, float, float] | None:
    """For a target with round horizontal cross-sections on one vertical axis (a can, a
    bottle with its neck) seen from the horizontal unit direction `view` (3,): (its axis's
    depth along view, its position across the view (along z x view) [m], the widest seen
    slice's width [m]). Each horizontal slice (slice_m [m] thick) seen at least 1 cm wide
    puts the axis at its front plus half its width; the foremost of those is taken. None
    when no slice is seen 1 cm wide. A slice whose front is hidden (a severe level's bottle:
    the top of its body, seen from above over the box in front, whose front face the box
    hides) puts the axis too far back: on (2, 1) of seed 0 the widest slice put it 2.1 cm
    behind the true axis, the neck's slices within 1 mm."""
    side = np.array([-view[1], view[0], 0.0])
    along, across = pts @ view, pts @ side
    k = np.floor(pts[:, 2] / slice_m).astype(np.int64)
    best, widest = None, 0.0
    for b in np.unique(k):
        m = k == b
        w = float(across[m].max() - across[m].min())
        widest = max(widest, w)
        if w < 0.01:
            continue
        est = (float(along[m].min()) + 0.5 * w, 0.5 * float(across[m].max() + across[m].min()))
        if best is None or est[0] < best[0]:
            best = est
    return None if best is None else (best[0], best[1], widest)


def round_plane(pts: np.ndarray, view: np.ndarray, along: np.ndarray, slice_m: float) -> float | None:
    """The depth along `view` of a round target's axis (`round_axis`), None when no slice is
    seen at least 1 cm wide (along: pts @ view, kept for the callers). A bottle whose body
    hides behind an occluder is then mirrored through its neck's axis, not through a plane
    half the body's width behind the neck's front (a 2.6 cm neck modelled 6 cm deep)."""
    axis = round_axis(pts, view, slice_m)
    return None if axis is None else axis[0]


def build_target_model(points: np.ndarray, camera_origin: np.ndarray, query: TargetQuery | None = None,
                       occ: OccupancyMap | None = None, config: TargetConfig | None = None) -> TargetModel:
    """The target model from its detected points (M,3) [m] seen from camera_origin (3,) [m].

    query: the TargetQuery (its size bounds the unseen depth); occ: the occupancy map to fuse
    (None: the detection view only, as in the paper).
    """
    config = config or TargetConfig()
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) < 10:
        raise CompassInputError(f"a target model needs at least 10 finite points, got {len(pts)}")
    cam = np.asarray(camera_origin, dtype=np.float64)
    if occ is not None and config.fuse_map:
        lo, hi = pts.min(0) - config.fuse_margin, pts.max(0) + config.fuse_margin
        lo[2] = pts[:, 2].min() + 0.5 * occ.resolution  # never the support below
        if query is not None and config.grow_up:
            hi[2] = grow_top(occ, lo, hi, pts[:, 2].min() + float(query.size[2]) + config.fuse_margin,
                             config.fuse_margin)
        extra = map_points_in_region(occ, lo, hi)
        if len(extra):
            pts = np.vstack([pts, extra])
    pts = thin(pts, config.voxel)
    if len(pts) < 10:
        raise CompassInputError(f"the target's points span fewer than 10 cubes of {config.voxel} m")
    view = pts.mean(0) - cam
    view[2] = 0.0
    if np.linalg.norm(view) < 1e-6:  # looking straight down: any horizontal direction
        view = np.array([1.0, 0.0, 0.0])
    view /= np.linalg.norm(view)
    along = pts @ view
    front = float(along.min())
    depth = float(along.max() - front)
    if query is not None:
        depth = max(depth, float(min(query.size[:2])))
    plane = front + 0.5 * depth
    if query is not None and query.shape in ROUND_SHAPES and config.round_axis:
        axis = round_plane(pts, view, along, config.slice)
        if axis is not None:  # its own axis, never in front of what was seen
            plane = max(axis, front + 0.5 * float(along.max() - front))
    centre = pts.mean(0)
    centre += (plane - centre @ view) * view
    normals = pca_normals(pts, config.normal_k)
    flip = np.sum(normals * (pts - centre), axis=1) < 0
    normals[flip] *= -1
    observed = np.ones(len(pts), dtype=bool)
    if config.mirror:
        front_side = along < plane - 0.5 * config.voxel
        mp = pts[front_side] - 2.0 * (along[front_side] - plane)[:, None] * view
        mn = normals[front_side] - 2.0 * (normals[front_side] @ view)[:, None] * view
        pts, normals = np.vstack([pts, mp]), np.vstack([normals, mn])
        observed = np.r_[observed, np.zeros(len(mp), dtype=bool)]
    axes, extents = principal_axes(pts)
    return TargetModel(pts, normals, observed, centre, axes, extents, view)
