"""The quality benchmark's readable reports: summary.md and summary.html.

Both show the aggregate table first, then one row per item with thumbnails of its
overlay.png and speed.png (and human_speeds.png when
the input had time stamps). Images are linked by paths relative to the summary (the item
folders sit beside it), so the folder can be moved or served as is; the HTML carries its
own style and loads nothing from elsewhere (no CDN, no script).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

from inkmotion.benchmarks.quality import (
    AGGREGATE_HEADER,
    aggregate_rows,
    format_value,
    totals_line,
)

#: the item images shown as thumbnails, in this order
THUMBNAILS = ("overlay.png", "speed.png", "human_speeds.png")


def _item_images(out: Path, row: dict[str, Any]) -> list[str]:
    """Relative paths of the item's thumbnails that exist."""
    item = row.get("item")
    if not item or row.get("status") != "ok":
        return []
    return [f"{item}/{name}" for name in THUMBNAILS if (out / item / name).is_file()]


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def write_markdown(path: Path, summary: dict) -> None:
    """summary.md: totals, the aggregate table, then the per-item table with thumbnails."""
    out = Path(path).parent
    lines = ["# Quality benchmark", "", totals_line(summary), "", "## Aggregate", ""]
    head = [*AGGREGATE_HEADER, "meaning"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |"
              for row in aggregate_rows(summary, meaning=True)]
    columns = summary["columns"]
    header = ["item", "status", *(c["label"] for c in columns), "images", "error"]
    lines += ["", "## Items", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in summary["items"]:
        images = " ".join(f"[![{Path(p).stem}]({p})]({p})" for p in _item_images(out, row))
        cells = [str(row.get("item", "")), row["status"],
                 *(format_value(row.get(c["key"])) for c in columns), images,
                 row.get("error", "")]
        lines.append("| " + " | ".join(_md_cell(c) for c in cells) + " |")
    Path(path).write_text("\n".join(lines) + "\n")


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; margin-bottom: 1.5em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; vertical-align: top; }
th { background: #f2f2f2; }
td.text { text-align: left; }
tr.failed td { background: #fdecea; }
img { max-height: 160px; max-width: 320px; border: 1px solid #ddd; margin: 0 0.2em; }
.error { color: #b00020; text-align: left; max-width: 30em; }
"""


def _cells(values: list[str], tag: str = "td", cls: str = "") -> str:
    attr = f' class="{cls}"' if cls else ""
    return "".join(f"<{tag}{attr}>{html.escape(v)}</{tag}>" for v in values)


def write_html(path: Path, summary: dict) -> None:
    """summary.html: the same content as summary.md, self-contained and with thumbnails."""
    out = Path(path).parent
    e = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>inkmotion quality benchmark</title>", f"<style>{_STYLE}</style>",
             "</head><body>", "<h1>Quality benchmark</h1>", f"<p>{e(totals_line(summary))}</p>",
             "<h2>Aggregate</h2>", "<table>",
             f"<tr>{_cells([*AGGREGATE_HEADER, 'meaning'], 'th')}</tr>"]
    for row in aggregate_rows(summary, meaning=True):
        parts.append(f"<tr>{_cells(row[:2], cls='text')}{_cells(row[2:-1])}"
                     f"{_cells(row[-1:], cls='text')}</tr>")
    parts.append("</table>")
    columns = summary["columns"]
    header = ["item", "status", *(c["label"] for c in columns), "images / error"]
    parts += ["<h2>Items</h2>", "<table>", f"<tr>{_cells(header, 'th')}</tr>"]
    for row in summary["items"]:
        failed = row["status"] != "ok"
        images = "".join(f'<a href="{e(p)}"><img src="{e(p)}" alt="{e(p)}" loading="lazy"></a>'
                         for p in _item_images(out, row))
        if failed:
            last = f'<td class="error">{e(row.get("error", ""))}</td>'
        else:
            last = f'<td class="text">{images}</td>'
        title = f' title="{e(row["source"])}"'
        parts.append(f'<tr class="{"failed" if failed else "ok"}">'
                     f'<td class="text"{title}>{e(str(row.get("item", "")))}</td>'
                     f'{_cells([row["status"]], cls="text")}'
                     f'{_cells([format_value(row.get(c["key"])) for c in columns])}{last}</tr>')
    parts += ["</table>", "</body></html>"]
    Path(path).write_text("\n".join(parts) + "\n")
