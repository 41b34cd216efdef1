"""A self-contained HTML page from report blocks: tables as <table>, PNGs inlined as data URIs.

Blocks are ("h1" | "h2" | "p" | "warn", text), ("table", bench.table.Table) or
("img", png_path, caption); the same blocks make report.md.
"""
from __future__ import annotations

import base64
import html

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1400px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 0.3em; font-size: 13px; }
th, td { border: 1px solid #bbb; padding: 3px 7px; text-align: right; white-space: nowrap; }
th:first-child, td:first-child { text-align: left; }
th { background: #eee; }
.warn { background: #fff3cd; border: 1px solid #e0b000; padding: 0.6em; }
.notes { font-size: 12px; color: #555; }
figure { margin: 1em 0; } img { max-width: 100%; }
.scroll { overflow-x: auto; }
"""


def png_data_uri(path: str) -> str:
    """The PNG file at `path` as a data: URI."""
    with open(path, "rb") as f:
        return "data:image/png;base64," + base64.b64encode(f.read()).decode("ascii")


def _table(t) -> str:
    e = html.escape
    head = "".join(f"<th>{e(h)}</th>" for h in t.header)
    body = []
    for i, row in enumerate(t.rows):
        cells = "".join(f"<td><b>{e(c)}</b></td>" if (i, j) in t.bold and c else f"<td>{e(c)}</td>"
                        for j, c in enumerate(row))
        body.append(f"<tr>{cells}</tr>")
    notes = "".join(f"<li>{e(n)}</li>" for n in t.notes)
    return (f"<h3>{e(t.title)}</h3><div class='scroll'><table><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table></div>" + (f"<ul class='notes'>{notes}</ul>" if notes else ""))


def render_html(blocks, title: str) -> str:
    """The whole page; every image is embedded, nothing is fetched."""
    e = html.escape
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{e(title)}</title>"
             f"<style>{_STYLE}</style></head><body>"]
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2"):
            parts.append(f"<{kind}>{e(block[1])}</{kind}>")
        elif kind == "p":
            parts.append(f"<p>{e(block[1])}</p>")
        elif kind == "warn":
            parts.append(f"<p class='warn'>{e(block[1])}</p>")
        elif kind == "table":
            parts.append(_table(block[1]))
        elif kind == "img":
            parts.append(f"<figure><img src='{png_data_uri(block[1])}' alt='{e(block[2])}'>"
                         f"<figcaption>{e(block[2])}</figcaption></figure>")
        else:
            raise ValueError(f"unknown report block {kind!r}")
    parts.append("</body></html>")
    return "\n".join(parts)
