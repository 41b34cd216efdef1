"""`mark_spheres` (the swept space in an exploration method's map) tests only the run of
voxels each column's chord can hold: the same voxels as testing every voxel of each sphere's
box, also for centres on voxel corners and radii that put voxel centres on the sphere."""
import numpy as np

from compass_manip.exploration.world_model import mark_spheres


def _every_voxel_of_the_box(mask, grid_min, res, centers, radii):
    nx, ny, nz = mask.shape
    for (c0, c1, c2), r in zip(centers, radii):
        lo = np.floor((np.array([c0, c1, c2]) - r - grid_min) / res).astype(int)
        hi = np.floor((np.array([c0, c1, c2]) + r - grid_min) / res).astype(int)
        i = np.arange(max(0, lo[0]), min(nx - 1, hi[0]) + 1)
        j = np.arange(max(0, lo[1]), min(ny - 1, hi[1]) + 1)
        k = np.arange(max(0, lo[2]), min(nz - 1, hi[2]) + 1)
        x = (grid_min[0] + (i + 0.5) * res - c0)[:, None, None]
        y = (grid_min[1] + (j + 0.5) * res - c1)[None, :, None]
        z = (grid_min[2] + (k + 0.5) * res - c2)[None, None, :]
        inside = x * x + y * y + z * z <= r * r
        if inside.size:
            mask[np.ix_(i, j, k)] |= inside


def test_mark_spheres_equals_the_whole_box_test():
    rng = np.random.default_rng(0)
    grid_min, res = np.array([-0.3, -0.5, 0.1]), 0.02
    for case in range(24):
        centers = rng.uniform(-0.4, 0.7, (30, 3))
        radii = rng.uniform(0.0, 0.2, 30)
        if case % 3 == 0:  # centres on voxel corners: chord ends on voxel boundaries
            centers = grid_min + np.round((centers - grid_min) / res) * res
        if case % 3 == 1:  # radii of whole and half voxels: voxel centres on the sphere
            radii = np.round(radii / res) * res * 0.5
        fast = np.zeros((30, 40, 25), bool)
        slow = fast.copy()
        mark_spheres(fast, grid_min, res, centers, radii)
        _every_voxel_of_the_box(slow, grid_min, res, centers, radii)
        assert np.array_equal(fast, slow), case
        assert fast.any()
