"""`compass run`: bad input gets one error line and exit 2 before any work; a trial prints
its metrics as JSON and writes its outputs."""
import json

import pytest

from compass_manip.cli import main


@pytest.mark.parametrize("argv, message", [
    (["--method", "nope", "--level", "1", "--scene", "0"], "not registered; use one of compass, compass-no-nfa"),
    (["--level", "5", "--scene", "0"], "level 5 is not allowed"),
    (["--level", "1", "--scene", "-2"], "scene -2 is not allowed"),
    (["--level", "1", "--scene", "0", "--seed", "-1"], "seed -1 is not allowed"),
    (["--level", "1", "--scene", "0", "--trial", "-3"], "trial -3 is not allowed"),
    (["--level", "1", "--scene", "0", "--seed", str(2**63)], f"seed {2**63} is not allowed"),  # as `scenes`
])
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys):
    assert main(["run", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_bad_out_is_rejected_before_the_trial(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["run", "--level", "1", "--scene", "0", "--out", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is an existing file, not a folder" in err[0]


def test_run_prints_json_and_writes_outputs(tmp_path, capsys):
    out = tmp_path / "trial"
    assert main(["run", "--method", "compass", "--level", "1", "--scene", "1", "--json", "--find-only",
                 "--out", str(out)]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["method"] == "compass" and rec["level"] == 1 and rec["scene"] == 1
    assert rec["success"] is True and rec["found"] is True and rec["collisions"] == 0 and rec["grasp_s"] is None
    for name in ("result.json", "camera_path.png", "explored.png"):
        assert (out / name).stat().st_size > 0, name
    saved = json.loads((out / "result.json").read_text())
    assert saved["result"]["tft_s"] == rec["tft_s"] and "method" in saved["config"]


def test_grasp_only_rejects_find_only_and_out(capsys):
    assert main(["run", "--level", "1", "--scene", "0", "--grasp-only", "--find-only"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--grasp-only does not take --find-only;" in err[0]


def test_grasp_only_prints_one_labelled_record(capsys):
    assert main(["run", "--grasp-only", "--level", "1", "--scene", "1", "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["start"] == "oracle view (ground truth)" and rec["constrained"] is True
    assert rec["level"] == 1 and rec["scene"] == 1 and rec["view_found"] is True and rec["n_target_points"] > 10
    assert isinstance(rec["success"], bool) and rec["collisions"] == []
    assert (rec["selection_failure"] is None) == (rec["commanded_lift_m"] is not None)
