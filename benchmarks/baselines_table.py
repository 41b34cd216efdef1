"""Summarise JSON-line trial records (baselines_side_by_side.py / baselines_sweep.py) as a
Markdown table per level and method: n, found, mean TFT [s] (a failed trial counts the
time limit, as TrialResult does) and over the found trials only, mean PFT [m] (path until
found, or until the trial ended) and over the found trials only, mean MPSR, and the
failures by reason.

    python benchmarks/baselines_table.py outputs/side_by_side_seed101.jsonl [--methods fv ig ...]
"""
from __future__ import annotations

import argparse
import json
from collections import Counter, defaultdict


def load(paths):
    recs = {}
    for p in paths:
        with open(p) as f:
            for line in f:
                r = json.loads(line)
                recs[(r["method"], r["level"], r["scene"], r["seed"])] = r  # the latest run of a trial counts
    return list(recs.values())


def table(recs, methods=None) -> str:
    groups = defaultdict(list)
    for r in recs:
        groups[(r["level"], r["method"])].append(r)
    methods = methods or sorted({r["method"] for r in recs})
    rows = ["| level | method | n | found | TFT s | TFT s (found) | PFT m | PFT m (found) | MPSR | failures |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for level in sorted({r["level"] for r in recs}):
        for m in methods:
            g = groups.get((level, m), [])
            if not g:
                continue
            ok = [r for r in g if "error" not in r]
            found = sum(r["success"] for r in ok)
            def mean(k, ok=ok):
                vals = [r[k] for r in ok if r[k] is not None]
                return sum(vals) / max(1, len(vals))
            fails = Counter(r["failure"] for r in ok if not r["success"])
            fails.update("error" for r in g if "error" in r)
            f = ", ".join(f"{k} {v}" for k, v in sorted(fails.items())) or "-"
            won = [r for r in ok if r["success"]]
            tf = f"{sum(r['tft_s'] for r in won) / len(won):.1f}" if won else "-"
            pf = f"{sum(r['pft_m'] for r in won) / len(won):.2f}" if won else "-"
            rows.append(f"| {level} | {m} | {len(g)} | {found}/{len(g)} | {mean('tft_s'):.1f} | {tf} | "
                        f"{mean('pft_m'):.2f} | {pf} | {mean('mpsr'):.2f} | {f} |")
    return "\n".join(rows)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("paths", nargs="+")
    p.add_argument("--methods", nargs="+", default=None)
    a = p.parse_args()
    print(table(load(a.paths), a.methods))


if __name__ == "__main__":
    main()
