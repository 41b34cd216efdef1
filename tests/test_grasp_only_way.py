"""The grasp-only harness's robot's-way mask (the space the arm moved through, marked safe)
never makes a voxel seen occupied safe: in the wider near-field scan's (1, 2) contact every
shelf voxel the camera housing met lay in the way mask, and the occupied ones were made safe
by it (docs/grasping_log.md, "Free space the grasp can trust"). As in the trial's grasp stage."""
import pytest

from compass_manip.sim import grasp_only
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.grasp_only import GraspOnlyConfig
from compass_manip.trial.inspect import InspectConfig


def test_the_way_mask_never_frees_a_voxel_seen_occupied(monkeypatch):
    seen = {}

    def capture(target, occ, task, q, spheres, config, rng, extra_safe=None, **kw):
        seen.update(occ=occ, extra=extra_safe)
        raise StopIteration

    monkeypatch.setattr(grasp_only, "select_grasp", capture)
    config = GraspOnlyConfig(n_view_samples=20, near_field_views=6, near_field_scan=None, explore_views=2,
                             fine_map=False, inspect=InspectConfig(n_views=0))
    with pytest.raises(StopIteration):
        grasp_only.run_grasp_only(certified_scene(1, 0, 0).scene, config, seed=0)
    occ, extra = seen["occ"], seen["extra"]
    assert extra.shape == occ.shape and extra.sum() > 1000  # the way was marked
    assert not (extra & occ.occupied_mask()).any()
