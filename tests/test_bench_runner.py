"""The sweep runner with fake trials: resume after SIGKILL, raising, over-cap and dying trials."""
from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from functools import partial

import pytest

from compass_manip.bench.runner import run_sweep, trial_fn_name
from compass_manip.bench.store import ResultsStore
from compass_manip.bench.sweep import RunFailure, Spec, SweepConfig, resolve_trial_fn, validate
from compass_manip.bench.synthetic import SyntheticConfig, synthetic_trial
from compass_manip.errors import CompassInputError

SRC = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "src")


def _fast(**kw):
    return partial(synthetic_trial, config=SyntheticConfig(**kw))


def _dying_trial(spec):
    if spec.scene == 1:
        os.kill(os.getpid(), signal.SIGKILL)
    return synthetic_trial(spec)


def _count(path: str) -> int:
    con = sqlite3.connect(path, timeout=10)
    try:
        return con.execute("SELECT COUNT(*) FROM trials").fetchone()[0]
    except sqlite3.OperationalError:
        return 0
    finally:
        con.close()


def test_specs_cover_the_grid_once():
    c = SweepConfig(methods=("fv", "compass"), levels=(1, 3), scenes=3, trials=2, seed=5)
    keys = [s.key for s in c.specs()]
    assert len(keys) == len(set(keys)) == 2 * 2 * 3 * 2
    assert all(k[4] == 5 for k in keys)
    assert {k[3] for k in keys} == {0, 1}


def test_sweep_records_every_trial_then_skips_them(tmp_path):
    db = str(tmp_path / "r.sqlite")
    config = SweepConfig(methods=("fv", "compass"), levels=(1,), scenes=2, trials=2, workers=2)
    first = run_sweep(config, db, trial_fn=_fast(), progress=False)
    assert (first.total, first.skipped, first.ran) == (8, 0, 8)
    second = run_sweep(config, db, trial_fn=_fast(), progress=False)
    assert (second.skipped, second.ran) == (8, 0)
    assert second.done == {"fv": 4, "compass": 4}
    with ResultsStore(db) as s:
        recs = s.records()
    assert len(recs) == 8
    assert all(r.trial_fn == "compass_manip.bench.synthetic:synthetic_trial" for r in recs)
    assert all(r.config["synthetic"]["sleep_s"] == 0.0 for r in recs)
    # the stored result is the trial's own, unchanged
    r = recs[0]
    assert r.result == synthetic_trial(Spec(r.method, r.level, r.scene, r.trial, r.seed))[1]


def test_raising_trial_is_recorded_and_the_sweep_finishes(tmp_path):
    db = str(tmp_path / "r.sqlite")
    config = SweepConfig(methods=("compass",), levels=(2,), scenes=3, trials=2, workers=2)
    summary = run_sweep(config, db, trial_fn=_fast(raise_scenes=(1,)), progress=False)
    assert summary.ran == 6 and summary.failures.get(RunFailure.ERROR.value) == 2
    with ResultsStore(db) as s:
        recs = s.records()
    errors = [r for r in recs if r.failure == RunFailure.ERROR.value]
    assert sorted((r.scene, r.trial) for r in errors) == [(1, 0), (1, 1)]
    assert all("synthetic failure in scene 1" in r.error and r.result is None and not r.success for r in errors)
    assert all(r.result is not None for r in recs if r.scene != 1)


def test_trial_over_the_wall_cap_is_killed_and_recorded(tmp_path):
    db = str(tmp_path / "r.sqlite")
    # the cap leaves the fast trials room for a worker's start-up on a loaded machine
    config = SweepConfig(methods=("compass",), levels=(1,), scenes=3, trials=1, workers=2, wall_cap_s=5.0)
    t0 = time.perf_counter()
    run_sweep(config, db, trial_fn=_fast(slow_scenes=(0,), slow_s=60.0), progress=False)
    assert time.perf_counter() - t0 < 40.0  # the 60 s trial did not run to its end
    with ResultsStore(db) as s:
        by_scene = {r.scene: r for r in s.records()}
    assert by_scene[0].failure == RunFailure.WALL_TIME.value and "5 s" in by_scene[0].error
    assert 4.9 <= by_scene[0].wall_s < 30.0
    assert by_scene[1].result is not None and by_scene[2].result is not None


def test_dying_worker_is_recorded_and_replaced(tmp_path):
    db = str(tmp_path / "r.sqlite")
    config = SweepConfig(methods=("ig",), levels=(1,), scenes=3, trials=2, workers=1)
    run_sweep(config, db, trial_fn=_dying_trial, progress=False)
    with ResultsStore(db) as s:
        recs = s.records()
    assert len(recs) == 6
    died = sorted((r.scene, r.trial) for r in recs if r.failure == RunFailure.WORKER_DIED.value)
    assert died == [(1, 0), (1, 1)]
    assert all("exit code -9" in r.error for r in recs if r.scene == 1)


_DRIVER = """
import sys
from functools import partial
from compass_manip.bench.runner import run_sweep
from compass_manip.bench.sweep import SweepConfig
from compass_manip.bench.synthetic import SyntheticConfig, synthetic_trial
config = SweepConfig(methods=("fv", "compass"), levels=(1, 4), scenes=3, trials=2, workers=2)
run_sweep(config, sys.argv[1], trial_fn=partial(synthetic_trial, config=SyntheticConfig(sleep_s=float(sys.argv[2]))),
          progress=False)
"""


def test_sigkill_midway_then_resume_loses_and_duplicates_nothing(tmp_path):
    db = str(tmp_path / "r.sqlite")
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-c", _DRIVER, db, "0.25"], env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while _count(db) < 6 and time.monotonic() < deadline:
            assert proc.poll() is None, "the sweep ended before it could be killed"
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # its orphaned workers, if any are left
        except ProcessLookupError:
            pass
    killed_at = _count(db)
    assert 6 <= killed_at < 24, killed_at
    with ResultsStore(db) as s:
        before = {r.key: r.finished_at for r in s.records()}
    r = subprocess.run([sys.executable, "-c", _DRIVER, db, "0.0"], env=env, timeout=120)
    assert r.returncode == 0
    con = sqlite3.connect(db)
    rows = con.execute("SELECT method, level, scene, trial, seed, COUNT(*) FROM trials "
                       "GROUP BY method, level, scene, trial, seed").fetchall()
    con.close()
    assert len(rows) == 24 and all(n == 1 for *_, n in rows)
    expected = {(m, lv, s, t, 0) for m in ("fv", "compass") for lv in (1, 4) for s in range(3) for t in range(2)}
    assert {tuple(row[:5]) for row in rows} == expected
    with ResultsStore(db) as s:
        after = {r.key: r.finished_at for r in s.records()}
    assert all(after[k] == v for k, v in before.items())  # finished trials were skipped, not re-run


@pytest.mark.parametrize("bad, match", [
    (dict(methods=()), "no method"),
    (dict(methods=("fv", "fv")), "repeat"),
    (dict(levels=(0,)), "level 0"),
    (dict(scenes=0), "scenes 0"),
    (dict(trials=0), "trials 0"),
    (dict(workers=0), "workers 0"),
    (dict(wall_cap_s=0.0), "wall-time cap"),
    (dict(seed=-1), "seed -1"),
])
def test_bad_config_is_refused(bad, match):
    with pytest.raises(CompassInputError, match=match):
        validate(SweepConfig(**{"methods": ("fv",), **bad}), methods=["fv", "compass"])


def test_unknown_method_is_refused_naming_the_allowed_ones():
    with pytest.raises(CompassInputError, match=r"'nope' is not known; use one of compass, fv"):
        validate(SweepConfig(methods=("nope",)), methods=["fv", "compass"])


def test_trial_function_resolution():
    fn = resolve_trial_fn("compass_manip.bench.synthetic:synthetic_trial")
    assert trial_fn_name(partial(fn, config=SyntheticConfig())) == "compass_manip.bench.synthetic:synthetic_trial"
    for bad in ("nomodule", "compass_manip.bench.synthetic:nothing", "no_such_module_xyz:f"):
        with pytest.raises(CompassInputError, match="trial function"):
            resolve_trial_fn(bad)


def test_default_trial_function_needs_the_trial_package():
    try:
        import compass_manip.trial.runner  # noqa: F401
    except ModuleNotFoundError:
        with pytest.raises(CompassInputError, match="trial.runner.run_trial is not in this build"):
            resolve_trial_fn()
    else:
        assert callable(resolve_trial_fn())


def test_synthetic_trial_is_deterministic_and_json_able():
    spec = Spec("compass", 3, 4, 5, 6)
    a, b = synthetic_trial(spec), synthetic_trial(spec)
    assert json.dumps(a) == json.dumps(b)
    assert json.dumps(synthetic_trial(Spec("compass", 3, 4, 6, 6))) != json.dumps(a)  # trials differ


def test_store_of_another_trial_function_is_not_mixed(tmp_path):
    db = str(tmp_path / "r.sqlite")
    config = SweepConfig(methods=("fv",), levels=(1,), scenes=1, trials=1)
    run_sweep(config, db, trial_fn=_fast(), progress=False)
    with pytest.raises(CompassInputError, match="not mixed"):
        run_sweep(config, db, trial_fn=_dying_trial, progress=False)


def _racing_trial(spec, db):
    """Stores its own row first, as a second sweep on the same file would."""
    with ResultsStore(db) as s:
        from compass_manip.bench.runner import record_of
        from compass_manip.bench.pool import Outcome

        config, result = synthetic_trial(spec)
        s.add(record_of(Outcome(spec, config, {**result, "decisions": -1}, None, None, 0.0),
                        "compass_manip.bench.synthetic:synthetic_trial"))
    return synthetic_trial(spec)


def test_trial_stored_first_by_a_concurrent_run_is_kept_once(tmp_path, capsys):
    db = str(tmp_path / "r.sqlite")
    ResultsStore(db, create=True).close()
    fn = partial(_racing_trial, db=db)
    summary = run_sweep(SweepConfig(methods=("gse",), levels=(1,), scenes=2, trials=1), db, trial_fn=fn,
                        progress=False)
    assert summary.ran == 2
    with ResultsStore(db) as s:
        recs = s.records()
    assert len(recs) == 2 and all(r.result["decisions"] == -1 for r in recs)  # the first writer's rows
