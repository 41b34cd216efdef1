"""`compass demo`: one Level-4 COMPASS trial end to end, outputs written and listed."""
import json

from compass_manip.cli import main


def test_demo_runs_a_level4_trial_and_writes_outputs(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--level", "4", "--out", str(out), "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["level"] == 4 and rec["method"] == "compass" and rec["decisions"] >= 1
    assert 0 < rec["tft_s"] <= 200
    for key, name in (("json", "result.json"), ("camera_path", "camera_path.png"), ("explored", "explored.png")):
        assert rec["outputs"][key].endswith(name) and (out / name).stat().st_size > 0


def test_demo_prints_where_the_outputs_are(tmp_path, capsys):
    assert main(["demo", "--level", "1", "--index", "1", "--out", str(tmp_path / "d")]) == 0
    text = capsys.readouterr().out
    assert "outputs in" in text and "camera_path.png" in text


def test_demo_rejects_bad_level(capsys):
    assert main(["demo", "--level", "9"]) == 2
    assert "level 9 is not allowed" in capsys.readouterr().err
