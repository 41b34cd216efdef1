"""Bad input on the command line and at the results store the CLI opens: one line on stderr,
exit 2, before any scene, trial or store work starts (cases not in tests/test_cli_*.py)."""
from __future__ import annotations

import math
import sqlite3

import pytest

from compass_manip.bench import sweep
from compass_manip.bench.store import ResultsStore, TrialRecord
from compass_manip.bench.sweep import SweepConfig, resolve_trial_fn, validate
from compass_manip.cli import main
from compass_manip.errors import CompassInputError

SYNTHETIC = "compass_manip.bench.synthetic:synthetic_trial"


@pytest.fixture
def no_work(monkeypatch):
    """Any scene generation or trial fails the test: the checks must come first."""
    def boom(*a, **k):
        raise AssertionError("work started before the input was checked")

    from compass_manip.sim import certify
    from compass_manip.trial import runner

    monkeypatch.setattr(certify, "certified_scene", boom)
    monkeypatch.setattr(runner, "run_trial_full", boom)


def _one_line_exit_2(argv, capsys, needle):
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and needle in err[0], (code, err)
    assert "Traceback" not in err[0]


RUN = ["run", "--level", "1", "--scene", "0"]


@pytest.mark.parametrize("extra, needle", [
    (["--grasp-only", "--video", "v.mp4"], "--grasp-only does not take --video;"),
    (["--grasp-only", "--record", "r.rrd"], "--grasp-only does not take --record;"),
    (["--grasp-only", "--method", "fv"], "--grasp-only does not take --method;"),
    (["--grasp-only", "--time-limit", "30"], "--grasp-only does not take --time-limit;"),
    (["--grasp-only", "--find-only", "--out", "o"], "--grasp-only does not take --find-only, --out;"),
    (["--find-only", "--unconstrained"], "--unconstrained changes the grasp selection, which --find-only skips"),
    (["--find-only", "--method", "compass-no-grasp-constraints"],
     "--method compass-no-grasp-constraints differs from compass only in its grasp, which --find-only skips"),
    (["--video", ".mp4"], "--video '.mp4' is not allowed; give a file name ending in .mp4"),
    (["--record", "out/.rrd"], "--record 'out/.rrd' is not allowed; give a file name ending in .rrd"),
])
def test_run_conflicting_flags_and_bare_suffixes(extra, needle, capsys, no_work, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _one_line_exit_2(RUN + extra, capsys, needle)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_run_grasp_only_still_takes_method_compass(capsys, monkeypatch):
    """`--method compass` is the method --grasp-only runs: accepted, the harness is reached."""
    from compass_manip.sim import certify

    reached = []

    def stop(*a, **k):
        reached.append(a)
        raise CompassInputError("reached the scene")

    monkeypatch.setattr(certify, "certified_scene", stop)
    _one_line_exit_2(RUN + ["--grasp-only", "--method", "compass"], capsys, "reached the scene")
    assert reached == [(1, 0, 0)]


def test_demo_names_its_own_index_option(capsys, no_work):
    _one_line_exit_2(["demo", "--index", "-1"], capsys, "--index -1 is not allowed")


def test_scenes_empty_out_is_refused_not_ignored(capsys, no_work):
    _one_line_exit_2(["scenes", "1", "--count", "1", "--out", ""], capsys, "--out is empty")


@pytest.mark.parametrize("extra, needle", [
    (["--wall-cap", "inf"], "wall-time cap inf s is not allowed"),
    (["--wall-cap", "1e9"], "up to 604800"),
    (["--db", ""], "results store '' is not allowed"),
    (["--trial-fn", "os:getcwd"], "trial function 'os:getcwd' cannot take one spec"),
    (["--trial-fn", "compass_manip.bench.synthetic:SyntheticConfig"], "is a type, not a function"),
    (["--trial-fn", "compass_manip.bench.sweep:LEVELS"], "is a tuple, not a function"),
])
def test_bench_bad_input_before_the_store(extra, needle, capsys, tmp_path):
    db = tmp_path / "r.sqlite"
    argv = ["bench", "--methods", "fv", "--scenes", "1", "--trials", "1", "--no-progress", "--db", str(db),
            "--trial-fn", SYNTHETIC, *extra]
    _one_line_exit_2(argv, capsys, needle)
    assert not db.exists()


@pytest.mark.parametrize("cap", [math.inf, math.nan, -1.0, 0.0, 7 * 24 * 3600.0 + 1])
def test_sweep_config_wall_cap(cap):
    with pytest.raises(CompassInputError, match="wall-time cap"):
        validate(SweepConfig(methods=("fv",), wall_cap_s=cap), methods=["fv"])


def test_sweep_config_accepts_a_day_long_cap():
    validate(SweepConfig(methods=("fv",), wall_cap_s=86400.0), methods=["fv"])


def test_trial_functions_that_take_one_spec_are_accepted():
    assert resolve_trial_fn(SYNTHETIC).__name__ == "synthetic_trial"
    assert resolve_trial_fn(sweep.REAL_TRIAL_FN) is sweep.real_trial


def _store_with_a_row(path) -> None:
    with ResultsStore(str(path), create=True) as s:
        s.add(TrialRecord("fv", 1, 0, 0, 0, False, "target_not_found", None, SYNTHETIC, {"a": 1}, {"b": 2}, 0.1))


@pytest.mark.parametrize("path, needle", [
    ("", "results store '' is not allowed"),
    (":memory:", "results store ':memory:' is not allowed"),
    (None, "results store None is not allowed"),
    (3, "results store 3 is not allowed"),
])
def test_results_store_refuses_paths_that_are_not_files(path, needle):
    with pytest.raises(CompassInputError, match=needle):
        ResultsStore(path, create=True)


def test_results_store_names_an_empty_file_and_a_row_with_bad_json(tmp_path, capsys):
    empty = tmp_path / "empty.sqlite"
    empty.write_bytes(b"")
    with pytest.raises(CompassInputError, match="is empty"):
        ResultsStore(str(empty))
    db = tmp_path / "r.sqlite"
    _store_with_a_row(db)
    con = sqlite3.connect(db)
    con.execute("UPDATE trials SET result_json = '{cut'")
    con.commit()
    con.close()
    with ResultsStore(str(db)) as s, pytest.raises(CompassInputError, match=r"trial \('fv', 1, 0, 0, 0\) holds no "
                                                                             "valid JSON"):
        s.records()
    out = tmp_path / "report"
    _one_line_exit_2(["report", str(db), "--out", str(out)], capsys, "holds no valid JSON")
    assert not out.exists()


def test_a_store_that_cannot_be_written_is_refused_for_a_sweep_but_read_for_a_report(tmp_path, monkeypatch):
    """A read-only file (simulated with SQLite's read-only mode, which root cannot bypass):
    `compass bench` used to run the first trial and then die with a traceback storing it."""
    from compass_manip.bench import store as store_mod

    db = tmp_path / "r.sqlite"
    _store_with_a_row(db)
    connect = sqlite3.connect
    monkeypatch.setattr(store_mod.sqlite3, "connect",
                        lambda path, **kw: connect(f"file:{path}?mode=ro", uri=True, **kw))
    with pytest.raises(CompassInputError, match="cannot be written .*readonly"):
        ResultsStore(str(db), create=True)
    with ResultsStore(str(db)) as s:
        assert [r.key for r in s.records()] == [("fv", 1, 0, 0, 0)]


@pytest.mark.parametrize("extra, needle", [
    (["--video", "clip.avi"], "--video 'clip.avi' is not allowed"),
    (["--record", "rec.mp4"], "--record 'rec.mp4' is not allowed"),
])
def test_a_bad_media_name_leaves_no_out_folder_behind(extra, needle, capsys, no_work, tmp_path):
    out = tmp_path / "new"
    _one_line_exit_2(RUN + ["--out", str(out), *extra], capsys, needle)
    assert not out.exists()


def test_run_sweep_refuses_a_trial_function_that_takes_no_spec(tmp_path):
    from compass_manip.bench.runner import run_sweep

    db = tmp_path / "r.sqlite"
    for bad in (42, print.__self__, lambda: None):
        with pytest.raises(CompassInputError, match="trial function"):
            run_sweep(SweepConfig(methods=("fv",), scenes=1, trials=1), str(db), trial_fn=bad, progress=False)
    assert not db.exists()
