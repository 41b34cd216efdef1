"""Grasp hypotheses kept across INSPECT steps: a pinned proposer puts the kept candidates
first, the inspector keeps each hypothesis's candidate (newest first, repeats once, capped)
and the grasp map's fine map grows by the new frames only, equal to one built afresh."""
from types import SimpleNamespace

import numpy as np
import pytest

from _inspect_fixtures import empty_cabinet_world, observed_view

from compass_manip.errors import CompassInputError
from compass_manip.grasp.candidates import GraspCandidates, PinnedProposer
from compass_manip.sim.grasp_only import oracle_detection
from compass_manip.trial.grasp_map import GraspMap
from compass_manip.trial.grasp_views import GraspInspector
from compass_manip.trial.inspect import InspectConfig


def _cands(xs):
    T = np.tile(np.eye(4), (len(xs), 1, 1))
    T[:, 0, 3] = xs
    z = np.zeros((len(xs), 3))
    return GraspCandidates(T, np.full(len(xs), 0.05), np.full(len(xs), 0.5), z, z, z, z)


class _Fixed:
    def __init__(self, cands):
        self.cands, self.calls = cands, []

    def propose(self, target, rng, toward=None, max_angle=None):
        self.calls.append((toward, max_angle))
        return self.cands


def test_pinned_candidates_come_first_then_the_base_proposers():
    base = _Fixed(_cands([0.3, 0.4]))
    out = PinnedProposer(base, _cands([0.1])).propose(None, np.random.default_rng(0), np.array([1.0, 0, 0]), 0.5)
    assert np.allclose(out.T_world_tcp[:, 0, 3], [0.1, 0.3, 0.4])
    assert base.calls[0][1] == 0.5  # the cone is passed on
    assert len(GraspCandidates.concat([GraspCandidates.empty(), _cands([0.2])])) == 1
    assert len(GraspCandidates.concat([])) == 0


def test_inspector_pins_hypotheses_newest_first_once_and_capped():
    insp = GraspInspector.__new__(GraspInspector)
    insp.config = InspectConfig(max_pinned=3)
    insp.pinned = GraspCandidates.empty()
    hyp = lambda x: SimpleNamespace(candidate=_cands([x]))  # noqa: E731
    insp.pin([hyp(0.1), hyp(0.2)])
    insp.pin([hyp(0.3), hyp(0.1)])
    assert np.allclose(insp.pinned.T_world_tcp[:, 0, 3], [0.3, 0.1, 0.2])
    insp.pin([hyp(0.4)])
    assert np.allclose(insp.pinned.T_world_tcp[:, 0, 3], [0.4, 0.3, 0.1])  # the oldest dropped
    insp.config = InspectConfig(max_pinned=0)
    insp.pin([hyp(0.5)])
    assert len(insp.pinned) == 3  # off: nothing more kept
    with pytest.raises(CompassInputError, match="max_pinned"):
        InspectConfig(max_pinned=-1)


def test_fine_map_grows_by_new_frames_and_equals_one_built_afresh():
    world = empty_cabinet_world()
    try:
        task, wm, q_view, view = observed_view(world)
        pts = oracle_detection(world, view)
        lo, hi = pts.min(0) - 0.1, pts.max(0) + 0.1
        q_home = np.asarray(world.robot.q_home)
        frames = [world.render(q_home + (q_view - q_home) * s, rgb=False, seg=False) for s in np.linspace(0, 1, 4)]
        gm = GraspMap(world.robot)
        for f in frames[:2]:
            gm.frame(f, None)
        first = gm.fine_map(lo, hi).state.copy()
        for f in frames[2:]:
            gm.frame(f, None)
        grown = gm.fine_map(lo, hi)
        fresh = GraspMap(world.robot)
        for f in frames:
            fresh.frame(f, None)
        assert np.array_equal(grown.state, fresh.fine_map(lo, hi).state)
        assert np.array_equal(grown.logodds, fresh.fine_map(lo, hi).logodds)
        assert not np.array_equal(first, grown.state)  # the later frames did add to it
    finally:
        world.close()

