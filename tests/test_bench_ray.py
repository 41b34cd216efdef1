"""The Ray path: two fake trials on a private local Ray instance, into the same store."""
from __future__ import annotations

import pytest

from compass_manip.bench.runner import run_sweep
from compass_manip.bench.store import ResultsStore
from compass_manip.bench.sweep import SweepConfig

ray = pytest.importorskip("ray", reason="Ray is the optional [cluster] extra; not installed here")


def test_ray_runs_two_trials_into_the_store(tmp_path):
    from compass_manip.bench.synthetic import synthetic_trial

    db = str(tmp_path / "r.sqlite")
    config = SweepConfig(methods=("compass",), levels=(1,), scenes=1, trials=2, workers=2, ray_address="local")
    summary = run_sweep(config, db, trial_fn=synthetic_trial, progress=False)
    assert (summary.total, summary.ran) == (2, 2)
    assert not ray.is_initialized()  # the instance this sweep started is shut down
    with ResultsStore(db) as s:
        recs = s.records()
    assert sorted(r.trial for r in recs) == [0, 1]
    assert all(r.result is not None and r.failure in (None, "target_not_found", "grasp_failed", "object_dropped")
               for r in recs)
    again = run_sweep(config, db, trial_fn=synthetic_trial, progress=False)
    assert (again.skipped, again.ran) == (2, 0)
