"""The `compass scenes` command as a user runs it."""
import json
import os
import subprocess
import sys

import pytest

from compass_manip.cli import main

KEYS = {"level", "index", "seed", "certified", "start_visibility", "view_visibility_fraction", "free_config_fraction"}


def _run(*args):
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    return subprocess.run([sys.executable, "-m", "compass_manip.cli", *args], capture_output=True, text=True, env=env,
                          timeout=300)


def test_json_output(capsys):
    assert main(["scenes", "2", "--count", "2", "--seed", "4", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == 2 and KEYS <= set(rows[0])
    assert [r["index"] for r in rows] == [0, 1] and all(r["certified"] for r in rows)
    assert all(r["level"] == 2 and r["seed"] == 4 for r in rows)


def test_table_and_files(tmp_path, capsys):
    assert main(["scenes", "3", "--count", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "view_vis_frac" in out and "free_cfg_frac" in out
    names = sorted(os.listdir(tmp_path))
    assert names == ["level3_000.json", "level3_000_overview.png", "level3_000_start_camera.png"]
    record = json.loads((tmp_path / "level3_000.json").read_text())
    assert record["scene"]["level"] == 3 and record["certificate"]["certified"] is True
    for png in names[1:]:
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args,needle", [
    (["scenes", "7"], "level '7' is not allowed"),
    (["scenes", "1", "--count", "0"], "--count 0 is not allowed"),
    (["scenes", "1", "--seed", "-2"], "--seed -2 is not allowed"),
    (["scenes", "1", "--count", "many"], "invalid int value"),
])
def test_bad_input_one_line_no_traceback(args, needle):
    r = _run(*args)
    assert r.returncode == 2
    assert needle in r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
