"""OMPL backend of the planner: OMPL 2.0.1's RRTConnect + PathSimplifier via its Python wheel.

State validity and motion validation call the same numba checks as the numba backend (one
Python callback per query). The search stops on the planner's `Budget`: its edge-check cap
counted on OMPL's validity queries (a termination condition polled by OMPL) and its
deadline if any. OMPL seeds one process-wide RNG on first use, so results are not
reproducible per call even with the check cap alone.
"""
from __future__ import annotations

import time

import numpy as np

from ..robot.model import N_ARM_JOINTS, Q_MAX, Q_MIN
from .rrt_kernels import edge_ok, states_valid

__all__ = ["plan_ompl"]


def plan_ompl(q_start, goals, validity, args, config, res, budget):
    """OMPL RRTConnect + PathSimplifier with Python callbacks; returns (path, fine_ok
    (all False: OMPL's simplifier is re-checked by the caller), goal index, n validity queries). args: `validity.kernel_args()` or None (use the Python API);
    res [rad] edge resolution; budget: the planner's `Budget` (charged with the queries)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    space = ob.RealVectorStateSpace(N_ARM_JOINTS)
    bounds = ob.RealVectorBounds(N_ARM_JOINTS)
    for i in range(N_ARM_JOINTS):
        bounds.setLow(i, float(Q_MIN[i]))
        bounds.setHigh(i, float(Q_MAX[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    si = ss.getSpaceInformation()
    counter = [0]

    def as_q(s) -> np.ndarray:
        return np.array([s[i] for i in range(N_ARM_JOINTS)])

    def state_valid(s) -> bool:
        counter[0] += 1
        q = as_q(s)
        return bool(states_valid(q[None], args)[0] if args is not None else validity.is_valid(q))

    class _EdgeValidator(ob.MotionValidator):
        def checkMotion(self, s1, s2, *_last_valid):
            counter[0] += 1
            q1, q2 = as_q(s1), as_q(s2)
            return bool(edge_ok(q1, q2, res, args) if args is not None else validity.edge_valid(q1, q2, res))

    ss.setStateValidityChecker(state_valid)
    mv = _EdgeValidator(si)
    si.setMotionValidator(mv)
    start = space.allocState()
    for i in range(N_ARM_JOINTS):
        start[i] = float(q_start[i])
    goal = ob.GoalStates(si)
    for g in goals:
        s = space.allocState()
        for i in range(N_ARM_JOINTS):
            s[i] = float(g[i])
        goal.addState(s)
    ss.setStartState(start)
    ss.setGoal(goal)
    planner = og.RRTConnect(si)
    planner.setRange(config.range)
    ss.setPlanner(planner)
    ss.setup()
    limit = budget.checks_left

    def stop() -> bool:
        return (limit is not None and counter[0] >= limit) or (
            budget.deadline is not None and time.perf_counter() >= budget.deadline)

    if budget.spent():
        return None, -1, 0
    ss.solve(ob.PlannerTerminationCondition(stop))
    budget.charge(counter[0])
    if not ss.haveExactSolutionPath():
        budget.spent()  # records a passed deadline
        return None, -1, counter[0]
    if config.simplify:  # not charged to the check cap (as the numba backend's shortcutting)
        if budget.deadline is None:
            ss.simplifySolution()
        else:
            ss.simplifySolution(max(budget.deadline - time.perf_counter(), 1e-3))
    p = ss.getSolutionPath()
    path = np.array([as_q(p.getState(k)) for k in range(p.getStateCount())])
    gi = int(np.argmin(np.linalg.norm(goals - path[-1], axis=1)))
    return path, gi, counter[0]
