"""The grasp's checked field, the robot's way mask and the fine local map (grasp/field.py,
grasp/robot_space.py, mapping.distance's sphere rasteriser)."""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.field import checked_field, local_fine_map, upsample_mask
from compass_manip.grasp.robot_space import RobotSpaceMask
from compass_manip.mapping.distance import DistanceField, _clear_spheres
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.spheres import panda_sphere_model


def brute_force_clear(shape, grid_min, res, c, r):
    """Every voxel centre tested against every sphere (the one-by-one rasterisation)."""
    idx = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), -1).reshape(-1, 3)
    p = grid_min + (idx + 0.5) * res
    inside = np.zeros(len(p), bool)
    for cc, rr in zip(c, r):
        d = p - cc
        inside |= d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2] <= rr * rr
    return ~inside.reshape(shape)


def test_sphere_rasteriser_equals_brute_force():
    rng = np.random.default_rng(3)
    for _ in range(20):
        c = rng.uniform(-0.05, 0.35, (25, 3))
        r = rng.uniform(0.0, 0.09, 25)
        c[:5] = np.round(c[:5] / 0.005) * 0.005  # centres and radii on voxel boundaries
        r[:5] = 0.005 * rng.integers(0, 12, 5)
        m = np.ones((30, 26, 28), bool)
        m[rng.random(m.shape) < 0.3] = False  # some voxels already safe
        want = m & brute_force_clear(m.shape, np.zeros(3), 0.01, c, r)
        _clear_spheres(m, np.zeros(3), 0.01, c, r)
        assert np.array_equal(m, want)


def test_sphere_rasteriser_on_a_corner_of_a_large_grid_equals_brute_force():
    """Only the blocks under the spheres' common box are counted: spheres in one corner, at
    the grid's far faces (a shape that is no multiple of the 4-voxel block) and wholly
    outside it clear exactly what the brute force clears, and nothing else."""
    rng = np.random.default_rng(7)
    shape = (41, 38, 35)
    for trial in range(12):
        n = int(rng.integers(1, 6))
        corner = np.array([0.0, 0.0, 0.0]) if trial % 2 else np.array(shape) * 0.01
        c = corner + rng.uniform(-0.06, 0.06, (n, 3))
        r = rng.uniform(0.0, 0.05, n)
        if trial % 3 == 0:
            c = np.vstack([c, [[-0.5, 0.2, 0.2], [0.2, 0.2, 1.0]]])  # wholly outside the grid
            r = np.r_[r, 0.1, 0.1]
        m = np.ones(shape, bool)
        m[rng.random(shape) < 0.2] = False
        want = m & brute_force_clear(shape, np.zeros(3), 0.01, c, r)
        _clear_spheres(m, np.zeros(3), 0.01, c, r)
        assert np.array_equal(m, want)
    m = np.ones(shape, bool)
    _clear_spheres(m, np.zeros(3), 0.01, np.array([[-1.0, -1.0, -1.0]]), np.array([0.2]))
    _clear_spheres(m, np.zeros(3), 0.01, np.zeros((0, 3)), np.zeros(0))
    assert m.all()


def test_sphere_rasteriser_whole_block_skip_and_fill_equal_brute_force():
    """Spheres of 2-30 voxels' radius (blocks of 4^3 voxels skipped or cleared whole), an
    odd grid origin and shape, centres beyond the grid's faces and radii exactly at a voxel
    centre's distance (the test's <= decides): the same voxels as the brute force."""
    rng = np.random.default_rng(21)
    shape, gm, res = (37, 42, 29), np.array([-0.6131, 0.2071, -0.0499]), 0.01
    for trial in range(10):
        n = int(rng.integers(2, 8))
        c = gm + rng.uniform(-0.08, 1.0, (n, 3)) * np.array(shape) * res
        r = rng.uniform(0.02, 0.3, n)
        v = gm + (rng.integers(0, 20, 3) + 0.5) * res  # a voxel centre exactly on the surface
        d = v - c[0]
        r[0] = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        m = np.ones(shape, bool)
        m[rng.random(shape) < 0.1] = False
        want = m & brute_force_clear(shape, gm, res, c, r)
        _clear_spheres(m, gm, res, c, r)
        assert np.array_equal(m, want), trial


def test_robot_space_mask_incremental_equals_one_shot():
    from compass_manip.robot.model import Q_MAX, Q_MIN, RobotConfig

    spheres = panda_sphere_model()
    occ = OccupancyMap(MapConfig(box_min=(-0.3, -0.4, -0.05), box_max=(0.7, 0.4, 1.0), resolution=0.02))
    rng = np.random.default_rng(0)
    home = np.asarray(RobotConfig().q_home)
    Q = np.vstack([np.clip(home + rng.normal(0, 0.2, 7), Q_MIN, Q_MAX) for _ in range(12)] + [home, home])
    way = RobotSpaceMask(occ, spheres, 0.02)
    for part in (Q[:3], Q[3:9], Q[9:]):  # added as the robot moves
        way.add(part)
    assert way.n_configs == 13  # the repeated home posture counted once
    c = spheres.sphere_centers(Q).reshape(-1, 3)
    r = np.tile(spheres.radii + 0.02, len(Q))
    want = ~brute_force_clear(occ.shape, occ.grid_min, occ.resolution, c, r)
    assert want.sum() > 100
    assert np.array_equal(way.mask, want)


def test_checked_field_is_sound_and_exact_inside():
    rng = np.random.default_rng(1)
    unsafe = rng.random((24, 22, 20)) < 0.04
    res, u = 0.01, 2
    a, b = np.array([6, 6, 5]), np.array([16, 15, 14])
    f = checked_field(unsafe, np.zeros(3), res, a, b, u)
    exact = DistanceField.from_unsafe(upsample_mask(unsafe, u), np.zeros(3), res / u).distances
    assert f.distances.shape == exact.shape
    # sound: the checker's bound (value at the nearest fine centre - offset - half a fine
    # diagonal) never exceeds the true distance from a point to the unsafe cubes
    p = rng.uniform(0.0, [0.24, 0.22, 0.20], (3000, 3))
    i = np.clip(np.floor(p / (res / u)).astype(int), 0, np.array(f.distances.shape) - 1)
    centre = (i + 0.5) * res / u
    bound = f.distances[i[:, 0], i[:, 1], i[:, 2]] - np.linalg.norm(p - centre, axis=1) - 0.5 * math.sqrt(3) * res / u
    lo = np.argwhere(unsafe) * res
    gap = np.maximum(np.maximum(lo[None] - p[:, None], p[:, None] - (lo[None] + res)), 0.0)
    true = np.linalg.norm(gap, axis=2).min(axis=1)
    assert np.all(bound <= true + 1e-6)
    # deep inside the inner box the composite field is the exact fine field wherever its
    # nearest unsafe voxel is inside the box too
    inner = f.distances[2 * a[0] + 4:2 * b[0] - 4, 2 * a[1] + 4:2 * b[1] - 4, 2 * a[2] + 4:2 * b[2] - 4]
    ex = exact[2 * a[0] + 4:2 * b[0] - 4, 2 * a[1] + 4:2 * b[1] - 4, 2 * a[2] + 4:2 * b[2] - 4]
    small = ex <= 0.015
    assert small.sum() > 50 and np.allclose(inner[small], ex[small])
    # outside: the map-grid bound carried over (D - |c - c_map| - h_map + h_fine)
    coarse = DistanceField.from_unsafe(unsafe, np.zeros(3), res).distances
    v = coarse[0, 0, 0] - 0.25 * res * math.sqrt(3) - 0.5 * math.sqrt(3) * res + 0.5 * math.sqrt(3) * res / u
    assert f.distances[0, 0, 0] == pytest.approx(max(v, 0.0), abs=1e-6)
    # the robot's own spheres (their map voxels made safe) raise the field around them, soundly
    c, R = np.array([[0.05, 0.06, 0.05], [0.2, 0.15, 0.12]]), np.array([0.04, 0.05])
    cleared = unsafe.copy()
    _clear_spheres(cleared, np.zeros(3), res, c, R)
    f2 = checked_field(cleared, np.zeros(3), res, a, b, u, safe_spheres=(c, R))
    f3 = checked_field(cleared, np.zeros(3), res, a, b, u)
    assert np.all(f2.distances >= f3.distances) and np.any(f2.distances > f3.distances + 1e-3)
    bound = f2.distances[i[:, 0], i[:, 1], i[:, 2]] - np.linalg.norm(p - centre, axis=1) - 0.5 * math.sqrt(3) * res / u
    lo2 = np.argwhere(cleared) * res
    gap = np.maximum(np.maximum(lo2[None] - p[:, None], p[:, None] - (lo2[None] + res)), 0.0)
    assert np.all(bound <= np.linalg.norm(gap, axis=2).min(axis=1) + 1e-6)
    with pytest.raises(CompassInputError, match="fine_unsafe"):
        checked_field(unsafe, np.zeros(3), res, a, b, u, np.zeros((3, 3, 3), bool))


def test_composite_field_equals_its_formula_cell_by_cell():
    """`field._compose` (row by row of the fine grid) against the module doc's formula in
    numpy, bit for bit: v = max(D(C) - h_map + h_fine - |c - c_C|, 0) outside the inner
    box, min(d_in, max(b + h_fine, v)) inside it (an inner box at the grid's faces too)."""
    from compass_manip.grasp.field import _compose, coarse_distances
    from compass_manip.mapping.distance import _distances
    rng = np.random.default_rng(4)
    res = 0.01
    for shape, a, b, u in [((13, 11, 9), (3, 2, 1), (9, 8, 7), 2), ((10, 9, 12), (0, 4, 6), (10, 9, 12), 3),
                           ((8, 8, 8), (2, 2, 2), (2, 5, 5), 2)]:
        a, b = np.array(a), np.array(b)
        coarse = coarse_distances(rng.random(shape) < 0.05, res)
        fu = rng.random(tuple(u * (b - a))) < 0.03
        d_in = _distances(fu, res / u) if fu.any() else np.full(fu.shape, np.inf, np.float32)
        got = _compose(coarse, d_in, a * u, u, res)
        fres, h_map, h_fine = res / u, 0.5 * math.sqrt(3.0) * res, 0.5 * math.sqrt(3.0) * res / u
        off = (((np.arange(u) + 0.5) / u - 0.5) * res) ** 2
        rad = np.sqrt(off[:, None, None] + off[None, :, None] + off[None, None, :])
        base = upsample_mask(coarse.astype(np.float64), u) - h_map + h_fine
        v = np.maximum(base - np.tile(rad, shape), 0.0)
        sl = tuple(slice(u * a[k], u * b[k]) for k in range(3))
        li, lj, lk = np.meshgrid(*[np.arange(n) for n in d_in.shape], indexing="ij")
        bnd = np.minimum.reduce([li + 0.5, d_in.shape[0] - li - 0.5, lj + 0.5, d_in.shape[1] - lj - 0.5,
                                 lk + 0.5, d_in.shape[2] - lk - 0.5]) * fres
        v[sl] = np.minimum(d_in.astype(np.float64), np.maximum(bnd + h_fine, v[sl]))
        assert np.array_equal(got.view(np.int32), v.astype(np.float32).view(np.int32))


def test_fine_map_integration_hand_computed():
    """One depth pixel straight down the camera's axis onto a plane 0.3 m away: at 5 mm the
    fine map marks the voxel holding the hit occupied and the voxels the ray crossed free,
    aligned with the 1 cm map's voxels."""
    occ = OccupancyMap(MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.4, 0.4, 0.4), resolution=0.01,
                                 ray_grouping=0))
    fine = local_fine_map(occ, np.array([0.1, 0.1, 0.0]), np.array([0.3, 0.3, 0.4]), 2)
    assert fine.resolution == pytest.approx(0.005) and np.allclose(fine.grid_min, [0.1, 0.1, 0.0])
    assert fine.shape == (42, 42, 80)  # the box snapped outwards to whole map voxels
    depth = np.full((3, 3), np.nan)
    depth[1, 1] = 0.3
    K = np.array([[10.0, 0, 1.0], [0, 10.0, 1.0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # looking down -z
    T[:3, 3] = [0.2025, 0.2025, 0.3925]
    fine.integrate(depth, K, T, 1.0)
    hit = fine.world_to_voxel(np.array([[0.2025, 0.2025, 0.0925]]))[0]
    assert tuple(hit) == (20, 20, 18)
    assert fine.state[20, 20, 18] == VoxelState.OCCUPIED
    assert np.all(fine.state[20, 20, 19:78] == VoxelState.FREE)  # the ray from the camera down to the hit
    assert fine.state[20, 20, 17] == VoxelState.UNKNOWN and fine.state[21, 20, 30] == VoxelState.UNKNOWN
    with pytest.raises(CompassInputError, match="upsample"):
        local_fine_map(occ, np.zeros(3), np.ones(3), 7)


def test_near_body_unknown_is_the_swept_spheres_unknown_voxels_and_cached():
    """`near_body_unknown` (cached swept mask) equals its definition: the unknown voxels
    whose centres lie inside the links 0-4 spheres swept near home (brute force on an 8 cm
    grid), for two maps of the same grid with different states."""
    from compass_manip.robot.model import RobotConfig
    from compass_manip.grasp.robot_space import near_body_spheres, near_body_swept
    from compass_manip.sim.grasp_only import near_body_unknown

    spheres = panda_sphere_model()
    home = np.asarray(RobotConfig().q_home)
    occ = OccupancyMap(MapConfig(box_min=(-0.64, -0.72, -0.08), box_max=(0.96, 0.72, 1.2), resolution=0.08))
    c, r = near_body_spheres(spheres, home)
    assert len(r) == 675 * np.isin(spheres.body_index, range(5)).sum()  # links 0-4 at 9 x 5 x 3 x 5 postures
    cr = np.unique(np.c_[c, r], axis=0)  # link 0 repeats in every posture, link 1 in most
    idx = np.stack(np.meshgrid(*[np.arange(n) for n in occ.shape], indexing="ij"), -1).reshape(-1, 3)
    p = occ.grid_min + (idx + 0.5) * occ.resolution
    inside = np.zeros(len(p), bool)
    for k in range(0, len(cr), 200):  # every voxel centre against every sphere, 200 at a time
        d = p[:, None, :] - cr[None, k:k + 200, :3]
        inside |= np.any(np.einsum("nsk,nsk->ns", d, d) <= cr[None, k:k + 200, 3] ** 2, axis=1)
    inside = inside.reshape(occ.shape)
    rng = np.random.default_rng(2)
    for _ in range(2):
        occ.state[...] = rng.choice([VoxelState.UNKNOWN, VoxelState.FREE, VoxelState.OCCUPIED], occ.shape)
        got = near_body_unknown(occ, spheres, home)
        assert np.array_equal(got, inside & (occ.state == VoxelState.UNKNOWN)) and got.sum() > 50
    assert near_body_swept(occ, spheres, home) is near_body_swept(occ, spheres, home)
    assert not near_body_swept(occ, spheres, home).flags.writeable


def test_voxels_in_spheres_equals_argwhere_of_the_brute_force():
    from compass_manip.mapping.distance import voxels_in_spheres

    rng = np.random.default_rng(11)
    shape, gm, res = (37, 30, 33), np.array([-0.1, 0.05, -0.02]), 0.01
    for trial in range(10):
        select = rng.random(shape) < 0.5
        n = int(rng.integers(1, 8))
        c = gm + rng.uniform(-0.05, 0.4, (n, 3))
        r = rng.uniform(0.0, 0.07, n)
        want = np.argwhere(select & ~brute_force_clear(shape, gm, res, c, r))
        got = voxels_in_spheres(select, gm, res, c, r)
        assert got.dtype == np.int64 and np.array_equal(got, want)
    assert voxels_in_spheres(select, gm, res, np.zeros((0, 3)), np.zeros(0)).shape == (0, 3)
    assert voxels_in_spheres(select, gm, res, np.array([[5.0, 5.0, 5.0]]), np.array([0.1])).shape == (0, 3)


def test_near_body_yaw_narrows_the_assumption_to_the_arm_facing_home():
    """The near-body volume with joint 1 within +-0.6 rad of home's lies (up to its finer joint-1
    sampling) inside the default +-1.2 rad one and is much smaller; a voxel beside the base at elbow height (where level-3 lateral base
    walls stand) is in the wide volume only; the default yaw gives the former mask exactly;
    bad yaw values are refused with the value named."""
    from compass_manip.robot.model import RobotConfig
    from compass_manip.grasp.robot_space import near_body_spheres, near_body_swept
    from compass_manip.trial.config import GraspTrialConfig

    spheres = panda_sphere_model()
    home = np.asarray(RobotConfig().q_home)
    occ = OccupancyMap(MapConfig(box_min=(-0.64, -0.72, -0.08), box_max=(0.96, 0.72, 1.2), resolution=0.04))
    wide, narrow = near_body_swept(occ, spheres, home), near_body_swept(occ, spheres, home, 0.6)
    assert np.array_equal(near_body_swept(occ, spheres, home, 1.2), wide)
    assert np.count_nonzero(narrow & ~wide) < 0.02 * narrow.sum() and narrow.sum() < 0.8 * wide.sum()
    side = occ.world_to_voxel(np.array([[0.02, -0.26, 0.56]]))[0]
    assert wide[tuple(side)] and not narrow[tuple(side)]
    front = occ.world_to_voxel(np.array([[0.30, 0.0, 0.60]]))[0]
    assert narrow[tuple(front)]
    for bad in (-0.1, 3.5, True, "1"):
        with pytest.raises(CompassInputError, match="near_body_yaw"):
            GraspTrialConfig(near_body_yaw=bad)
    with pytest.raises(CompassInputError, match="yaw"):
        near_body_spheres(spheres, home, 3.5)


def test_trial_defaults_scan_and_take_only_the_narrow_near_body_volume_as_free():
    """The trial's grasp stage by default runs the near-field scan and takes as free only the
    near-body volume of joint 1 within +-0.6 rad of home's (measured: as many grasps as the
    former defaults and none of their collision trials, docs/grasping_log.md): on an all-unknown
    map a voxel beside the base at elbow height, where level-3 lateral walls stand, is not
    assumed free, one ahead of the base is; the former 1.2 rad assumed both."""
    from dataclasses import replace
    from compass_manip.robot.model import RobotConfig
    from compass_manip.trial.config import GraspTrialConfig
    from compass_manip.trial.grasp_stage import assumed_unknown_free

    config = GraspTrialConfig()
    assert config.scan.max_views > 0 and config.near_body_free
    spheres = panda_sphere_model()
    home = np.asarray(RobotConfig().q_home)
    occ = OccupancyMap(MapConfig(box_min=(-0.64, -0.72, -0.08), box_max=(0.96, 0.72, 1.2), resolution=0.04))
    side = tuple(occ.world_to_voxel(np.array([[0.02, -0.26, 0.56]]))[0])
    front = tuple(occ.world_to_voxel(np.array([[0.30, 0.0, 0.60]]))[0])
    now = assumed_unknown_free(occ, config, spheres, home, None, None)
    former = assumed_unknown_free(occ, replace(config, near_body_yaw=1.2), spheres, home, None, None)
    assert now[front] and not now[side]
    assert former[front] and former[side]
