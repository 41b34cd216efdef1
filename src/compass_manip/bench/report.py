"""`compass report`: report.md and a self-contained report.html (plots inlined) from a results store.

Contents: what was run, Table I (metric rows × level/method columns, best in bold, mean ±
95 % CI and n), the two ablation tables (whichever variants are present; absent ones are
named), failure reasons per method and level, and three PNG plots (explored fraction
over time, TFT distributions, success rates). The out directory is checked writable
before any work.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass

from ..errors import CompassInputError
from ..paths import check_output_dir
from .store import ResultsStore, TrialRecord
from .summary import ablation_grasp, ablation_nfa, ablation_rule, failure_breakdown, run_overview, table_one

SYNTHETIC_FN = "compass_manip.bench.synthetic:synthetic_trial"
PLOTS = (("explored_over_time.png", "Explored fraction over time per level (mean ± std per method)"),
         ("tft_distributions.png", "Time to find target per level and method"),
         ("success_rate.png", "Success rate per level with 95 % Wilson intervals"))


@dataclass(frozen=True)
class ReportFiles:
    markdown: str
    html: str
    plots: tuple[str, ...]
    n_trials: int


def load_records(db: str) -> tuple[list[TrialRecord], dict]:
    """Every trial of the store at `db` and its meta table; CompassInputError if it has none."""
    with ResultsStore(db) as store:
        records, meta = store.records(), dict(store.meta)
    if not records:
        raise CompassInputError(f"results store {db!r} holds no trials yet; run compass bench first")
    return records, meta


def build_blocks(records: list[TrialRecord], meta: dict, db: str, plot_paths: list[str]) -> list:
    """The report as blocks (see viz.report_html) shared by the Markdown and HTML renderings."""
    blocks: list = [("h1", "COMPASS benchmark report"),
                    ("p", f"Results store {os.path.basename(db)}: {len(records)} trials, schema version "
                          f"{meta.get('schema_version')}, written by compass-manip {meta.get('compass_manip_version')}; "
                          f"report made {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.")]
    synthetic = sum(r.trial_fn == SYNTHETIC_FN for r in records)
    if synthetic:
        blocks.append(("warn", f"{synthetic} of these {len(records)} trials come from the synthetic trial function "
                               "(no simulator): they test the sweep machinery and are not benchmark results."))
    blocks += [("table", run_overview(records)), ("h2", "Table I")]
    t1 = table_one(records)
    blocks.append(("table", t1) if t1 else ("p", "No main method (fv, ig, gse, compass or others) in this file."))
    blocks += [("h2", "Ablations"), ("table", ablation_nfa(records)), ("table", ablation_grasp(records))]
    rule = ablation_rule(records)
    if rule is not None:
        blocks.append(("table", rule))
    blocks += [("h2", "Failures"), ("table", failure_breakdown(records)), ("h2", "Plots")]
    blocks += [("img", p, caption) for p, (_, caption) in zip(plot_paths, PLOTS)]
    return blocks


def render_markdown(blocks, out: str) -> str:
    """report.md text: tables in GitHub Markdown, images linked by relative path."""
    parts = []
    for block in blocks:
        kind = block[0]
        if kind == "h1":
            parts.append(f"# {block[1]}\n")
        elif kind == "h2":
            parts.append(f"## {block[1]}\n")
        elif kind == "p":
            parts.append(f"{block[1]}\n")
        elif kind == "warn":
            parts.append(f"> **Warning:** {block[1]}\n")
        elif kind == "table":
            parts.append(block[1].markdown())
        elif kind == "img":
            parts.append(f"![{block[2]}]({os.path.relpath(block[1], out)})\n")
    return "\n".join(parts)


def write_report(db: str, out: str) -> ReportFiles:
    """Write report.md, report.html and the PNG plots for the results store `db` into `out`."""
    records, meta = load_records(db)
    check_output_dir(out)
    from ..viz.plots import plot_explored, plot_success, plot_tft  # noqa: PLC0415 (matplotlib is slow to import)
    from ..viz.report_html import render_html  # noqa: PLC0415

    plot_paths = [fn(records, os.path.join(out, name))
                  for fn, (name, _) in zip((plot_explored, plot_tft, plot_success), PLOTS)]
    blocks = build_blocks(records, meta, db, plot_paths)
    md_path, html_path = os.path.join(out, "report.md"), os.path.join(out, "report.html")
    for path, text in ((md_path, render_markdown(blocks, out)), (html_path, render_html(blocks, "COMPASS benchmark"))):
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    return ReportFiles(md_path, html_path, tuple(plot_paths), len(records))
