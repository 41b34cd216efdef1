"""Frontiers: free voxels with at least one unknown 6-neighbour, grouped into clusters.

Neighbours outside the grid do not count as unknown (space outside the workspace box is not
explored). Clusters are connected components of the frontier voxels (26-connectivity by
default; union-find over the frontier voxels only, numbered in C order of their first voxel
like `scipy.ndimage.label`) with at least `min_cluster_size` voxels. Each cluster has a
centroid [m], a size [voxels] and the mean direction into unknown space: the average of the
frontier voxels' unit vectors towards their unknown neighbours, normalised.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..errors import CompassInputError, instance_of, check_field_types
from .occupancy import OccupancyMap
from .raycast import FREE, UNKNOWN

_OFFSETS = np.array(
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.int64
)


@dataclass(frozen=True)
class FrontierConfig:
    """min_cluster_size [voxels]; connectivity 6, 18 or 26 for clustering."""

    min_cluster_size: int = 10
    connectivity: int = 26

    def __post_init__(self) -> None:
        check_field_types(self)
        if not (isinstance(self.min_cluster_size, int) and self.min_cluster_size >= 1):
            raise CompassInputError(f"min_cluster_size {self.min_cluster_size} is not allowed; use an int >= 1")
        if self.connectivity not in (6, 18, 26):
            raise CompassInputError(f"connectivity {self.connectivity} is not allowed; use 6, 18 or 26")


@dataclass(frozen=True, eq=False)
class FrontierCluster:
    """centroid_world (3,) [m]; size [voxels]; direction (3,) unit vector into unknown
    space (world frame); voxels (size, 3) grid indices of its frontier voxels."""

    centroid_world: np.ndarray
    size: int
    direction: np.ndarray
    voxels: np.ndarray


def frontier_mask(state: np.ndarray) -> np.ndarray:
    """(nx, ny, nz) bool: free voxels with an unknown 6-neighbour inside the grid."""
    idx, _ = _frontier_voxels(np.ascontiguousarray(state, dtype=np.uint8))
    mask = np.zeros(state.shape, bool)
    mask[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    return mask


def find_frontiers(occ_map: OccupancyMap, config: FrontierConfig | None = None) -> tuple[FrontierCluster, ...]:
    """Frontier clusters of the map, largest first (ties: by centroid x, y, z)."""
    instance_of(occ_map, OccupancyMap, "occ_map")
    config = FrontierConfig() if config is None else instance_of(config, FrontierConfig, "config")
    idx, dirs = _frontier_voxels(occ_map.state)
    if len(idx) == 0:
        return ()
    lookup = np.zeros(occ_map.state.size, np.int32)  # calloc: only touched pages cost
    lab, n_labels = _label(idx, lookup, np.asarray(occ_map.shape, np.int64), _neighbour_offsets(config.connectivity))
    sizes = np.bincount(lab, minlength=n_labels + 1)
    centres = occ_map.voxel_to_world(idx)
    sums = np.stack([np.bincount(lab, weights=centres[:, a], minlength=n_labels + 1) for a in range(3)], axis=1)
    dsum = np.stack([np.bincount(lab, weights=dirs[:, a], minlength=n_labels + 1) for a in range(3)], axis=1)
    order = np.argsort(lab, kind="stable")
    starts = np.concatenate([[0], np.cumsum(sizes)])
    clusters = []
    for k in range(1, n_labels + 1):
        if sizes[k] < config.min_cluster_size:
            continue
        members = order[starts[k]:starts[k + 1]]
        direction = _unit_direction(dsum[k], occ_map.state, idx[members])
        clusters.append(
            FrontierCluster(
                centroid_world=sums[k] / sizes[k], size=int(sizes[k]), direction=direction, voxels=idx[members]
            )
        )
    clusters.sort(key=lambda c: (-c.size, *c.centroid_world.tolist()))
    return tuple(clusters)


def _unit_direction(dsum: np.ndarray, state: np.ndarray, voxels: np.ndarray) -> np.ndarray:
    """Normalised mean direction; if it cancels out, the most frequent unknown-neighbour
    offset of the cluster (first in +x, -x, +y, -y, +z, -z order on ties)."""
    n = np.linalg.norm(dsum)
    if n > 1e-9:
        return dsum / n
    counts = np.zeros(6, np.int64)
    shape = np.asarray(state.shape)
    for a, off in enumerate(_OFFSETS):
        nb = voxels + off
        ok = np.all((nb >= 0) & (nb < shape), axis=1)
        nb = nb[ok]
        counts[a] = np.count_nonzero(state[nb[:, 0], nb[:, 1], nb[:, 2]] == UNKNOWN)
    return _OFFSETS[int(np.argmax(counts))].astype(np.float64)


@njit(cache=True, inline="always")
def _unknown_dir(state, i, j, k, nx, ny, nz):
    """Sum of unit offsets towards unknown 6-neighbours and their count."""
    dx = 0.0
    dy = 0.0
    dz = 0.0
    c = 0
    if i + 1 < nx and state[i + 1, j, k] == UNKNOWN:
        dx += 1.0
        c += 1
    if i > 0 and state[i - 1, j, k] == UNKNOWN:
        dx -= 1.0
        c += 1
    if j + 1 < ny and state[i, j + 1, k] == UNKNOWN:
        dy += 1.0
        c += 1
    if j > 0 and state[i, j - 1, k] == UNKNOWN:
        dy -= 1.0
        c += 1
    if k + 1 < nz and state[i, j, k + 1] == UNKNOWN:
        dz += 1.0
        c += 1
    if k > 0 and state[i, j, k - 1] == UNKNOWN:
        dz -= 1.0
        c += 1
    return dx, dy, dz, c


@njit(cache=True, parallel=True)
def _frontier_voxels(state):
    """Indices (F, 3) of frontier voxels in C order and their unit directions (F, 3)."""
    nx, ny, nz = state.shape
    counts = np.zeros(nx, np.int64)
    for i in prange(nx):
        c = 0
        for j in range(ny):
            for k in range(nz):
                if state[i, j, k] == FREE:
                    _, _, _, nu = _unknown_dir(state, i, j, k, nx, ny, nz)
                    if nu > 0:
                        c += 1
        counts[i] = c
    offsets = np.zeros(nx + 1, np.int64)
    for i in range(nx):
        offsets[i + 1] = offsets[i] + counts[i]
    idx = np.empty((offsets[nx], 3), np.int64)
    dirs = np.zeros((offsets[nx], 3))
    for i in prange(nx):
        n = offsets[i]
        for j in range(ny):
            for k in range(nz):
                if state[i, j, k] == FREE:
                    dx, dy, dz, nu = _unknown_dir(state, i, j, k, nx, ny, nz)
                    if nu > 0:
                        idx[n, 0] = i
                        idx[n, 1] = j
                        idx[n, 2] = k
                        norm = np.sqrt(dx * dx + dy * dy + dz * dz)
                        if norm > 0.0:
                            dirs[n, 0] = dx / norm
                            dirs[n, 1] = dy / norm
                            dirs[n, 2] = dz / norm
                        n += 1
    return idx, dirs


def _neighbour_offsets(connectivity: int) -> np.ndarray:
    """The half of the 6/18/26 neighbour offsets that comes later in C order."""
    offs = [
        (a, b, c)
        for a in (-1, 0, 1)
        for b in (-1, 0, 1)
        for c in (-1, 0, 1)
        if (a, b, c) > (0, 0, 0) and abs(a) + abs(b) + abs(c) <= {6: 1, 18: 2, 26: 3}[connectivity]
    ]
    return np.array(offs, dtype=np.int64)


@njit(cache=True, inline="always")
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True)
def _label(idx, lookup, shape, offsets):
    """Connected-component labels (F,) in 1..L of voxels idx (F, 3) (C order), and L.

    lookup: all-zero int32 scratch of the grid's size."""
    ny = shape[1]
    nz = shape[2]
    n = idx.shape[0]
    parent = np.arange(n)
    for f in range(n):
        lookup[(idx[f, 0] * ny + idx[f, 1]) * nz + idx[f, 2]] = f + 1
    for f in range(n):
        for o in range(offsets.shape[0]):
            i = idx[f, 0] + offsets[o, 0]
            j = idx[f, 1] + offsets[o, 1]
            k = idx[f, 2] + offsets[o, 2]
            if i < 0 or j < 0 or k < 0 or i >= shape[0] or j >= ny or k >= nz:
                continue
            g = lookup[(i * ny + j) * nz + k]
            if g > 0:
                ra = _find(parent, f)
                rb = _find(parent, g - 1)
                if ra != rb:
                    if ra < rb:
                        parent[rb] = ra
                    else:
                        parent[ra] = rb
    labels = np.zeros(n, np.int64)
    root_label = np.zeros(n, np.int64)
    n_labels = 0
    for f in range(n):  # roots are the smallest member, so labels follow C order
        r = _find(parent, f)
        if root_label[r] == 0:
            n_labels += 1
            root_label[r] = n_labels
        labels[f] = root_label[r]
    return labels, n_labels
