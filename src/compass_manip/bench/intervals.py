"""95 % confidence intervals for the report: Student-t for means, Wilson score for rates."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: The standard normal's 97.5 % quantile, scipy.stats.norm.ppf(0.975) (tests check it).
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Estimate:
    """value: the mean (or rate); lo, hi: the 95 % interval; n: samples. NaN when n == 0."""

    value: float
    lo: float
    hi: float
    n: int

    @property
    def half_width(self) -> float:
        return (self.hi - self.lo) / 2.0


def mean_t95(samples) -> Estimate:
    """Mean with the two-sided 95 % Student-t interval mean ± t(0.975, n-1)·s/√n.

    One sample gives an unbounded interval (NaN half-width is shown as "n/a").
    """
    a = np.asarray([x for x in samples if x is not None], dtype=float)
    a = a[np.isfinite(a)]
    n = int(a.size)
    if n == 0:
        return Estimate(math.nan, math.nan, math.nan, 0)
    mean = float(a.mean())
    if n == 1:
        return Estimate(mean, math.nan, math.nan, 1)
    from scipy import stats  # noqa: PLC0415 (slow to import; `compass report` checks its input first)

    half = float(stats.t.ppf(0.975, n - 1) * a.std(ddof=1) / math.sqrt(n))
    return Estimate(mean, mean - half, mean + half, n)


def wilson95(k: int, n: int) -> Estimate:
    """Rate k/n with its 95 % Wilson score interval (sensible at 0/n and n/n)."""
    if n == 0:
        return Estimate(math.nan, math.nan, math.nan, 0)
    p = k / n
    z2 = Z95 * Z95
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    lo = 0.0 if k == 0 else min(p, centre - half)  # exact ends; no rounding past the rate
    hi = 1.0 if k == n else max(p, centre + half)
    return Estimate(p, lo, hi, n)
