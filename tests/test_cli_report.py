"""`compass report` as a user runs it, and its bad input."""
from __future__ import annotations

import os
import sqlite3
import subprocess
import sys
from functools import partial

import pytest

from compass_manip.bench.runner import run_sweep
from compass_manip.bench.store import ResultsStore
from compass_manip.bench.sweep import SweepConfig
from compass_manip.bench.synthetic import SyntheticConfig, synthetic_trial
from compass_manip.cli import main

SRC = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "src")


def _run(*args):
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "compass_manip.cli", *args], capture_output=True, text=True, env=env,
                          timeout=120)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    db = str(tmp_path_factory.mktemp("r") / "r.sqlite")
    run_sweep(SweepConfig(methods=("fv", "compass"), levels=(1,), scenes=2, trials=2, workers=1), db,
              trial_fn=partial(synthetic_trial, config=SyntheticConfig()), progress=False)
    return db


def test_report_writes_markdown_html_and_plots(results, tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["report", results, "--out", str(out)]) == 0
    assert "8 trials ->" in capsys.readouterr().out
    assert sorted(os.listdir(out)) == ["explored_over_time.png", "report.html", "report.md", "success_rate.png",
                                       "tft_distributions.png"]
    assert (out / "report.html").read_text().count("data:image/png;base64,") == 3


def _bad_store(path) -> str:
    ResultsStore(str(path), create=True).close()
    con = sqlite3.connect(path)
    con.execute("UPDATE meta SET value = '999' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    return str(path)


def test_bad_input_one_line_exit_2(results, tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("plain text, not SQLite\n" * 40)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    empty = tmp_path / "empty.sqlite"
    ResultsStore(str(empty), create=True).close()
    cases = [
        ([str(text)], "is not a compass results store"),
        ([_bad_store(tmp_path / "v999.sqlite")], "schema version 999"),
        ([str(tmp_path / "missing.sqlite")], "does not exist"),
        ([str(empty)], "holds no trials yet"),
        ([results, "--out", str(blocker)], "is an existing file, not a folder"),
        ([results, "--out", str(blocker / "sub")], "lies under the file"),
    ]
    for args, needle in cases:
        r = _run("report", *args, "--out", str(tmp_path / "out")) if "--out" not in args else _run("report", *args)
        assert r.returncode == 2 and needle in r.stderr, (args, r.stderr)
        assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()  # nothing written for a bad results file
