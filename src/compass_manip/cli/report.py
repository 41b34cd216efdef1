"""`compass report RESULTS --out DIR`: Table I, ablations, failures and plots from a results store."""
from __future__ import annotations

HELP = "write report.md and a self-contained report.html (Table I, ablations, failures, plots) from a results store"


def add_arguments(p) -> None:
    p.add_argument("results", help="results store written by compass bench (.sqlite)")
    p.add_argument("--out", default="outputs/report", help="output directory, created if missing "
                                                           "(default outputs/report)")


def run(args) -> int:
    from ..bench.report import write_report

    files = write_report(args.results, args.out)
    print(f"{files.n_trials} trials -> {files.markdown}, {files.html} and {len(files.plots)} plots")
    return 0
