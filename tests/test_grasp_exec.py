"""Grasp-and-lift in physics: a free-standing box through the whole grasp-only harness, and a
box on a shelf under a board grasped from the side."""
import numpy as np
import pytest

from compass_manip.grasp.select import GraspSelectConfig, select_grasp
from compass_manip.grasp.target import TargetModel, principal_axes
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.grasp_exec import ExecFailure, execute_grasp
from compass_manip.sim.grasp_only import GraspOnlyConfig, run_grasp_only
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec
from compass_manip.sim.world import World

from test_grasp_candidates import box_surface

RED = (0.9, 0.05, 0.05, 1.0)


def test_free_standing_box_is_lifted_by_the_grasp_only_harness():
    cab = CabinetSpec((0.45, -0.3, 0.30), (0.80, 0.3, 0.80))  # an empty, open cabinet
    target = Primitive("target", "box", (0.02, 0.02, 0.06), (0.60, 0.0, 0.36), 0.2, RED, True, 0.08)
    scene = SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target)
    r = run_grasp_only(scene, GraspOnlyConfig(), seed=0)
    assert r.q_view is not None and r.n_target_points > 100
    assert r.selection.failure is None, r.selection.rejections
    o = r.outcome
    assert o.failure is None, (o.failure, o.collisions)
    assert o.success and o.held and not o.collisions
    assert o.lift_height > 0.08 and o.hold_height > 0.07  # commanded 10 cm, held for 2 s
    assert 0.03 < o.finger_width < 0.05  # closed on the 4 cm box
    assert 0.0 < r.selection.gpq <= r.selection.score


def known_map(scene: SceneSpec) -> OccupancyMap:
    """GROUND-TRUTH MAP (test fixture): every primitive's box occupied, the rest free."""
    occ = OccupancyMap(MapConfig())
    occ.set_box(occ.grid_min, occ.grid_max, VoxelState.FREE)
    occ.set_box(occ.grid_min, np.r_[occ.grid_max[:2], scene.floor_z], VoxelState.OCCUPIED)
    for p in scene.all_primitives():
        lo, hi = p.aabb()
        occ.set_box(lo, hi, VoxelState.OCCUPIED)
    return occ


def test_box_on_a_shelf_under_a_board_is_grasped_from_the_side_in_physics():
    cab = CabinetSpec((0.45, -0.3, 0.46), (0.85, 0.3, 0.95), shelves=(0.76,))  # board 0.74-0.76 m
    centre, half = np.array([0.55, 0.0, 0.52]), np.array([0.02, 0.02, 0.06])
    target = Primitive("target", "box", tuple(half), tuple(centre), 0.0, RED, True, 0.08)
    scene = SceneSpec(level=1, index=0, seed=(0,), cabinet=cab, target=target)
    P, N = box_surface(half, centre)
    axes, ext = principal_axes(P)
    model = TargetModel(P, N, np.ones(len(P), bool), centre, axes, ext, np.array([1.0, 0.0, 0.0]))
    sel = select_grasp(model, known_map(scene), scene.task(), Q_HOME, panda_sphere_model(), GraspSelectConfig(),
                       np.random.default_rng(0))
    assert sel.failure is None, sel.rejections
    a = sel.T_world_tcp[:3, 2]
    assert a[0] > 0.5 and a[2] > -0.75  # through the opening, not down through the board
    world = World(scene)
    try:
        o = execute_grasp(world, sel, Q_HOME)
    finally:
        world.close()
    assert o.failure is None, (o.failure, o.collisions, o.lift_height)
    assert o.lift_height > 0.08 and o.held and not o.collisions


def test_no_selection_is_reported_not_executed():
    scene = SceneSpec(level=1, index=0, seed=(0,), cabinet=CabinetSpec((0.45, -0.3, 0.3), (0.8, 0.3, 0.8)),
                      target=Primitive("target", "box", (0.02, 0.02, 0.06), (0.6, 0.0, 0.36), 0.0, RED, True))
    world = World(scene)
    try:
        assert execute_grasp(world, None).failure is ExecFailure.NOT_SELECTED
    finally:
        world.close()
