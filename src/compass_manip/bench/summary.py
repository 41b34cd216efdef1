"""The report's tables from stored trials: Table I, the ablations, failures, the run itself.

Means carry a 95 % Student-t interval over trials; rates (SR, DSR, grasp SR) a 95 % Wilson
interval. A metric's mean is over the trials that report it (runner failures have no
result; GPQ is null until a grasp is selected); SR counts every trial, runner failures as
failures. TFT is as the trial records it (the trial scores not-found at its time limit).
"""
from __future__ import annotations

from collections import Counter, defaultdict
from dataclasses import dataclass

import numpy as np

from .intervals import Estimate, mean_t95, wilson95
from .stats import median_p90
from .store import TrialRecord
from .table import Table, best_indices, fmt_count, fmt_mean, fmt_rate

#: Table I's methods in the paper's column order; other main methods follow alphabetically.
METHOD_ORDER = ("fv", "ig", "gse", "compass")
NFA_ABLATION = "compass-no-nfa"
GRASP_ABLATION = "compass-no-grasp-constraints"
#: COMPASS under the baselines' motion rule (unknown space near the base counts as free)
RULE_ABLATION = "compass-baseline-rule"
ABLATIONS = (NFA_ABLATION, GRASP_ABLATION, RULE_ABLATION)
SUCCESS = "success"
#: rate rows: the share of trials whose result has this key true (FOUND: a true detection)
FOUND = "found"
RATES = (SUCCESS, FOUND)


@dataclass(frozen=True)
class Metric:
    """A Table I row: `key` in the trial result (SUCCESS / FOUND: the share of all trials
    that succeeded end to end / found the target)."""

    label: str
    key: str
    higher_is_better: bool
    scale: float = 1.0
    digits: int = 1


TABLE_ONE = (
    Metric("TFT (s) ↓", "tft_s", False),
    Metric("PFT (m) ↓", "pft_m", False, digits=2),
    Metric("MPSR (%) ↑", "mpsr", True, scale=100.0),
    Metric("AM ↑", "am", True, digits=3),
    Metric("GPQ ↑", "gpq", True, digits=3),
    Metric("Found (%) ↑", FOUND, True),
    Metric("SR (%) ↑", SUCCESS, True),
)

Groups = dict  # (method, level) -> list[TrialRecord]


def group(records: list[TrialRecord]) -> Groups:
    out: Groups = defaultdict(list)
    for r in records:
        out[(r.method, r.level)].append(r)
    return dict(out)


def order_methods(methods) -> list[str]:
    """Paper order first (fv, ig, gse, compass), then the rest alphabetically."""
    methods = set(methods)
    return [m for m in METHOD_ORDER if m in methods] + sorted(methods - set(METHOD_ORDER))


def estimate(recs: list[TrialRecord], metric: Metric) -> Estimate:
    if metric.key == SUCCESS:
        return wilson95(sum(r.success for r in recs), len(recs))
    if metric.key == FOUND:
        return wilson95(sum(bool(r.result and r.result.get(FOUND)) for r in recs), len(recs))
    return mean_t95(r.result.get(metric.key) for r in recs if r.result is not None)


def _text(e: Estimate, metric: Metric) -> str:
    if metric.key in RATES:
        return fmt_rate(e)
    return fmt_mean(e, metric.scale, metric.digits)


def table_one(records: list[TrialRecord]) -> Table | None:
    """Metric rows × (level, method) columns, the best mean per level in bold; None without main methods."""
    groups = group(records)
    methods = order_methods({m for m, _ in groups if m not in ABLATIONS})
    levels = sorted({lv for _, lv in groups})
    if not methods:
        return None
    columns = [(lv, m) for lv in levels for m in methods]
    rows, bold = [], set()
    for i, metric in enumerate(TABLE_ONE):
        ests = [estimate(groups.get((m, lv), []), metric) for lv, m in columns]
        rows.append((metric.label, *(_text(e, metric) for e in ests)))
        for lv in levels:
            idx = [j for j, c in enumerate(columns) if c[0] == lv]
            for k in best_indices([ests[j].value if ests[j].n else None for j in idx], metric.higher_is_better):
                bold.add((i, 1 + idx[k]))
    return Table("Table I: all methods by difficulty level", ("Metric", *(f"L{lv} {m}" for lv, m in columns)),
                 tuple(rows), frozenset(bold), notes=(
                     "Cells: mean ± 95 % Student-t half-width (n trials); SR: rate [95 % Wilson interval] (n).",
                     "Bold: best mean of its level (↓ lower is better, ↑ higher is better).",
                     "MPSR is each trial's planning success fraction, averaged over trials.",
                     "Means are over trials that report the metric; SR counts every trial "
                     "(runner errors and wall-time kills as failures)."))


def _metric_column(key: str):
    """An ablation column (label, cell function) of Table I's metric `key`, as Table I shows it."""
    metric = next(m for m in TABLE_ONE if m.key == key)
    return metric.label, lambda recs: _text(estimate(recs, metric), metric)


#: MC: trials with a ground-truth collision, over trials with a result
_COLLISION_COLUMN = ("MC ↓", lambda recs: fmt_count(
    sum(1 for r in recs if r.result and (r.result.get("collisions") or 0) > 0), sum(1 for r in recs if r.result)))


def _variant_rows(groups: Groups, base: str, ablation: str, columns) -> tuple[tuple, ...]:
    rows = []
    for lv in sorted({lv for m, lv in groups if m in (base, ablation)}):
        for m in (base, ablation):
            recs = groups.get((m, lv), [])
            if recs:
                rows.append((f"L{lv}", m, *(fn(recs) for _, fn in columns)))
    return tuple(rows)


def _absent(present: set, base: str, ablation: str) -> str | None:
    missing = [m for m in (base, ablation) if m not in present]
    return f"Absent from this results file: {', '.join(missing)}." if missing else None


def ablation_nfa(records: list[TrialRecord]) -> Table:
    """compass vs compass-no-nfa: MPSR, detection success rate (DSR), SR per level."""
    groups = group(records)
    with_result = lambda recs: [r for r in recs if r.result is not None]  # noqa: E731
    columns = [
        _metric_column("mpsr"),
        ("DSR (%) ↑", lambda recs: fmt_rate(wilson95(sum(r.result.get("true_detection") is True
                                                         for r in with_result(recs)), len(with_result(recs))))),
        _metric_column(SUCCESS),
    ]
    notes = ["DSR: trials whose accepted detection was the true target, over trials with a result."]
    absent = _absent({m for m, _ in groups}, "compass", NFA_ABLATION)
    return Table("Ablation: without the near-field scan", ("Level", "Method", *(c for c, _ in columns)),
                 _variant_rows(groups, "compass", NFA_ABLATION, columns), notes=tuple(notes + ([absent] if absent else [])))


def ablation_grasp(records: list[TrialRecord]) -> Table:
    """compass vs compass-no-grasp-constraints: SR, grasp SR, motion collisions, failure counts."""
    groups = group(records)
    subset = [r for r in records if r.method in ("compass", GRASP_ABLATION)]
    reasons = sorted({r.failure for r in subset if r.failure is not None})
    columns = [
        _metric_column(SUCCESS),
        ("Grasp SR (%) ↑", lambda recs: fmt_rate(wilson95(
            sum(r.success for r in recs if r.result and r.result.get("gpq") is not None),
            sum(1 for r in recs if r.result and r.result.get("gpq") is not None)))),
        _COLLISION_COLUMN,
    ] + [(f"{reason} ↓", lambda recs, reason=reason: fmt_count(sum(r.failure == reason for r in recs), len(recs)))
         for reason in reasons]
    notes = ["Grasp SR: successes over trials that selected a grasp (GPQ recorded); "
             "MC: trials with a ground-truth collision, over trials with a result; then each failure reason."]
    absent = _absent({m for m, _ in groups}, "compass", GRASP_ABLATION)
    return Table("Ablation: without grasp constraints", ("Level", "Method", *(c for c, _ in columns)),
                 _variant_rows(groups, "compass", GRASP_ABLATION, columns), notes=tuple(notes + ([absent] if absent else [])))


def ablation_rule(records: list[TrialRecord]) -> Table | None:
    """compass vs compass-baseline-rule (the same method on the baselines' motion rule): what
    the near-field safety rule costs and buys, per level; None when the file holds no
    compass-baseline-rule trial."""
    groups = group(records)
    if not any(m == RULE_ABLATION for m, _ in groups):
        return None
    columns = [_metric_column("tft_s"), _metric_column(FOUND), _metric_column(SUCCESS), _COLLISION_COLUMN]
    notes = ["compass-baseline-rule: COMPASS with unknown space outside the confined space counted as free, "
             "Omega_safe included (the baselines' rule); compass keeps unknown space inside Omega_safe unsafe.",
             "MC: trials with a ground-truth collision, over trials with a result."]
    absent = _absent({m for m, _ in groups}, "compass", RULE_ABLATION)
    return Table("Ablation: the near-field motion rule", ("Level", "Method", *(c for c, _ in columns)),
                 _variant_rows(groups, "compass", RULE_ABLATION, columns), notes=tuple(notes + ([absent] if absent else [])))


def failure_breakdown(records: list[TrialRecord]) -> Table:
    """Trials per method and level by how they ended: success or each failure reason."""
    groups = group(records)
    reasons = sorted({r.failure or "failed (no reason)" for r in records if not r.success})
    rows = []
    for m in order_methods({m for m, _ in groups}):
        for lv in sorted({lv for mm, lv in groups if mm == m}):
            recs = groups[(m, lv)]
            c = Counter(r.failure or "failed (no reason)" for r in recs if not r.success)
            rows.append((m, f"L{lv}", str(len(recs)), str(sum(r.success for r in recs)), *(str(c[x]) for x in reasons)))
    return Table("Failure reasons by method and level", ("Method", "Level", "Trials", SUCCESS, *reasons), tuple(rows),
                 notes=("runner_error: the trial raised (text in the store); wall_time_exceeded: killed at the "
                        "sweep's wall-time cap; worker_died: its process died.",))


def run_overview(records: list[TrialRecord]) -> Table:
    """What was run: trials per method, the trial functions, wall time per trial."""
    by_method = defaultdict(list)
    for r in records:
        by_method[r.method].append(r)
    rows = []
    for m in order_methods(by_method):
        recs = by_method[m]
        w = median_p90([r.wall_s for r in recs], digits=2)
        rows.append((m, str(len(recs)), ", ".join(str(x) for x in sorted({r.level for r in recs})),
                     str(len({(r.level, r.scene) for r in recs})), ", ".join(str(x) for x in sorted({r.seed for r in recs})),
                     ", ".join(sorted({r.trial_fn for r in recs})),
                     f"{w['median']} / {w['p90']}", f"{np.sum([r.wall_s for r in recs]) / 3600:.2f}"))
    return Table("Trials run", ("Method", "Trials", "Levels", "Scenes", "Base seeds", "Trial function",
                                "Wall s median / p90",
                                "Wall h total"), tuple(rows))
