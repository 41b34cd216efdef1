"""The `compass scenes` command as a user runs it."""
import json
import os
import subprocess
import sys

import pytest

from compass_manip.cli import main

KEYS = {"level", "index", "seed", "certified", "start_visibility", "best_fixed_view_visibility", "fv_solvable",
        "view_visibility_fraction", "free_config_fraction", "views_removed_by_obstacles",
        "grasps_removed_by_obstacles", "grasp_approach_deg", "grasp_yaw_deg", "n_objects", "n_distractors", "attempts",
        "best_outside_view_visibility", "view_camera_outside_m"}


def _run(*args):
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    return subprocess.run([sys.executable, "-m", "compass_manip.cli", *args], capture_output=True, text=True, env=env,
                          timeout=300)


def test_json_output_and_the_cache_it_fills(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("COMPASS_CACHE_DIR", str(tmp_path))
    assert main(["scenes", "2", "--count", "1", "--seed", "4", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == 1 and KEYS <= set(rows[0])
    r = rows[0]
    assert r["index"] == 0 and r["certified"] and r["level"] == 2 and r["seed"] == 4
    assert r["n_objects"] >= 8 and r["n_distractors"] >= 2 and 0.0 <= r["grasp_approach_deg"] <= 90.0
    assert len(r["rejections"]) == r["attempts"] - 1 and abs(r["grasp_yaw_deg"]) <= 55.0
    assert r["best_outside_view_visibility"] < 0.3 and r["view_camera_outside_m"] <= 0.10  # a severe level
    # the command certifies afresh (it measures the time) and leaves the entry trials read
    from compass_manip.sim import scene_cache
    from compass_manip.sim.certify import CertifyConfig, certified_scene
    entry = scene_cache.entry_path(2, 0, 4, CertifyConfig())
    assert os.path.exists(entry)
    cached = certified_scene(2, 0, 4)
    assert list(cached.scene.seed) == r["sub_seed"] and cached.attempts == r["attempts"]


def test_table_files_and_contact_sheet(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COMPASS_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["scenes", "1", "--count", "1", "--seed", "3", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for column in ("start", "fv_best", "fv_ok", "out_best", "cam_out_m", "view_vis", "free_cfg", "v_rm", "g_rm", "appr°", "yaw°", "obj", "dis",
                   "time_s_p90"):
        assert column in out
    assert "fv_solvable" in out  # the per-level summary
    names = sorted(n for n in os.listdir(tmp_path) if n != "cache")
    assert names == ["level1_000.json", "level1_000_overview.png", "level1_000_start_camera.png",
                     "level1_contact_sheet.png"]
    record = json.loads((tmp_path / "level1_000.json").read_text())
    assert record["scene"]["level"] == 1 and record["certificate"]["certified"] is True
    assert record["certificate"]["failure"] is None and len(record["certificate"]["path"]) >= 4
    for png in names[1:]:
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args,needle", [
    (["scenes", "7"], "level '7' is not allowed"),
    (["scenes", "1.5"], "level '1.5' is not allowed"),
    (["scenes", "1", "--count", "0"], "--count 0 is not allowed"),
    (["scenes", "1", "--seed", "-2"], "--seed -2 is not allowed"),
    (["scenes", "1", "--seed", "x"], "invalid int value"),
    (["scenes", "1", "--count", "many"], "invalid int value"),
])
def test_bad_input_one_line_no_traceback(args, needle):
    r = _run(*args)
    assert r.returncode == 2
    assert needle in r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
