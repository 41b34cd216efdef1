"""The results store: rows round-trip, keys are unique, foreign and other-version files are refused."""
from __future__ import annotations

import sqlite3

import pytest

from compass_manip.bench import store as store_mod
from compass_manip.bench.store import SCHEMA_VERSION, ResultsStore, TrialRecord
from compass_manip.errors import CompassInputError


def _record(method="compass", level=1, scene=0, trial=0, seed=0, success=True, result=None):
    return TrialRecord(method, level, scene, trial, seed, success=success, failure=None if success else "grasp_failed",
                       error=None, trial_fn="tests:fake", config={"method": method, "nested": {"a": [1, 2]}},
                       result=result if result is not None else {"tft_s": 12.5, "explored_curve": [[0.0, 0.1]]},
                       wall_s=0.25)


def test_round_trip_and_done_keys(tmp_path):
    path = str(tmp_path / "r.sqlite")
    with ResultsStore(path, create=True) as s:
        s.add(_record())
        s.add(_record(method="fv", scene=3, trial=2, seed=7, success=False))
    with ResultsStore(path) as s:
        assert s.done_keys() == {("compass", 1, 0, 0, 0), ("fv", 1, 3, 2, 7)}
        recs = {r.method: r for r in s.records()}
        assert s.meta["schema_version"] == str(SCHEMA_VERSION)
    assert recs["compass"].config == {"method": "compass", "nested": {"a": [1, 2]}}
    assert recs["compass"].result["explored_curve"] == [[0.0, 0.1]]
    assert recs["fv"].success is False and recs["fv"].failure == "grasp_failed"
    assert recs["fv"].finished_at > 0


def test_duplicate_key_is_refused(tmp_path):
    with ResultsStore(str(tmp_path / "r.sqlite"), create=True) as s:
        s.add(_record())
        with pytest.raises(sqlite3.IntegrityError):
            s.add(_record(success=False))
        assert s.count() == 1


def test_missing_file_is_refused_for_reading(tmp_path):
    with pytest.raises(CompassInputError, match="does not exist"):
        ResultsStore(str(tmp_path / "nope.sqlite"))


def test_not_a_store_is_refused(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("this is not a database\n" * 20)
    with pytest.raises(CompassInputError, match="not a compass results store"):
        ResultsStore(str(text))
    other = tmp_path / "other.sqlite"
    con = sqlite3.connect(other)
    con.execute("CREATE TABLE t (x)")
    con.commit()
    con.close()
    with pytest.raises(CompassInputError, match="not a compass results store"):
        ResultsStore(str(other), create=True)


def test_other_schema_version_is_refused(tmp_path):
    path = str(tmp_path / "r.sqlite")
    ResultsStore(path, create=True).close()
    con = sqlite3.connect(path)
    con.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION + 1),))
    con.commit()
    con.close()
    with pytest.raises(CompassInputError, match=f"schema version {SCHEMA_VERSION + 1}"):
        ResultsStore(path)


def test_other_code_version_is_refused_for_writing_only(tmp_path, monkeypatch):
    path = str(tmp_path / "r.sqlite")
    with ResultsStore(path, create=True) as s:
        s.add(_record())
    monkeypatch.setattr(store_mod, "__version__", "99.0.0")
    with pytest.raises(CompassInputError, match="not mixed"):
        ResultsStore(path, create=True)
    with ResultsStore(path) as s:  # reading for a report is fine
        assert s.count() == 1


def test_unwritable_location_is_refused(tmp_path):
    with pytest.raises(CompassInputError, match="does not exist"):
        ResultsStore(str(tmp_path / "no" / "such" / "dir.sqlite"), create=True)
    with pytest.raises(CompassInputError, match="directory"):
        ResultsStore(str(tmp_path), create=True)
