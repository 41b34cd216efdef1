"""The report from a small hand-made results file: Table I's shape and numbers, ablations, failures, HTML."""
from __future__ import annotations

import base64
import math
import re

import numpy as np
import pytest
from scipy import stats

from compass_manip.bench.intervals import Z95, mean_t95, wilson95
from compass_manip.bench.report import write_report
from compass_manip.bench.store import ResultsStore, TrialRecord
from compass_manip.bench.summary import ablation_grasp, ablation_nfa, ablation_rule, failure_breakdown, table_one
from compass_manip.viz.plots import resample_curve

TFT = {("fv", 1): [10.0, 20.0, 30.0], ("compass", 1): [5.0, 6.0, 7.0],
       ("fv", 2): [50.0, 60.0, 70.0], ("compass", 2): [80.0, 90.0, 100.0],
       ("compass-no-nfa", 2): [100.0, 110.0, 120.0]}


def _records() -> list[TrialRecord]:
    out = []
    for (m, lv), tfts in TFT.items():
        for t, tft in enumerate(tfts):
            success = (m == "compass" and t < 2) or (m == "fv" and t == 0)
            failure = None if success else ("target_not_found" if t == 2 else "grasp_failed")
            result = {"method": m, "level": lv, "scene": 0, "trial": t, "seed": 0, "success": success,
                      "failure": failure, "tft_s": tft, "pft_m": tft / 10, "mpsr": 0.5 + 0.1 * t, "am": 0.05,
                      "gpq": None if m == "fv" else 0.6, "collisions": int(t == 1),
                      "explored_curve": [[0.0, 0.0], [tft / 2, 0.3], [tft, 0.6]], "decisions": 3,
                      "planning_ms_median": 1.0, "planning_ms_p90": 2.0, "wall_s": 1.0,
                      "true_detection": t < 2 if m != "fv" else None, "found": t < 2}
            out.append(TrialRecord(m, lv, 0, t, 0, success, failure, None, "tests:hand", {"method": m}, result, 1.0))
    out.append(TrialRecord("compass", 2, 1, 0, 0, False, "runner_error", "RuntimeError: boom", "tests:hand",
                           None, None, 0.1))
    return out


def test_intervals_against_scipy_and_hand_values():
    assert Z95 == pytest.approx(stats.norm.ppf(0.975), abs=1e-12)
    e = mean_t95([10.0, 20.0, 30.0])
    assert e.value == 20.0 and e.n == 3
    assert e.half_width == pytest.approx(stats.t.ppf(0.975, 2) * 10.0 / math.sqrt(3))
    lo, hi = stats.binomtest(3, 10).proportion_ci(0.95, method="wilson")
    w = wilson95(3, 10)
    assert (w.lo, w.hi, w.value) == (pytest.approx(lo), pytest.approx(hi), 0.3)
    assert wilson95(0, 5).lo == 0.0 and wilson95(5, 5).hi == 1.0 and 0.5 < wilson95(5, 5).lo < 1.0
    assert mean_t95([None, 4.0]).n == 1 and math.isnan(mean_t95([4.0]).half_width)
    assert mean_t95([]).n == 0


def test_table_one_shape_numbers_and_bold():
    t = table_one(_records())
    assert t.header == ("Metric", "L1 fv", "L1 compass", "L2 fv", "L2 compass")  # ablations are not Table I columns
    assert [r[0] for r in t.rows] == ["TFT (s) ↓", "PFT (m) ↓", "MPSR (%) ↑", "AM ↑", "GPQ ↑", "Found (%) ↑",
                                      "SR (%) ↑"]
    tft = t.rows[0]
    half = stats.t.ppf(0.975, 2) * 10.0 / math.sqrt(3)
    assert tft[1] == f"20.0 ± {half:.1f} (3)" and tft[2] == "6.0 ± 2.5 (3)"
    assert (0, 2) in t.bold and (0, 1) not in t.bold  # L1: compass is faster
    assert (0, 3) in t.bold and (0, 4) not in t.bold  # L2: fv is faster
    assert t.rows[4][1] == "–" and t.rows[4][2].startswith("0.600 ± 0.000 (3)")  # fv has no GPQ
    found = t.rows[5]  # fv L1: found in 2 of 3 trials but succeeded in 1 (found counts without the grasp)
    w = wilson95(2, 3)
    assert found[1] == f"66.7 [{100 * w.lo:.1f}–{100 * w.hi:.1f}] (3)"
    sr = t.rows[6]
    assert sr[1].startswith("33.3 [")
    w = wilson95(2, 4)  # compass L2: 2 of 3 trials, plus the runner error counts as a failure
    assert sr[4] == f"50.0 [{100 * w.lo:.1f}–{100 * w.hi:.1f}] (4)"
    assert found[4] == sr[4]  # the runner error has no result: not found
    assert (6, 2) in t.bold and t.rows[2][2] == "60.0 ± 24.8 (3)"  # MPSR in percent


def test_markdown_table_has_the_table_one_layout(tmp_path):
    db = str(tmp_path / "r.sqlite")
    with ResultsStore(db, create=True) as s:
        for r in _records():
            s.add(r)
    files = write_report(db, str(tmp_path / "out"))
    md = open(files.markdown).read()
    block = md.split("### Table I")[1].split("\n\n")[1].strip().splitlines()
    assert len(block) == 2 + 7  # header, separator, seven metric rows
    assert all(line.count("|") == 6 for line in block)  # Metric + 2 levels × 2 methods
    assert re.search(r"\| TFT \(s\) ↓ \| 20\.0 ± 24\.8 \(3\) \| \*\*6\.0 ± 2\.5 \(3\)\*\* \|", md)
    assert "Absent from this results file: compass-no-grasp-constraints." in md
    assert "compass-no-nfa" in md.split("### Ablation: without the near-field scan")[1].split("###")[0]
    assert "Student-t" in md and "Wilson" in md
    html = open(files.html).read()
    uris = re.findall(r"src='data:image/png;base64,([A-Za-z0-9+/=]+)'", html)
    assert len(uris) == 3 and all(base64.b64decode(u)[:8] == b"\x89PNG\r\n\x1a\n" for u in uris)
    assert "<b>6.0 ± 2.5 (3)</b>" in html and "http" not in html.split("<body>")[1]  # nothing fetched


def test_ablation_and_failure_tables():
    recs = _records()
    nfa = ablation_nfa(recs)
    assert [r[:2] for r in nfa.rows] == [("L1", "compass"), ("L2", "compass"), ("L2", "compass-no-nfa")]
    assert nfa.rows[1][3].startswith("66.7 [") and nfa.rows[1][3].endswith("(3)")  # DSR 2/3 over trials with a result
    assert not any("Absent" in n for n in nfa.notes)
    grasp = ablation_grasp(recs)
    assert any("Absent from this results file: compass-no-grasp-constraints." in n for n in grasp.notes)
    assert grasp.header[2:5] == ("SR (%) ↑", "Grasp SR (%) ↑", "MC ↓")
    assert grasp.rows[1][4] == "1/3" and "runner_error ↓" in grasp.header
    assert ablation_rule(recs) is None  # no compass-baseline-rule trial: no table
    rule_recs = recs + [TrialRecord("compass-baseline-rule", 1, 0, t, 0, t == 0, None if t == 0 else "collision", None,
                                    "tests:hand", None, {"tft_s": 4.0 + t, "found": True, "collisions": t}, 1.0)
                        for t in range(2)]
    rule = ablation_rule(rule_recs)
    assert [r[:2] for r in rule.rows] == [("L1", "compass"), ("L1", "compass-baseline-rule"), ("L2", "compass")]
    assert rule.header[2:] == ("TFT (s) ↓", "Found (%) ↑", "SR (%) ↑", "MC ↓")
    assert rule.rows[1][2].startswith("4.5 ± ") and rule.rows[1][3].startswith("100.0 [") and rule.rows[1][5] == "1/2"
    assert rule.rows[0][5] == "1/3" and "compass-baseline-rule" not in table_one(rule_recs).header[-1]
    fb = failure_breakdown(recs)
    assert fb.header == ("Method", "Level", "Trials", "success", "grasp_failed", "runner_error", "target_not_found")
    row = {(r[0], r[1]): r for r in fb.rows}[("compass", "L2")]
    assert row[2:] == ("4", "2", "0", "1", "1")
    assert sum(int(r[2]) for r in fb.rows) == len(recs)


def test_resample_curve_holds_values():
    grid = np.array([0.0, 0.5, 1.0, 2.5, 10.0])
    y = resample_curve([[1.0, 0.2], [2.0, 0.5], [0.5, 0.1]], grid)
    np.testing.assert_allclose(y, [0.0, 0.1, 0.2, 0.5, 0.5])
    np.testing.assert_allclose(resample_curve([], grid), 0.0)


def test_report_of_only_failed_ablation_trials_still_renders(tmp_path):
    db = str(tmp_path / "r.sqlite")
    with ResultsStore(db, create=True) as s:
        for t in range(2):
            s.add(TrialRecord("compass-no-nfa", 3, 0, t, 0, False, "wall_time_exceeded", "killed", "tests:hand",
                              None, None, 900.0))
    files = write_report(db, str(tmp_path / "out"))
    md = open(files.markdown).read()
    assert "No main method" in md and "Absent from this results file: compass." in md
    assert "| compass-no-nfa | L3 | 2 | 0 | 2 |" in md
    assert open(files.html).read().count("data:image/png;base64,") == 3


def test_the_grasp_ablation_the_report_reads_is_a_runnable_trial_method():
    from compass_manip.bench.summary import GRASP_ABLATION, NFA_ABLATION
    from compass_manip.trial.config import GRASP_ABLATION_METHOD
    from compass_manip.trial.runner import trial_methods

    assert GRASP_ABLATION == GRASP_ABLATION_METHOD
    from compass_manip.bench.summary import RULE_ABLATION

    assert {GRASP_ABLATION, NFA_ABLATION, RULE_ABLATION} <= set(trial_methods())
