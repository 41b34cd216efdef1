"""The selection's speed-ups change nothing: the cache-friendly transform is bit-identical to
the mapping's, the exact fallback's field built on the first field's parts equals one built
from scratch, the first field equals the one composed step by step, and a selection whose
candidates all lack IK gives the same verdict without the fallback field."""
import math

import numpy as np

from compass_manip.grasp.checks import GraspChecks, exact_boxes
from compass_manip.grasp.carve import grasp_unsafe_box, target_carve
from compass_manip.grasp.field import (checked_field, coarse_distances, fine_map_range, fine_unsafe_labels,
                                       local_fine_map, upsample_mask)
from compass_manip.grasp.select import GraspFailure, GraspSelectConfig, Rejection, select_grasp
from compass_manip.mapping.distance import DistanceField
from compass_manip.mapping.occupancy import VoxelState
from compass_manip.robot.ik import PandaIK
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model

from test_grasp_candidates import box_surface, model
from test_grasp_select import CENTRE, HALF, shelf_world


def test_coarse_distances_equal_the_maps_field():
    unsafe = np.random.default_rng(3).random((21, 19, 17)) < 0.01
    assert np.array_equal(coarse_distances(unsafe, 0.01), DistanceField.from_unsafe(unsafe, np.zeros(3), 0.01).distances)


def _fine_map(occ, points):
    fine = local_fine_map(occ, points.min(0) - 0.1, points.max(0) + 0.1, 2)
    fine.state[...] = VoxelState.UNKNOWN
    lo = np.asarray(fine.grid_min)
    i = fine.world_to_voxel(np.array([CENTRE - HALF - 0.03, CENTRE + HALF + 0.03]))  # seen around the box
    fine.state[i[0, 0]:i[1, 0], i[0, 1]:i[1, 1], i[0, 2]:i[1, 2]] = VoxelState.FREE
    j = fine.world_to_voxel(np.array([CENTRE - HALF, CENTRE + HALF]))
    fine.state[j[0, 0]:j[1, 0], j[0, 1]:j[1, 1], j[0, 2]:j[1, 2]] = VoxelState.OCCUPIED
    assert np.all(lo < points.min(0))
    return fine


def test_fallback_field_on_reused_parts_equals_a_fresh_one_and_the_first_equals_the_reference():
    occ, task, target = shelf_world(board_above_z=0.74)
    occ.state[60:, :, 80:] = VoxelState.UNKNOWN  # some unseen space, so the labels matter
    spheres = panda_sphere_model()
    ik, config, q = PandaIK(spheres.kinematics), GraspSelectConfig(), np.asarray(Q_HOME, dtype=np.float64)
    cur = spheres.sphere_centers(q[None])[0]
    safe = (cur, spheres.radii + config.robot_clearance)
    fine = _fine_map(occ, target.points)
    first = GraspChecks(occ, target, spheres, ik, config, safe, None, q, fine_map=fine)
    reused = GraspChecks(occ, target, spheres, ik, config, safe, None, q, fine_map=fine, exact_everywhere=True,
                         reuse=first)
    fresh = GraspChecks(occ, target, spheres, ik, config, safe, None, q, fine_map=fine, exact_everywhere=True)
    assert np.array_equal(reused.fine.distances, fresh.fine.distances)
    assert not np.array_equal(first.fine.distances, fresh.fine.distances)
    # the first field, composed step by step as before the parts were kept
    a, b = first._parts["a"], first._parts["b"]
    unsafe, robot, _ = grasp_unsafe_box(occ, target, config.clearance, a, b, safe, None)
    ia, ib, base = exact_boxes(occ, a, b, target, spheres, cur, 0.2, 0.05)
    fa, fb, u = fine_map_range(occ, fine)
    fu = upsample_mask(unsafe[ia[0]:ib[0], ia[1]:ib[1], ia[2]:ib[2]], u)
    lo, hi = np.maximum(fa, a + ia), np.minimum(fb, a + ib)
    sl = tuple(slice(int(lo[k] - a[k]), int(hi[k] - a[k])) for k in range(3))
    fsl = tuple(slice(int(u * (lo[k] - fa[k])), int(u * (hi[k] - fa[k]))) for k in range(3))
    dst = tuple(slice(int(u * (lo[k] - a[k] - ia[k])), int(u * (hi[k] - a[k] - ia[k]))) for k in range(3))
    carve = target_carve(fine, target, config.clearance, math.sqrt(3.0) * fine.resolution)[fsl]
    fu[dst] = fine_unsafe_labels(fine.state[fsl], unsafe[sl], robot[sl], carve, u)
    ref = checked_field(unsafe, occ.grid_min + a * occ.resolution, occ.resolution, ia, ib, u, fu, safe, (base,))
    assert np.array_equal(first.fine.distances, ref.distances)


def test_no_ik_anywhere_gives_the_same_verdict_without_the_fallback_field():
    occ, task, _ = shelf_world(board_above_z=0.74)
    P, N = box_surface(HALF, np.array([0.85, 0.0, 1.15]))  # above the back wall, 1.18 m from the shoulder
    target = model(P, N)
    occ.set_box(P.min(0), P.max(0), VoxelState.OCCUPIED)
    spheres = panda_sphere_model()
    out = {}
    for fallback in (True, False):
        cfg = GraspSelectConfig(max_approach_angle=math.pi, exact_fallback=fallback)
        out[fallback] = select_grasp(target, occ, task, Q_HOME, spheres, cfg, np.random.default_rng(5))
    on, off = out[True], out[False]
    assert on.failure == off.failure == GraspFailure.NO_IK
    assert on.rejections == off.rejections and on.rejections.get(Rejection.NO_IK, 0) > 0
    assert "exact_field_s" not in on.stage_times


def _ordered_reference(S, q_ref, tol):
    """The IK dedupe as it was: a Python loop over the kept solutions."""
    order = np.argsort(np.linalg.norm(S - q_ref, axis=1), kind="stable")
    keep = []
    for i in order:
        if all(np.max(np.abs(S[i] - S[k])) > tol for k in keep):
            keep.append(int(i))
    return keep


def test_ik_sweep_cache_and_dedupe_give_the_same_solutions():
    from compass_manip.robot import ik as ikmod
    spheres = panda_sphere_model()
    ik = PandaIK(spheres.kinematics)
    q0 = np.asarray(Q_HOME, dtype=np.float64)
    T = spheres.kinematics.T_world_tcp(q0 + np.array([0.3, 0.2, -0.1, 0.3, 0.2, -0.2, 0.4]))
    plain = ik.solve(T, "tcp", q0, 24, None)
    cache: dict = {}
    first = ik.solve(T, "tcp", q0, 24, None, cache=cache)
    again = ik.solve(T, "tcp", q0, 24, None, cache=cache)
    assert len(cache) == 2 and len(plain.solutions) > 1  # the sweep and its q7 grid part
    for r in (first, again):
        assert np.array_equal(r.solutions, plain.solutions) and np.array_equal(r.pos_err, plain.pos_err)

    class Half:  # a validity filter applied after the cached sweep, as without the cache
        def are_valid(self, Q):
            return Q[:, 0] > np.median(Q[:, 0])

    assert np.array_equal(ik.solve(T, "tcp", q0, 24, Half(), cache=cache).solutions,
                          ik.solve(T, "tcp", q0, 24, Half()).solutions)
    rng = np.random.default_rng(2)
    S = np.repeat(rng.uniform(-1, 1, (12, 7)), 3, axis=0) + rng.normal(0, 1e-4, (36, 7))  # near-duplicates
    q = rng.uniform(-1, 1, 7)
    got = ikmod._ordered(S, np.zeros(36), np.zeros(36), np.eye(4)[None].repeat(36, 0), q, 1e-3, "tcp", None)
    assert np.array_equal(got.solutions, S[_ordered_reference(S, q, 1e-3)]) and len(got.solutions) == 12
