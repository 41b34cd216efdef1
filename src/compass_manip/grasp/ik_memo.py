"""The IK solver's q7 sweeps kept across grasp checks: INSPECT's steps and the GRASP stage.

`robot.ik.PandaIK.solve(..., cache=d)` memoises its q7 sweep (the analytic solutions and
their refinement, before any validity check) in the dict d by the hand pose, q_ref and n_q7:
a pure function of those and of the solver's robot (its base, flange mount and kinematic
arrays) and `IKConfig`. `GraspChecks` used a new dict per selection, so every INSPECT step
solved again the pre-grasp and lift poses of the hypotheses it had checked the step before
(their IK is asked from each grasp configuration, the same one as long as that pose's
solutions are), and the GRASP stage's selection the pinned hypotheses that the last INSPECT
step had solved from the same configuration. `IKSweeps` keeps one dict per solver
fingerprint (`solver_key`), so two `PandaIK` of the same robot share it and two of different
robots never do; the answers are those of a fresh solve, only not computed twice.
"""
from __future__ import annotations

import hashlib

import numpy as np

from ..errors import CompassInputError


def solver_key(ik) -> str:
    """A digest of everything a `PandaIK` q7 sweep depends on besides its arguments: the
    base pose, the flange mount, the hand's link index, the kinematic arrays and the config."""
    h = hashlib.sha1()
    for a in (ik.T_base_world, ik.T_hand_link8, *tuple(ik.kin.kernel_args())):
        a = np.asarray(a)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(repr((ik.kin.hand_index, ik.config)).encode())
    return h.hexdigest()


class IKSweeps:
    """Memoised q7 sweeps per IK solver (module doc); `for_solver(ik)` gives the dict to pass
    as `PandaIK.solve(cache=...)`. max_entries: when one solver's dict holds more, it is
    emptied before it is handed out again (only what is recomputed changes, never an answer)."""

    def __init__(self, max_entries: int = 50_000) -> None:
        if isinstance(max_entries, bool) or not isinstance(max_entries, int) or max_entries < 1:
            raise CompassInputError(f"max_entries {max_entries!r} is not allowed; use an integer >= 1")
        self.max_entries = max_entries
        self._by_solver: dict[str, dict] = {}
        self._keys: dict[int, tuple] = {}  # id(ik) -> (ik, its solver_key): the digest once per solver object

    def for_solver(self, ik) -> dict:
        held = self._keys.get(id(ik))
        if held is None or held[0] is not ik:
            held = self._keys[id(ik)] = (ik, solver_key(ik))
        cache = self._by_solver.setdefault(held[1], {})
        if len(cache) > self.max_entries:
            cache.clear()
        return cache

    def __len__(self) -> int:
        return sum(len(c) for c in self._by_solver.values())
