"""`compass bench` as a user runs it: a synthetic sweep, resume, and bad input caught before any work."""
from __future__ import annotations

import os
import sqlite3
import subprocess
import sys

import pytest

from compass_manip.bench import sweep
from compass_manip.bench.store import SCHEMA_VERSION, ResultsStore
from compass_manip.cli import main

SYNTHETIC = "compass_manip.bench.synthetic:synthetic_trial"
SRC = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "src")


def _run(*args):
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "compass_manip.cli", *args], capture_output=True, text=True, env=env,
                          timeout=120)


def test_sweep_then_resume(tmp_path, capsys):
    db = str(tmp_path / "r.sqlite")
    args = ["bench", "--methods", "fv,compass", "--levels", "2,4", "--scenes", "2", "--trials", "2", "--seed", "3",
            "--workers", "2", "--db", db, "--trial-fn", SYNTHETIC, "--no-progress"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "16 trials run, 0 already stored, 16 in the sweep" in out
    with ResultsStore(db) as s:
        keys = s.done_keys()
    assert len(keys) == 16 and {k[4] for k in keys} == {3} and {k[1] for k in keys} == {2, 4}
    assert main(args) == 0
    assert "0 trials run, 16 already stored" in capsys.readouterr().out


def test_progress_bar_shows_successes_per_method(tmp_path):
    r = _run("bench", "--methods", "ig,compass", "--levels", "1", "--scenes", "1", "--trials", "3", "--workers", "1",
             "--db", str(tmp_path / "r.sqlite"), "--trial-fn", SYNTHETIC)
    assert r.returncode == 0, r.stderr
    with ResultsStore(str(tmp_path / "r.sqlite")) as s:
        wins = {m: sum(r.success for r in s.records() if r.method == m) for m in ("ig", "compass")}
    last = r.stderr.replace("\r", "\n").strip().splitlines()[-1]
    assert "6/6" in last  # done / total
    assert f"ig {wins['ig']}/3 compass {wins['compass']}/3" in last  # successes / done per method


def _store_of_other_version(path: str) -> None:
    ResultsStore(path, create=True).close()
    con = sqlite3.connect(path)
    con.execute("UPDATE meta SET value = '0' WHERE key = 'schema_version'")
    con.commit()
    con.close()


@pytest.mark.parametrize("extra, needle", [
    (["--levels", "0"], "level '0' is not allowed"),
    (["--levels", "1,5"], "level '5' is not allowed"),
    (["--scenes", "0"], "scenes 0 is not allowed"),
    (["--trials", "0"], "trials 0 is not allowed"),
    (["--workers", "0"], "workers 0 is not allowed"),
    (["--wall-cap", "-1"], "wall-time cap -1"),
    (["--methods", "fv,,compass"], "'' is not a method name"),
    (["--trial-fn", "nonsense"], "trial function 'nonsense' is not allowed"),
    (["--scenes", "many"], "invalid int value"),
])
def test_bad_arguments_one_line_exit_2_nothing_written(tmp_path, extra, needle):
    db = tmp_path / "r.sqlite"
    r = _run("bench", "--methods", "fv", "--scenes", "1", "--trials", "1", "--db", str(db), "--trial-fn", SYNTHETIC,
             *extra)
    assert r.returncode == 2, r.stderr
    assert needle in r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not db.exists()  # checked before any work


def test_bad_store_files_are_refused(tmp_path):
    text = tmp_path / "notes.sqlite"
    text.write_text("not a database at all\n" * 50)
    old = tmp_path / "old.sqlite"
    _store_of_other_version(str(old))
    for path, needle in ((text, "is not a compass results store"), (old, "schema version 0"),
                         (tmp_path / "missing" / "r.sqlite", "does not exist")):
        r = _run("bench", "--methods", "fv", "--scenes", "1", "--trials", "1", "--db", str(path), "--trial-fn",
                 SYNTHETIC)
        assert r.returncode == 2 and needle in r.stderr, r.stderr
        assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    con = sqlite3.connect(old)
    assert con.execute("SELECT COUNT(*) FROM trials").fetchone()[0] == 0  # nothing mixed in
    con.close()


def test_unknown_method_names_the_allowed_ones(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sweep, "known_methods", lambda: ["compass", "fv", "gse", "ig"])
    db = tmp_path / "r.sqlite"
    code = main(["bench", "--methods", "fv,teleport", "--db", str(db), "--trial-fn", SYNTHETIC, "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "method 'teleport' is not known; use one of compass, fv, gse, ig" in err
    assert len(err.strip().splitlines()) == 1 and not db.exists()


def test_ray_without_the_extra_says_how_to_install(tmp_path):
    try:
        import ray  # noqa: F401
    except ImportError:
        r = _run("bench", "--methods", "fv", "--scenes", "1", "--trials", "1", "--db", str(tmp_path / "r.sqlite"),
                 "--trial-fn", SYNTHETIC, "--ray", "local")
        assert r.returncode == 2 and "pip install 'compass-manip[cluster]'" in r.stderr
    else:
        pytest.skip("ray is installed here; tests/test_bench_ray.py runs the Ray path")


def test_default_trial_function_missing_is_one_clear_line(tmp_path):
    try:
        import compass_manip.trial.runner  # noqa: F401
    except ModuleNotFoundError:
        r = _run("bench", "--methods", "fv", "--scenes", "1", "--trials", "1", "--db", str(tmp_path / "r.sqlite"))
        assert r.returncode == 2 and "trial.runner.run_trial is not in this build" in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
    else:
        pytest.skip("the trial package is present in this build")
