"""OctoMap interop through `octomap-python`: OcTree conversion and `.bt` files.

`to_octree` copies every known voxel with its exact log-odds into an `octomap.OcTree` of
the same resolution and sensor model (voxel boundaries coincide: both use keys
floor(x / res)). A `.bt` file stores maximum-likelihood labels only, so `read_bt` gives
free voxels the lower and occupied voxels the upper clamping log-odds, as OctoMap's own
`readBinary` does. A round trip preserves every free / occupied / unknown label inside the
grid. octomap-python takes file names as bytes.
"""
from __future__ import annotations

import os

import numpy as np
import octomap

from ..errors import CompassInputError
from .occupancy import MapConfig, OccupancyMap, VoxelState


def to_octree(occ_map: OccupancyMap) -> octomap.OcTree:
    """An OcTree holding the map's known voxels with their log-odds."""
    c = occ_map.config
    tree = octomap.OcTree(occ_map.resolution)
    tree.setProbHit(c.prob_hit)
    tree.setProbMiss(c.prob_miss)
    tree.setClampingThresMin(c.clamp_min)
    tree.setClampingThresMax(c.clamp_max)
    tree.setOccupancyThres(c.occupancy_threshold)
    idx = np.argwhere(occ_map.state != VoxelState.UNKNOWN)
    if len(idx) == 0:
        return tree
    values = occ_map.logodds[idx[:, 0], idx[:, 1], idx[:, 2]]
    centres = occ_map.voxel_to_world(idx)
    # log-odds take few distinct values (sums of hit/miss steps): one batched update each
    for v in np.unique(values):
        pts = np.ascontiguousarray(centres[values == v])
        tree.updateNodes(pts, float(v), True)
    tree.updateInnerOccupancy()
    return tree


def from_octree(tree: octomap.OcTree, config: MapConfig | None = None) -> OccupancyMap:
    """A map on `config`'s box holding the tree's labels (clamping log-odds, see module doc).

    The tree's resolution must equal the config's; leaves outside the box are ignored.
    """
    config = config or MapConfig()
    if abs(tree.getResolution() - config.resolution) > 1e-12:
        raise CompassInputError(
            f"OcTree resolution {tree.getResolution()} m differs from the map resolution {config.resolution} m"
        )
    occ_map = OccupancyMap(config)
    res = occ_map.resolution
    free_idx, occ_idx = [], []
    for leaf in tree.begin_leafs():
        size = leaf.getSize()
        centre = np.asarray(leaf.getCoordinate(), dtype=np.float64)
        n = max(int(round(size / res)), 1)
        if n == 1:
            idx = occ_map.world_to_voxel(centre)
        else:  # a pruned leaf covers n^3 voxels
            lo = occ_map.world_to_voxel(centre - 0.5 * size + 0.5 * res)[0]
            g = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
            idx = lo + g
        idx = idx[occ_map.in_grid(idx)]
        (occ_idx if tree.isNodeOccupied(leaf) else free_idx).append(idx)
    for lst, state in ((free_idx, VoxelState.FREE), (occ_idx, VoxelState.OCCUPIED)):
        if lst:
            occ_map.set_voxels(np.concatenate(lst), state)
    return occ_map


def write_bt(occ_map: OccupancyMap, path: str | os.PathLike) -> None:
    """Write the map's labels as an OctoMap binary `.bt` file."""
    tree = to_octree(occ_map)
    if not tree.writeBinary(os.fsencode(path)):
        raise CompassInputError(f"could not write OctoMap file {os.fspath(path)!r}; check the folder exists")


def read_bt(path: str | os.PathLike, config: MapConfig | None = None) -> OccupancyMap:
    """Read an OctoMap binary `.bt` file into a map on `config`'s box."""
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise CompassInputError(f"OctoMap file {p!r} does not exist")
    tree = octomap.OcTree(os.fsencode(p))
    return from_octree(tree, config)
