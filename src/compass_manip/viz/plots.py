"""The benchmark report's PNG plots, drawn from stored trial records (matplotlib, no pyplot state).

- explored fraction over time per level: mean ± std per method, each trial's curve held
  at its last value after it ends;
- TFT distributions per level and method (box plots, every trial that reports TFT);
- success rate per level and method with 95 % Wilson intervals.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..bench.intervals import wilson95
from ..bench.summary import group, order_methods

GRID_STEP_S = 1.0


def resample_curve(curve, t_grid: np.ndarray) -> np.ndarray:
    """A curve [[t_s, fraction], ...] as a step function on t_grid [s]: the last value at or
    before each time (0 before the first sample, the final value after the end)."""
    c = np.asarray(curve, dtype=float).reshape(-1, 2)
    if c.size == 0:
        return np.zeros_like(t_grid)
    order = np.argsort(c[:, 0], kind="stable")
    t, f = c[order, 0], c[order, 1]
    idx = np.searchsorted(t, t_grid, side="right") - 1
    return np.where(idx >= 0, f[np.clip(idx, 0, None)], 0.0)


def _levels_and_methods(records):
    groups = group(records)
    return groups, sorted({lv for _, lv in groups}), order_methods({m for m, _ in groups})


def _axes(n: int, title: str):
    fig = Figure(figsize=(4.2 * n, 3.6), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
    fig.suptitle(title)
    return fig, axes


def plot_explored(records, path: str) -> str:
    """Explored fraction over time per level, mean ± std over trials per method."""
    groups, levels, methods = _levels_and_methods(records)
    curves = [r.result["explored_curve"] for r in records if r.result and r.result.get("explored_curve")]
    t_end = max((max(p[0] for p in c) for c in curves), default=1.0)
    t_grid = np.arange(0.0, t_end + GRID_STEP_S, GRID_STEP_S)
    fig, axes = _axes(len(levels), "Explored fraction over time (mean ± std)")
    for ax, lv in zip(axes, levels):
        for m in methods:
            cs = [r.result["explored_curve"] for r in groups.get((m, lv), [])
                  if r.result and r.result.get("explored_curve")]
            if not cs:
                continue
            y = np.stack([resample_curve(c, t_grid) for c in cs])
            mean, std = y.mean(axis=0), y.std(axis=0)
            line, = ax.plot(t_grid, mean, label=f"{m} ({len(cs)})")
            ax.fill_between(t_grid, np.clip(mean - std, 0, 1), np.clip(mean + std, 0, 1), alpha=0.2,
                            color=line.get_color())
        ax.set(title=f"Level {lv}", xlabel="time [s]", ylabel="explored fraction", ylim=(0, 1.02))
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
        else:
            ax.text(0.5, 0.5, "no explored curves", ha="center", va="center", transform=ax.transAxes)
    fig.savefig(path, dpi=100)
    return path


def plot_tft(records, path: str) -> str:
    """Distributions of time to find the target per level and method."""
    groups, levels, methods = _levels_and_methods(records)
    fig, axes = _axes(len(levels), "Time to find target (TFT)")
    for ax, lv in zip(axes, levels):
        data, labels = [], []
        for m in methods:
            v = [r.result["tft_s"] for r in groups.get((m, lv), []) if r.result and r.result.get("tft_s") is not None]
            if v:
                data.append(v)
                labels.append(f"{m}\n({len(v)})")
        if data:
            ax.boxplot(data, tick_labels=labels, showmeans=True)
        ax.set(title=f"Level {lv}", ylabel="TFT [s]")
        ax.tick_params(axis="x", labelsize=7)
    fig.savefig(path, dpi=100)
    return path


def plot_success(records, path: str) -> str:
    """Success rate per level and method with 95 % Wilson intervals."""
    groups, levels, methods = _levels_and_methods(records)
    fig = Figure(figsize=(1.6 + 1.4 * len(levels), 3.6), layout="constrained")
    ax = fig.subplots()
    width = 0.8 / max(1, len(methods))
    for k, m in enumerate(methods):
        xs, ys, err = [], [], [[], []]
        for i, lv in enumerate(levels):
            recs = groups.get((m, lv), [])
            if not recs:
                continue
            e = wilson95(sum(r.success for r in recs), len(recs))
            xs.append(i + (k - (len(methods) - 1) / 2) * width)
            ys.append(100 * e.value)
            err[0].append(max(0.0, 100 * (e.value - e.lo)))
            err[1].append(max(0.0, 100 * (e.hi - e.value)))
        ax.bar(xs, ys, width=width * 0.9, yerr=err, capsize=3, label=m)
    ax.set_xticks(range(len(levels)), [f"Level {lv}" for lv in levels])
    ax.set(ylabel="success rate [%]", ylim=(0, 105), title="Success rate (95 % Wilson interval)")
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=100)
    return path
