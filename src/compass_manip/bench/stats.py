"""Summary statistics and the JSON lines every benchmark prints (`make bench`).

One line per figure: `{"name": ..., "median": ..., "p90": ..., "unit": ...}` for samples
where smaller is better (times, lengths), `{"name": ..., "median": ..., "p10": ...}` for
rates (the slowest tenth of the runs), `{"name": ..., "value": ...}` for single figures.
Extra keys (n, context) may follow. Names are stable once published.
"""
from __future__ import annotations

import json
import os
import sys

import numpy as np


def json_float(x: float, digits: int = 4) -> float | None:
    """x rounded for JSON, or None when it is NaN or infinite (JSON has neither)."""
    x = float(x)
    return round(x, digits) if np.isfinite(x) else None


def median_p90(samples, digits: int = 4) -> dict:
    """{"median", "p90", "n"} of samples (NaN-free); None values when there are none."""
    a = np.asarray(samples, dtype=float).ravel()
    if a.size == 0:
        return {"median": None, "p90": None, "n": 0}
    return {"median": json_float(np.median(a), digits), "p90": json_float(np.percentile(a, 90), digits),
            "n": int(a.size)}


def emit(name: str, stream=None, **fields) -> dict:
    """Print one benchmark JSON line `{"name": name, **fields}` and return it."""
    record = {"name": name, **fields}
    print(json.dumps(record), file=stream or sys.stdout, flush=True)
    return record


def emit_samples(name: str, samples, unit: str, **extra) -> dict:
    """Median and 90th percentile of samples already in `unit` (smaller is better)."""
    return emit(name, **median_p90(samples), unit=unit, **extra)


def emit_rate(name: str, rates, unit: str, **extra) -> dict:
    """Median and 10th percentile (the slow end) of rates in `unit` (larger is better)."""
    a = np.asarray(rates, dtype=float).ravel()
    return emit(name, median=json_float(np.median(a), 1), p10=json_float(np.percentile(a, 10), 1), unit=unit,
                n=int(a.size), **extra)


def emit_value(name: str, value: float, unit: str, digits: int = 4, **extra) -> dict:
    """One figure."""
    return emit(name, value=json_float(value, digits), unit=unit, **extra)


def load_average() -> float | None:
    """The 1-minute load average (how busy the machine was), None where unknown."""
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None
