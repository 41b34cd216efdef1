"""Named kernel data of the validity checker: what the numba kernels read, by name.

`ValidityChecker.kernel_args()` returns a `KernelArgs`; the kernels in `validity`,
`edge_bounds`, `tree` and `rrt_kernels` take its fields. NamedTuples of arrays compile in
numba like plain tuples, so naming the fields costs nothing at run time.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class RobotSpheres(NamedTuple):
    """The robot's collision spheres, packed for the kernels.

    body_index (S,) link of each sphere; centers (S, 3) [m] in its link frame; radii (S,) [m];
    start (L+1,) first sphere of each link (spheres sorted by link); link_c (L, 3) [m] /
    link_r (L,) [m] bounding sphere of each link (-1: no spheres); env_link (L,) links tested
    against the environment (those moving with the arm); self-collision pairs grouped by
    link pair: link_pairs (P, 2), pair_run (P+1,) first run of each link pair, run_u (R,)
    the first sphere of each run, run_start (R+1,) first partner of each run, partner (N,)
    the second spheres; per link, its spheres split into clusters with bounding spheres
    (link frame): clu_start (L+1,) first cluster of each link, clu_c (K, 3) [m], clu_r (K,)
    [m], mem_start (K+1,) first member of each cluster, members (S,) sphere indices.

    Flat on purpose: numba's parallel loops cannot take a tuple nested in a tuple argument.
    """

    body_index: np.ndarray
    centers: np.ndarray
    radii: np.ndarray
    start: np.ndarray
    link_c: np.ndarray
    link_r: np.ndarray
    env_link: np.ndarray
    link_pairs: np.ndarray
    pair_run: np.ndarray
    run_u: np.ndarray
    run_start: np.ndarray
    partner: np.ndarray
    clu_start: np.ndarray
    clu_c: np.ndarray
    clu_r: np.ndarray
    mem_start: np.ndarray
    members: np.ndarray


class GridData(NamedTuple):
    """The map's distance grid: dist (X, Y, Z) float32 [m] to unsafe space, origin (3,) [m]
    (centre of voxel 0), resolution [m], active (False: no map), outside_free (space outside
    the grid counts as free)."""

    dist: np.ndarray
    origin: np.ndarray
    resolution: float
    active: bool
    outside_free: bool


#: Indices into `KernelArgs.params`.
P_MARGIN, P_SELF_MARGIN, P_HALF_DIAG = 0, 1, 2


class KernelArgs(NamedTuple):
    """Everything the validity kernels need about one checker: kin (robot kinematics,
    `robot.kinematics.KinematicsData`), robot (`RobotSpheres`), grid (`GridData`), prims
    (known primitives, `PrimitiveSet.arrays()`), limits (q_min (7,), q_max (7,)) [rad],
    params (4,) [margin, self_margin, half voxel diagonal, 0] [m]."""

    kin: tuple
    robot: RobotSpheres
    grid: GridData
    prims: tuple
    limits: tuple
    params: np.ndarray
