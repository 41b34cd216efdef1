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

import numba
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


def from_octree(tree: octomap.OcTree, config: MapConfig | None = None, source: str = "OcTree") -> OccupancyMap:
    """A map on `config`'s box holding the tree's labels (clamping log-odds, see module doc).

    The tree's resolution must equal the config's; leaves outside the box are ignored. Each
    leaf is clipped to the box before its voxels are touched, so the work is bounded by the
    number of leaves plus the grid's size (leaves are disjoint), whatever their sizes.
    """
    config = config or MapConfig()
    if abs(tree.getResolution() - config.resolution) > 1e-12:
        raise CompassInputError(
            f"{source}: resolution {tree.getResolution()} m differs from the map resolution {config.resolution} m; "
            "read it with MapConfig(resolution=...) equal to the file's"
        )
    occ_map = OccupancyMap(config)
    res = occ_map.resolution
    shape = np.asarray(occ_map.shape)
    single: dict[bool, list] = {False: [], True: []}
    for leaf in tree.begin_leafs():
        size = leaf.getSize()
        centre = np.asarray(leaf.getCoordinate(), dtype=np.float64)
        occupied = bool(tree.isNodeOccupied(leaf))
        n = max(int(round(size / res)), 1)
        if n == 1:
            single[occupied].append(occ_map.world_to_voxel(centre)[0])
            continue
        # a pruned leaf covers n^3 voxels: clip its index box to the grid first
        lo = occ_map.world_to_voxel(centre - 0.5 * size + 0.5 * res)[0]
        a = np.clip(lo, 0, shape)
        b = np.clip(lo + n, 0, shape)
        if np.any(b <= a):
            continue
        sl = tuple(slice(int(x), int(y)) for x, y in zip(a, b))
        state = VoxelState.OCCUPIED if occupied else VoxelState.FREE
        occ_map.logodds[sl] = occ_map._logs[3] if occupied else occ_map._logs[2]
        occ_map.state[sl] = int(state)
    for occupied, lst in single.items():
        if lst:
            idx = np.asarray(lst, np.int64).reshape(-1, 3)
            occ_map.set_voxels(idx[occ_map.in_grid(idx)], VoxelState.OCCUPIED if occupied else VoxelState.FREE)
    return occ_map


def write_bt(occ_map: OccupancyMap, path: str | os.PathLike) -> None:
    """Write the map's labels as an OctoMap binary `.bt` file."""
    tree = to_octree(occ_map)
    p = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(p))
    if not os.path.isdir(folder) or os.path.isdir(p):
        raise CompassInputError(f"cannot write OctoMap file {p!r}: its folder does not exist or the path is a folder")
    if not tree.writeBinary(os.fsencode(p)):
        raise CompassInputError(f"could not write OctoMap file {p!r}; check the folder is writable")


#: First line of every OctoMap binary file (`OcTree::writeBinary`).
BT_MAGIC = b"# Octomap OcTree binary file"
#: Depth of OctoMap's trees: 16 levels below the root.
BT_TREE_DEPTH = 16


def read_bt(path: str | os.PathLike, config: MapConfig | None = None) -> OccupancyMap:
    """Read an OctoMap binary `.bt` file into a map on `config`'s box.

    The header (magic line, `id OcTree`, `size`, `res`, `data`) and the whole node stream
    are checked before OctoMap reads the file: a file that is not a `.bt` file, is cut off,
    has trailing bytes, nodes deeper than OctoMap's 16 levels or a node count differing from
    its header raises CompassInputError naming the file. Work and memory are bounded by the
    file's size and the map's grid.
    """
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise CompassInputError(f"OctoMap file {p!r} does not exist or is not a file")
    try:
        with open(p, "rb") as fh:
            blob = fh.read()
    except OSError as exc:
        raise CompassInputError(f"OctoMap file {p!r} cannot be read ({exc.strerror or exc})") from exc
    res, size, data_at = _bt_header(blob, p)
    status, end, nodes = _scan_bt_nodes(np.frombuffer(blob, np.uint8, offset=data_at), BT_TREE_DEPTH)
    if status == 1:
        raise CompassInputError(f"OctoMap file {p!r} is cut off: its node data ends inside the tree")
    if status == 2:
        raise CompassInputError(f"OctoMap file {p!r} is corrupt: nodes deeper than OctoMap's {BT_TREE_DEPTH} levels")
    if end != len(blob) - data_at:
        raise CompassInputError(f"OctoMap file {p!r} is corrupt: {len(blob) - data_at - end} bytes after the tree")
    if nodes != size:
        raise CompassInputError(f"OctoMap file {p!r} is corrupt: header size {size} but the data holds {nodes} nodes")
    config = config or MapConfig()
    if abs(res - config.resolution) > 1e-12:
        raise CompassInputError(
            f"OctoMap file {p!r}: res {res} m differs from the map resolution {config.resolution} m; "
            "read it with MapConfig(resolution=...) equal to the file's"
        )
    tree = octomap.OcTree(os.fsencode(p))
    return from_octree(tree, config, source=f"OctoMap file {p!r}")


def _bt_header(blob: bytes, where: str) -> tuple[float, int, int]:
    """(res [m], size, offset of the node data) of a `.bt` file's header."""
    if not blob.startswith(BT_MAGIC):
        what = "empty" if not blob else "not an OctoMap binary file"
        raise CompassInputError(f"{where!r} is {what}: the first line must be {BT_MAGIC.decode()!r}")
    pos, fields = 0, {}
    for _ in range(256):  # comment lines + id, size, res, data
        nl = blob.find(b"\n", pos, pos + 4096)
        if nl < 0:
            raise CompassInputError(f"OctoMap file {where!r} has a header without its 'data' line")
        line = blob[pos:nl].strip()
        pos = nl + 1
        if line.startswith(b"#") or not line:
            continue
        if line == b"data":
            break
        key, _, value = line.partition(b" ")
        fields[key.decode("ascii", "replace")] = value.strip().decode("ascii", "replace")
    else:
        raise CompassInputError(f"OctoMap file {where!r} has a header without its 'data' line")
    if fields.get("id") != "OcTree":
        raise CompassInputError(f"OctoMap file {where!r} holds id {fields.get('id')!r}; only 'OcTree' is supported")
    try:
        res = float(fields["res"])
        size = int(fields["size"])
    except (KeyError, ValueError) as exc:
        raise CompassInputError(f"OctoMap file {where!r}: header needs numeric 'size' and 'res' lines, got "
                                f"size {fields.get('size')!r}, res {fields.get('res')!r}") from exc
    if not (np.isfinite(res) and 1e-4 <= res <= 10.0):
        raise CompassInputError(f"OctoMap file {where!r}: res {res} m is not allowed; use 1e-4..10 m")
    if size < 1:
        raise CompassInputError(f"OctoMap file {where!r}: size {size} is not allowed; a tree has >= 1 node")
    return res, size, pos


@numba.njit(cache=True)
def _scan_bt_nodes(data, max_depth):
    """Walk OctoMap's binary node stream (2 bytes per inner node, 2 bits per child: 01 free
    leaf, 10 occupied leaf, 11 inner node whose record follows depth-first) without building
    anything. Returns (status: 0 ok, 1 cut off, 2 too deep; bytes used; nodes incl. root)."""
    n = data.shape[0]
    todo = np.zeros(max_depth + 1, np.int64)  # records still to read at each depth
    todo[0] = 1
    d = 0
    pos = 0
    nodes = 1
    while True:
        while d >= 0 and todo[d] == 0:
            d -= 1
        if d < 0:
            return 0, pos, nodes
        if pos + 2 > n:
            return 1, pos, nodes
        todo[d] -= 1
        inner = 0
        for byte in (data[pos], data[pos + 1]):
            for i in range(4):
                bits = (int(byte) >> (2 * i)) & 3
                if bits == 3:
                    inner += 1
                elif bits != 0:
                    nodes += 1
        pos += 2
        nodes += inner
        if inner > 0:
            if d + 1 >= max_depth:
                return 2, pos, nodes
            d += 1
            todo[d] = inner
