"""The trial end to end: a find-only Level-1 COMPASS trial finds the target with no contact
and a true detection; the same seed gives a bit-identical trial with the fixed planning
charge; results carry the JSON keys of `compass run --json`. (The GRASP state: test_trial_grasp.py.)"""
import json

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.trial.config import GraspTrialConfig, TrialConfig
from compass_manip.trial.machine import TrialState
from compass_manip.trial.result import TrialFailure
from compass_manip.trial.runner import TrialSpec, check_spec, run_trial_full, trial_rng

SPEC = TrialSpec("compass", level=1, scene=1, trial=0, seed=0)
KEYS = {"method", "level", "scene", "trial", "seed", "success", "failure", "tft_s", "pft_m", "mpsr", "am", "gpq",
        "collisions", "explored_curve", "decisions", "planning_ms_median", "planning_ms_p90", "wall_s",
        "true_detection", "found", "grasp_s", "lift_m", "grasp_looks"}
FIND_ONLY = GraspTrialConfig(enabled=False)


@pytest.fixture(scope="module")
def found():
    return run_trial_full(SPEC, TrialConfig(grasp=FIND_ONLY))


@pytest.fixture(scope="module")
def runs():
    """Two short runs (12 s simulated) of one trial."""
    config = TrialConfig(time_limit_s=12.0, grasp=FIND_ONLY)
    spec = TrialSpec("compass", level=1, scene=3, trial=1, seed=0)
    return run_trial_full(spec, config), run_trial_full(spec, config)


def test_level1_trial_finds_the_target(found):
    run = found
    r = run.result
    assert r.success and r.failure is None, r.failure
    assert r.true_detection is True and r.collisions == 0
    assert 0 < r.tft_s < 200 and r.pft_m > 0 and r.decisions >= 1
    assert r.mpsr is not None and 0 < r.mpsr <= 1 and r.am > 0
    assert run.outcome.states[0] is TrialState.NFA and run.outcome.states[-1] is TrialState.DONE
    assert TrialState.FOUND in run.outcome.states and TrialState.GRASP not in run.outcome.states
    assert r.found and r.grasp_s is None and r.lift_m is None and run.outcome.grasp is None
    curve = np.array(r.explored_curve)
    assert np.all(np.diff(curve[:, 0]) >= 0) and np.all((curve[:, 1] >= 0) & (curve[:, 1] <= 1))
    d = r.to_dict()
    assert set(d) == KEYS and json.loads(json.dumps(d)) == d
    assert d["gpq"] is None and d["failure"] is None


def test_same_seed_gives_an_identical_trial(runs):
    a, b = (run.result.to_dict() for run in runs)
    for k in ("wall_s", "planning_ms_median", "planning_ms_p90"):  # measured compute, not simulated
        a.pop(k), b.pop(k)
    assert a == b
    assert np.array_equal(runs[0].outcome.camera_path, runs[1].outcome.camera_path)
    assert runs[0].result.decisions > 5


def test_trial_seeds_differ_per_trial_and_specs_are_checked():
    x = trial_rng(TrialSpec("compass", 1, 1, 0)).uniform()
    assert x == trial_rng(TrialSpec("compass", 1, 1, 0)).uniform()
    assert x != trial_rng(TrialSpec("compass", 1, 1, 1)).uniform()
    with pytest.raises(CompassInputError, match="not registered; use one of compass"):
        check_spec(TrialSpec("nope", 1, 0))
    with pytest.raises(CompassInputError, match="level 7"):
        check_spec(TrialSpec("compass", 7, 0))
    with pytest.raises(CompassInputError, match="scene -1"):
        check_spec(TrialSpec("compass", 1, -1))


def test_config_is_json_and_failures_are_named():
    d = TrialConfig().to_dict()
    assert json.loads(json.dumps(d)) == d
    assert d["clock"]["measured"] is False and d["method"]["nfa"]["enabled"] is True
    assert {f.name for f in TrialFailure} == {"NO_REACHABLE_VIEW", "PLANNING_FAILED", "TIME_LIMIT",
                                              "TARGET_NOT_FOUND", "FALSE_DETECTION", "COLLISION",
                                              "GRASP_NO_CANDIDATE", "GRASP_NO_IK", "GRASP_NO_PATH", "GRASP_COLLISION",
                                              "GRASP_MISSED", "GRASP_SLIP", "GRASP_DROP", "GRASP_UNVERIFIED"}
    assert d["grasp"]["enabled"] is True and d["grasp"]["select"]["constrained"] is True
