"""Constrained selection (Eq. 6) on a fully known map: a box on a shelf board with another
board above it. Top-down approaches go through the upper board and are rejected with their
reason; the selection comes in from the side, through the opening."""
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.candidates import GraspCandidates, antipodal_candidates
from compass_manip.grasp.select import (GraspFailure, GraspSelectConfig, Rejection, approach_angles,
                                        desired_approach, gpq, select_grasp)
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.task import ConfinedSpace, TargetQuery, Task

from test_grasp_candidates import box_surface, model

CENTRE = np.array([0.55, 0.0, 0.52])
HALF = np.array([0.02, 0.02, 0.06])


def shelf_world(board_above_z: float):
    occ = OccupancyMap(MapConfig())
    occ.set_box(occ.grid_min, occ.grid_max, VoxelState.FREE)
    occ.set_box(occ.grid_min, np.r_[occ.grid_max[:2], 0.0], VoxelState.OCCUPIED)  # floor
    occ.set_box((0.45, -0.3, 0.44), (0.85, 0.3, 0.46), VoxelState.OCCUPIED)  # shelf under the box
    occ.set_box((0.45, -0.3, board_above_z), (0.85, 0.3, board_above_z + 0.02), VoxelState.OCCUPIED)
    occ.set_box((0.85, -0.3, 0.44), (0.87, 0.3, 0.9), VoxelState.OCCUPIED)  # back wall
    occ.set_box(CENTRE - HALF, CENTRE + HALF, VoxelState.OCCUPIED)
    space = ConfinedSpace((0.45, -0.3, 0.46), (0.85, 0.3, 0.9), (0.45, -0.3, 0.46), (0.45, 0.3, 0.9))
    task = Task((0.0, 0.0, 0.0), 0.0, 0.0, space, TargetQuery("box", "red", (0.04, 0.04, 0.12)))
    P, N = box_surface(HALF, CENTRE)
    return occ, task, model(P, N)


class OnlyTopDown:
    """A proposer (the plug-in point) keeping only near-vertical approaches."""

    def propose(self, target, rng):
        c = antipodal_candidates(target, None, rng)
        return c.take(np.nonzero(c.approach[:, 2] < -0.9)[0])


@pytest.fixture(scope="module")
def world():
    return shelf_world(board_above_z=0.74)


def test_desired_approach_enters_the_opening_tilted_down(world):
    occ, task, target = world
    n = desired_approach(target, task)
    assert abs(n[0] - math.cos(math.radians(20))) < 1e-9 and abs(n[2] + math.sin(math.radians(20))) < 1e-9 \
        and abs(n[1]) < 1e-9  # +x into the space, pitched 20 deg down
    assert gpq(0.8, True, 0.0) == pytest.approx(0.8) and gpq(0.8, False, 0.0) == 0.0


def test_an_approach_through_the_board_above_is_rejected_with_its_reason(world):
    occ, task, target = world
    spheres = panda_sphere_model()
    sel = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(), np.random.default_rng(0),
                       proposer=OnlyTopDown())
    assert sel.failure is not None and sel.T_world_tcp is None
    blocked = sum(sel.rejections.get(r, 0) for r in (Rejection.HAND_IN_COLLISION, Rejection.HAND_APPROACH_BLOCKED,
                                                     Rejection.IK_IN_COLLISION, Rejection.PREGRASP_BLOCKED))
    assert blocked > 0 and sel.failure in (GraspFailure.NO_APPROACH_PATH, GraspFailure.NO_IK)


def test_the_box_under_the_board_is_grasped_from_the_side(world):
    occ, task, target = world
    spheres = panda_sphere_model()
    sel = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(), np.random.default_rng(0))
    assert sel.failure is None, sel.rejections
    a = sel.T_world_tcp[:3, 2]
    assert a[2] > -0.75 and a[0] > 0.5  # from the opening, well away from straight down
    assert sel.approach_angle <= GraspSelectConfig().max_approach_angle + 1e-9
    assert sel.ik_free and sel.gpq == pytest.approx(sel.score * math.cos(sel.approach_angle))
    assert sel.path is not None and np.allclose(sel.path[0], Q_HOME) and np.allclose(sel.path[-1], sel.q_pregrasp)
    # the unconstrained ablation takes the best score whatever the approach and the map say;
    # only the motion planner may still refuse its pre-grasp
    off = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(constrained=False),
                       np.random.default_rng(0))
    assert Rejection.APPROACH_ANGLE not in off.rejections
    assert off.failure is GraspFailure.NO_PATH or off.score >= sel.score


def test_the_fine_field_near_the_target_keeps_the_same_cubes_and_loses_less():
    from compass_manip.grasp.carve import local_fine_field
    from compass_manip.grasp.checks import hand_clear
    from compass_manip.mapping.distance import DistanceField

    occ = OccupancyMap(MapConfig())
    occ.set_box(occ.grid_min, occ.grid_max, VoxelState.FREE)
    occ.set_box(np.array([0.50, -0.05, 0.40]), np.array([0.52, 0.05, 0.50]), VoxelState.OCCUPIED)
    unsafe = occ.state != VoxelState.FREE
    coarse = DistanceField.from_unsafe(unsafe, occ.grid_min, occ.resolution)
    fine = local_fine_field(unsafe, occ, np.array([0.3, -0.2, 0.3]), np.array([0.7, 0.2, 0.6]), 2)
    assert fine.resolution == pytest.approx(0.005)
    cubes = occ.grid_min + np.argwhere(unsafe) * occ.resolution  # min corners of the unsafe cubes
    rng = np.random.default_rng(0)
    p = np.array([0.51, 0.0, 0.45]) + rng.uniform(-0.08, 0.08, (300, 3))
    gap = np.maximum(np.maximum(cubes[None] - p[:, None], p[:, None] - (cubes[None] + occ.resolution)), 0.0)
    true = np.min(np.linalg.norm(gap, axis=2), axis=1)  # exact distance to the cubes
    ident = np.broadcast_to(np.eye(4), (len(p), 4, 4)).copy()
    ident[:, :3, 3] = p
    bounds = []
    for f in (coarse, fine):
        # hand_clear with one sphere of radius r at each point: clear only if r <= the true distance
        for r in (0.004, 0.012, 0.02):
            ok = hand_clear(f, ident, (np.zeros((1, 3)), np.array([r])), voxel_extent=True)
            assert np.all(true[ok] >= r - 1e-9)  # sound: never clear where a cube is nearer than r
        ok = hand_clear(f, ident, (np.zeros((1, 3)), np.array([0.012])), voxel_extent=True)
        bounds.append(ok.sum())
    assert bounds[1] > bounds[0]  # the fine field clears more of the truly free points
    with pytest.raises(CompassInputError, match="upsample"):
        local_fine_field(unsafe, occ, p[0], p[0], 9)


def test_the_search_goes_past_many_infeasible_candidates_up_to_max_checked(world, monkeypatch):
    """The arm's checks run on up to max_checked candidates (default 400: in the default scenes
    the first feasible one often came after the 60th), and no further."""
    from compass_manip.grasp import checks as checks_mod
    occ, task, target = world
    spheres = panda_sphere_model()
    orig = checks_mod.GraspChecks.check_shorter
    calls = {"n": 0}

    def first_100_fail(self, *args, **kw):  # the best 100 candidates have no arm solution
        calls["n"] += 1
        return (None, "NO_IK", math.nan, math.nan) if calls["n"] <= 100 else orig(self, *args, **kw)

    monkeypatch.setattr(checks_mod.GraspChecks, "check_shorter", first_100_fail)
    assert GraspSelectConfig().max_checked >= 150
    sel = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(), np.random.default_rng(0))
    assert sel.failure is None and sel.rejections[Rejection.NO_IK] == 100
    calls["n"] = 0
    few = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(max_checked=60, exact_fallback=False),
                       np.random.default_rng(0))
    assert few.failure is GraspFailure.NO_IK and few.rejections[Rejection.NO_IK] == 60 and calls["n"] == 60


def test_the_arm_takes_a_lower_lift_or_shorter_pregrasp_than_the_hand_alone_allows(world):
    """Under the board above, the hand alone clears a 10 cm lift for some grasps whose arm
    does not: the arm's checks fall back to the lower lift heights (and shorter pre-grasps)
    of the config, and the configurations they return sit at the distances they report; the
    selection still prefers, at equal score, a grasp with the full lift."""
    import dataclasses
    from compass_manip.grasp.checks import GraspChecks, first_clear, lift_steps, pregrasp_steps, rigid_hand_spheres
    from compass_manip.robot.ik import PandaIK
    occ, task, target = world
    spheres = panda_sphere_model()
    cfg = GraspSelectConfig()
    safe = (spheres.sphere_centers(Q_HOME[None])[0], spheres.radii + cfg.robot_clearance)

    def checks(c):
        return GraspChecks(occ, target, spheres, PandaIK(spheres.kinematics), c, safe, None, Q_HOME)

    ch = checks(cfg)
    only_full = checks(dataclasses.replace(cfg, pregrasp_distances=(0.10,), lift_heights=(0.10,)))
    clear = {h: ch.held_target_clear(h) for h in cfg.lift_heights}
    c = antipodal_candidates(target, None, np.random.default_rng(0))
    n = desired_approach(target, task)
    c = c.take(np.nonzero(approach_angles(c, n) <= cfg.max_approach_angle)[0])
    local = rigid_hand_spheres(spheres)
    pre = first_clear(ch.fine, c.T_world_tcp, local, pregrasp_steps(cfg.pregrasp_distances))
    lift = first_clear(ch.fine, c.T_world_tcp, local, lift_steps(cfg.lift_heights))
    found = 0
    for i in np.nonzero((pre == 0.10) & (lift == 0.10))[0][:150]:
        T = c.T_world_tcp[i]
        if only_full.check_shorter(T, Q_HOME, 0.10, 0.10, clear)[1] != "LIFT_BLOCKED":
            continue
        qs, why, d, h = ch.check_shorter(T, Q_HOME, 0.10, 0.10, clear)
        if why is not None:
            continue
        found += 1
        assert d in cfg.pregrasp_distances and h in (0.07, 0.04)
        kin = spheres.kinematics
        assert np.allclose(kin.T_world_tcp(qs[1])[:3, 3], T[:3, 3] - d * T[:3, 2], atol=2e-3)
        assert np.allclose(kin.T_world_tcp(qs[2])[:3, 3], T[:3, 3] + np.array([0.0, 0.0, h]), atol=2e-3)
        assert ch.check(T, Q_HOME, 0.10, 0.10, clear)[1] is None  # `check` is the same test
        assert math.isnan(only_full.check_shorter(T, Q_HOME, 0.10, 0.10, clear)[2])
        if found >= 3:
            break
    assert found >= 1
    sel = select_grasp(target, occ, task, Q_HOME, spheres, cfg, np.random.default_rng(0))
    assert sel.lift_height == 0.10  # a full lift exists at the best score: it is preferred


def test_pinned_candidates_are_checked_first_whatever_their_score(world, monkeypatch):
    """INSPECT's hypotheses (a `PinnedProposer`'s pinned candidates) go to the arm's checks
    before every other candidate, so the cap on the candidates checked cannot drop them."""
    from compass_manip.grasp import checks as checks_mod
    from compass_manip.grasp.candidates import AntipodalProposer, PinnedProposer
    from compass_manip.grasp.select import n_pinned
    occ, task, target = world
    spheres = panda_sphere_model()
    best = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(), np.random.default_rng(0))
    c = antipodal_candidates(target, None, np.random.default_rng(0))
    i = int(np.argmin(np.linalg.norm(c.T_world_tcp[:, :3, 3] - best.T_world_tcp[:3, 3], axis=1)
                      + np.linalg.norm(c.T_world_tcp[:, :3, 2] - best.T_world_tcp[:3, 2], axis=1)))
    pin = c.take([i])
    pin = GraspCandidates(pin.T_world_tcp, pin.width, np.array([0.1]), pin.p1, pin.p2, pin.n1, pin.n2)
    proposer = PinnedProposer(AntipodalProposer(), pin)
    assert n_pinned(proposer) == 1 and n_pinned(AntipodalProposer()) == 0 and n_pinned(None) == 0
    seen = []
    orig = checks_mod.GraspChecks.check_shorter

    def record(self, T, *args, **kw):
        seen.append(np.array(T))
        return orig(self, T, *args, **kw)

    monkeypatch.setattr(checks_mod.GraspChecks, "check_shorter", record)
    sel = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(), np.random.default_rng(1),
                       proposer=proposer)
    assert np.allclose(seen[0], pin.T_world_tcp[0])
    assert sel.failure is None


def test_a_search_stops_after_max_failed_plans_planner_failures(world, monkeypatch):
    """Every group of feasible goals whose path fails costs the planner's budget: one field's
    search stops after `max_failed_plans` of them and reports NO_PATH."""
    from compass_manip.grasp import select as select_mod
    from compass_manip.motion.planner import PlanFailure, PlanResult
    occ, task, target = world
    spheres = panda_sphere_model()
    calls = {"n": 0}

    def never(*args, **kw):
        calls["n"] += 1
        return PlanResult(None, PlanFailure.TIMEOUT, -1, 0.0, 0)

    monkeypatch.setattr(select_mod, "plan", never)
    cfg = GraspSelectConfig(max_failed_plans=2, exact_fallback=False, max_feasible=1)
    sel = select_grasp(target, occ, task, Q_HOME, spheres, cfg, np.random.default_rng(0))
    assert sel.failure is GraspFailure.NO_PATH and calls["n"] == 2 and sel.rejections[Rejection.NO_PATH] == 2
    calls["n"] = 0
    sel = select_grasp(target, occ, task, Q_HOME, spheres, GraspSelectConfig(max_failed_plans=None, max_feasible=1,
                                                                            exact_fallback=False),
                       np.random.default_rng(0))
    assert sel.failure is GraspFailure.NO_PATH and calls["n"] > 2
    with pytest.raises(CompassInputError, match="max_failed_plans"):
        GraspSelectConfig(max_failed_plans=0)


def test_the_pregrasp_configuration_is_a_valid_goal_for_the_planner(world):
    """The pre-grasp the arm's checks return is valid for the planner's checker (its margin and
    the target's box): a pre-grasp within the plan's margin of unsafe space made the planner
    refuse its goal at once (GOAL_INVALID on levels 2 and 4 of seed 0: a NO_PATH that no
    planning time could change)."""
    import dataclasses
    from compass_manip.grasp.checks import (GraspChecks, first_clear, lift_steps, offset_pose, pregrasp_steps,
                                            rigid_hand_spheres)
    from compass_manip.robot.ik import PandaIK
    occ, task, target = world
    spheres = panda_sphere_model()
    cfg = dataclasses.replace(GraspSelectConfig(), plan_margin=0.04)
    safe = (spheres.sphere_centers(Q_HOME[None])[0], spheres.radii + cfg.robot_clearance)
    ch = GraspChecks(occ, target, spheres, PandaIK(spheres.kinematics), cfg, safe, None, Q_HOME)
    assert ch.plan_margin > 0.02
    clear = {h: ch.held_target_clear(h) for h in cfg.lift_heights}
    c = antipodal_candidates(target, None, np.random.default_rng(0))
    c = c.take(np.nonzero(approach_angles(c, desired_approach(target, task)) <= cfg.max_approach_angle)[0])
    local = rigid_hand_spheres(spheres)
    pre = first_clear(ch.fine, c.T_world_tcp, local, pregrasp_steps(cfg.pregrasp_distances))
    lift = first_clear(ch.fine, c.T_world_tcp, local, lift_steps(cfg.lift_heights))
    ok = np.nonzero(~np.isnan(pre) & ~np.isnan(lift))[0][:60]
    near_unsafe = feasible = 0
    for i in ok:
        T = c.T_world_tcp[i]
        qs, why, d, _ = ch.check_shorter(T, Q_HOME, pre[i], lift[i], clear)
        # the pre-grasp the full checker alone would take next to the first free grasp configuration
        sol = ch.ik_first(T, Q_HOME).solutions
        free = sol[ch.valid(sol)]
        q_any = None if not len(free) else ch.near(offset_pose(T, -pre[i]), free[0], ch)
        near_unsafe += q_any is not None and not bool(ch.plan.are_valid(q_any[None])[0])
        if why is None:
            feasible += 1
            assert bool(ch.plan.are_valid(qs[1][None])[0])
    assert feasible >= 1 and near_unsafe >= 1
