"""The Ray path: two fake trials on a private local Ray instance, into the same store; one over the cap."""
from __future__ import annotations

from functools import partial

import pytest

from compass_manip.bench.runner import run_sweep
from compass_manip.bench.store import ResultsStore
from compass_manip.bench.sweep import RunFailure, SweepConfig
from compass_manip.bench.synthetic import SyntheticConfig, synthetic_trial

ray = pytest.importorskip("ray", reason="Ray is the optional [cluster] extra; not installed here")


def test_ray_runs_two_trials_into_the_store(tmp_path):
    db = str(tmp_path / "r.sqlite")
    fn = partial(synthetic_trial, config=SyntheticConfig(slow_scenes=(1,), slow_s=60.0))
    config = SweepConfig(methods=("compass",), levels=(1,), scenes=2, trials=1, workers=2, wall_cap_s=10.0,
                         ray_address="local")
    summary = run_sweep(config, db, trial_fn=fn, progress=False)
    assert (summary.total, summary.ran) == (2, 2)
    assert not ray.is_initialized()  # the instance this sweep started is shut down
    with ResultsStore(db) as s:
        by_scene = {r.scene: r for r in s.records()}
    assert by_scene[0].result == synthetic_trial(next(iter(config.specs())))[1]
    assert by_scene[1].failure == RunFailure.WALL_TIME.value and by_scene[1].result is None
    again = run_sweep(config, db, trial_fn=fn, progress=False)
    assert (again.skipped, again.ran) == (2, 0)
