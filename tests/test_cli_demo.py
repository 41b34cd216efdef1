"""`compass demo`: one Level-4 COMPASS trial end to end, outputs written and listed."""
import json

from compass_manip.cli import main


def test_demo_runs_a_level4_trial_and_writes_outputs(tmp_path, capsys):
    out = tmp_path / "demo"
    # a short time limit keeps the test fast; `make demo` runs the full 200 s
    assert main(["demo", "--level", "4", "--out", str(out), "--json", "--time-limit", "15"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["level"] == 4 and rec["method"] == "compass" and rec["decisions"] >= 1
    assert 0 < rec["tft_s"] <= 15
    for key, name in (("json", "result.json"), ("camera_path", "camera_path.png"), ("explored", "explored.png"),
                      ("video", "trial.mp4")):
        assert rec["outputs"][key].endswith(name) and (out / name).stat().st_size > 0


def test_demo_prints_where_the_outputs_are(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["demo", "--level", "1", "--index", "1", "--out", str(out), "--time-limit", "5", "--no-video"]) == 0
    text = capsys.readouterr().out
    assert "outputs in" in text and "camera_path.png" in text
    assert "trial.mp4" not in text and not (out / "trial.mp4").exists()
    verdict = json.load(open(out / "result.json"))["result"]
    first = text.splitlines()[0]
    if verdict["success"]:
        assert "and grasped it" in first
    elif verdict["found"]:  # the find is reported even when the grasp fails after it
        assert f"found the target at {verdict['tft_s']:.1f} s, then failed: {verdict['failure']}" in first
    else:
        assert f"failed: {verdict['failure']}" in first and "found" not in first


def test_demo_rejects_bad_input(capsys):
    assert main(["demo", "--level", "9"]) == 2
    assert "level 9 is not allowed" in capsys.readouterr().err
    assert main(["demo", "--time-limit", "0"]) == 2
    assert "--time-limit 0.0 s is not allowed" in capsys.readouterr().err
