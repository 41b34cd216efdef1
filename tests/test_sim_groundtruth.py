"""Ground-truth voxelisation against MuJoCo's own geometry."""
import mujoco
import numpy as np

from compass_manip.sim.certify import regenerate
from compass_manip.sim.groundtruth import occupancy_grid, voxel_centres
from compass_manip.sim.world import World


def test_voxelisation_matches_mujoco_point_queries():
    scene = regenerate((0, 4, 0, 0))
    w = World(scene)
    origin, res, shape = np.array([-0.3, -0.6, 0.0]), 0.02, (70, 60, 60)
    occ = occupancy_grid(scene, origin, shape, res, floor=False)
    pts = voxel_centres(origin, shape, res).reshape(-1, 3)
    rng = np.random.default_rng(0)
    idx = np.concatenate([rng.choice(np.flatnonzero(occ.ravel()), 300), rng.choice(len(pts), 300)])
    scene_geoms = [g for g in range(w.model.ngeom) if not w.is_robot_geom[g] and g != w.model.geom("floor").id]
    for i in idx:
        # a point is inside a geom if a tiny sphere there penetrates it: use mj_geomDistance
        inside = False
        for g in scene_geoms:
            probe = _probe_distance(w, g, pts[i])
            if probe < 0:
                inside = True
                break
        assert inside == occ.ravel()[i], (pts[i], inside)
    w.close()


def _probe_distance(w, g, p):
    """Signed distance-like test: negative when point p is strictly inside geom g."""
    m, d = w.model, w.data
    R = d.geom_xmat[g].reshape(3, 3)
    local = R.T @ (p - d.geom_xpos[g])
    t, s = m.geom_type[g], m.geom_size[g]
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        return float(np.max(np.abs(local) - s))
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return float(max(np.hypot(local[0], local[1]) - s[0], abs(local[2]) - s[1]))
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return float(np.linalg.norm(local) - s[0])
    return 1.0
