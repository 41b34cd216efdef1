"""A rendered table of the report (title, header, cells, bold cells, notes) and its Markdown."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .intervals import Estimate


@dataclass(frozen=True)
class Table:
    """rows are tuples of cell strings as wide as header; bold holds (row, column) indices."""

    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    bold: frozenset = field(default_factory=frozenset)
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        for row in self.rows:
            if len(row) != len(self.header):
                raise ValueError(f"table {self.title!r}: row {row} has {len(row)} cells, header {len(self.header)}")

    def cell(self, i: int, j: int) -> str:
        """Cell text, in **bold** where marked."""
        text = self.rows[i][j]
        return f"**{text}**" if (i, j) in self.bold and text else text

    def markdown(self) -> str:
        """A GitHub-flavoured Markdown table with its title as a heading and notes below."""
        esc = lambda s: s.replace("|", "\\|")  # noqa: E731
        lines = [f"### {self.title}", "", "| " + " | ".join(esc(h) for h in self.header) + " |",
                 "|" + "|".join([":---"] + ["---:"] * (len(self.header) - 1)) + "|"]
        for i in range(len(self.rows)):
            lines.append("| " + " | ".join(esc(self.cell(i, j)) for j in range(len(self.header))) + " |")
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines) + "\n"


def fmt_mean(e: Estimate, scale: float = 1.0, digits: int = 1) -> str:
    """"mean ± half-width (n)" of a t-interval estimate; "–" when there are no samples."""
    if e.n == 0:
        return "–"
    half = "n/a" if math.isnan(e.half_width) else f"{e.half_width * scale:.{digits}f}"
    return f"{e.value * scale:.{digits}f} ± {half} ({e.n})"


def fmt_rate(e: Estimate, digits: int = 1) -> str:
    """"rate % [lo–hi] (n)" of a Wilson estimate in percent; "–" when n == 0."""
    if e.n == 0:
        return "–"
    return f"{100 * e.value:.{digits}f} [{100 * e.lo:.{digits}f}–{100 * e.hi:.{digits}f}] ({e.n})"


def fmt_count(k: int, n: int) -> str:
    """"k/n"."""
    return f"{k}/{n}"


def best_indices(values: list[float], higher_is_better: bool) -> list[int]:
    """Indices of the best finite values (all of them when tied); [] with fewer than two."""
    finite = [(i, v) for i, v in enumerate(values) if v is not None and math.isfinite(v)]
    if len(finite) < 2:
        return []  # nothing to compare with
    best = max(v for _, v in finite) if higher_is_better else min(v for _, v in finite)
    return [i for i, v in finite if math.isclose(v, best, rel_tol=1e-12, abs_tol=1e-12)]
