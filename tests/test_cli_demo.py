"""`compass demo`: the end-to-end path a new user runs first."""
import json
import os

from compass_manip.cli import main


def test_demo_writes_outputs(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--level", "4", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["certified"] and summary["scan_completed"] and summary["contacts"] == 0
    assert summary["frames"] >= 5
    assert summary["voxels_occupied"] > 1000 and summary["voxels_free"] > 10000
    # the target is hidden at the start and the wrist scan alone does not reveal it (level 4)
    assert summary["target_pixels_seen"] == 0
    for name in ("overview.png", "map.png", "map.bt", "summary.json"):
        assert (out / name).stat().st_size > 0, name
    assert len(os.listdir(out / "frames")) == summary["frames"]


def test_demo_rejects_bad_level(capsys):
    assert main(["demo", "--level", "9"]) == 2
    assert "level 9 is not allowed" in capsys.readouterr().err
