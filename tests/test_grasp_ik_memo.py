"""IK sweeps kept across grasp checks (`grasp.ik_memo`): two solvers of the same robot share
one memo, other robots do not; hypotheses and a selection checked with a memo filled by
earlier checks (other configurations, other maps) are those checked afresh."""

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.hypotheses import HypothesisConfig, grasp_hypotheses
from compass_manip.grasp.ik_memo import IKSweeps, solver_key
from compass_manip.grasp.select import GraspSelectConfig, select_grasp
from compass_manip.robot.ik import PandaIK
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME
from compass_manip.robot.spheres import panda_sphere_model

from test_grasp_hypotheses import SLAB, _context
from test_grasp_select import shelf_world
from compass_manip.mapping.occupancy import VoxelState


def test_solvers_of_one_robot_share_a_memo_and_the_memo_answers_as_a_fresh_solve():
    spheres = panda_sphere_model()
    a, b = PandaIK(spheres.kinematics), PandaIK(PandaKinematics())
    assert solver_key(a) == solver_key(b)
    other = PandaIK(spheres.kinematics)
    other.T_base_world = other.T_base_world.copy()
    other.T_base_world[0, 3] += 0.1  # a robot standing elsewhere
    assert solver_key(other) != solver_key(a)
    memo = IKSweeps()
    assert memo.for_solver(a) is memo.for_solver(b) and memo.for_solver(other) is not memo.for_solver(a)
    q = np.asarray(Q_HOME, float)
    T = spheres.kinematics.T_world_tcp(q + 0.1)
    first = a.solve(T, "tcp", q, cache=memo.for_solver(a))
    assert len(memo) >= 1
    again = b.solve(T, "tcp", q, cache=memo.for_solver(b))  # from the memo
    fresh = b.solve(T, "tcp", q)
    for r in (first, again):
        np.testing.assert_array_equal(r.solutions, fresh.solutions)
    with pytest.raises(CompassInputError, match="max_entries"):
        IKSweeps(0)


def test_a_full_memo_is_emptied_and_answers_stay_the_same():
    spheres = panda_sphere_model()
    ik, memo, q = PandaIK(spheres.kinematics), IKSweeps(max_entries=1), np.asarray(Q_HOME, float)
    for s in (0.05, 0.1, 0.15):
        T = spheres.kinematics.T_world_tcp(q + s)
        np.testing.assert_array_equal(ik.solve(T, "tcp", q, cache=memo.for_solver(ik)).solutions,
                                      ik.solve(T, "tcp", q).solutions)
    assert len(memo) <= 2


def test_hypotheses_and_selection_with_a_memo_of_earlier_steps_equal_fresh_ones():
    occ, task, target = shelf_world(board_above_z=0.74)
    unknown = occ.copy()
    unknown.set_box(*SLAB, VoxelState.UNKNOWN)
    spheres, q, safe = _context(occ, target)
    sc, cfg = GraspSelectConfig(), HypothesisConfig(n_hypotheses=4)
    memo = IKSweeps()
    q_before = q + np.r_[0.05, -0.05, 0.0, 0.05, 0.0, -0.05, 0.1]  # an earlier step stood elsewhere
    grasp_hypotheses(target, unknown, task, q_before, spheres, sc, cfg, np.random.default_rng(2), safe,
                     ik_sweeps=memo)
    grasp_hypotheses(target, unknown, task, q, spheres, sc, cfg, np.random.default_rng(2), safe, ik_sweeps=memo)
    n_memo = len(memo)
    assert n_memo > 0
    with_memo = grasp_hypotheses(target, unknown, task, q, spheres, sc, cfg, np.random.default_rng(3), safe,
                                 ik_sweeps=memo)
    fresh = grasp_hypotheses(target, unknown, task, q, spheres, sc, cfg, np.random.default_rng(3), safe)
    assert len(with_memo) == len(fresh) >= 1
    for h, f in zip(with_memo, fresh):
        for name in ("T_world_tcp", "q_grasp", "q_pregrasp", "q_lift"):
            np.testing.assert_array_equal(getattr(h, name), getattr(f, name))
        assert (h.score, h.pregrasp_distance, h.lift_height) == (f.score, f.pregrasp_distance, f.lift_height)
    # the strict selection on the seen map, after the hypotheses on the unknown one filled the memo
    sel_memo = select_grasp(target, occ, task, q, spheres, sc, np.random.default_rng(4), safe_spheres=safe,
                            ik_sweeps=memo)
    sel = select_grasp(target, occ, task, q, spheres, sc, np.random.default_rng(4), safe_spheres=safe)
    assert sel.success and sel_memo.success
    for name in ("T_world_tcp", "q_grasp", "q_pregrasp", "q_lift", "path"):
        np.testing.assert_array_equal(getattr(sel_memo, name), getattr(sel, name))
