"""The report's ``index.html``: self-contained (inline CSS, no JavaScript)."""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from typing import Any

from .results import Run, format_value, run_title
from .tables import CONTROLLER_CELL, RMS_CELL, TABLE_HEADERS, Row, failures_text

# --------------------------------------------------------------------------- HTML

_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1300px; color: #222; }
h1, h2, h3 { font-weight: 600; }
table { border-collapse: collapse; font-size: 0.88em; margin-bottom: 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: right; }
th { background: #f0f0f0; position: sticky; top: 0; }
td.text { text-align: left; }
tbody.scenario { border-top: 3px solid #888; }
tbody.scenario tr:nth-child(even) { background: #fafafa; }
td.best { font-weight: bold; background: #e8f5e9; }
table.meta td, table.meta th { text-align: left; }
img { max-width: 100%; height: auto; border: 1px solid #ddd; }
section.run { margin-top: 2em; }
div.wide { overflow-x: auto; }
code { background: #f4f4f4; padding: 0 0.2em; }
""".strip()


def _e(value: object) -> str:
    return html.escape(str(value))


def _key_value_table(caption: str, mapping: object) -> str:
    if not isinstance(mapping, Mapping) or not mapping:
        return ""
    rows = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in mapping.items())
    return f'<table class="meta"><caption>{_e(caption)}</caption>{rows}</table>'


def _html_meta(meta: Mapping[str, Any]) -> str:
    parts = [
        f"<p>Command: <code>{_e(meta.get('command', '-'))}</code><br>"
        f"Created: {_e(meta.get('created', '-'))}</p>",
        _key_value_table("machine", meta.get("machine")),
        _key_value_table("settings", meta.get("settings")),
    ]
    return "\n".join(part for part in parts if part)


def html_table(groups: Sequence[Sequence[Row]]) -> str:
    text_cells = set(range(CONTROLLER_CELL + 1)) - {TABLE_HEADERS.index("peak ratio")}
    head = "".join(f"<th>{_e(title)}</th>" for title in TABLE_HEADERS)
    bodies = []
    for group in groups:
        rows = []
        for rid, cells, best in group:
            html_cells = []
            for index, cell in enumerate(cells):
                content = _e(cell)
                if index == CONTROLLER_CELL:
                    content = f'<a href="#{_e(rid)}">{content}</a>'
                classes = ["text"] if index in text_cells else []
                if index == RMS_CELL and best:
                    classes.append("best")
                    content = f"<b>{content}</b>"
                attribute = f' class="{" ".join(classes)}"' if classes else ""
                html_cells.append(f"<td{attribute}>{content}</td>")
            rows.append(f'<tr id="row-{_e(rid)}">{"".join(html_cells)}</tr>')
        bodies.append(f'<tbody class="scenario">{"".join(rows)}</tbody>')
    return (
        f'<div class="wide"><table class="summary"><thead><tr>{head}</tr></thead>'
        f"{''.join(bodies)}</table></div>"
    )


def _html_run_section(run: Run, rid: str) -> str:
    metrics = run["metrics"]
    details = (
        f"failures: {_e(failures_text(metrics))}; solve time p50 / p99: "
        f"{_e(format_value(metrics.get('solve_time_p50'), 1e3))} / "
        f"{_e(format_value(metrics.get('solve_time_p99'), 1e3))} ms; tick max: "
        f"{_e(format_value(metrics.get('tick_time_max'), 1e3))} ms"
    )
    return (
        f'<section class="run" id="{_e(rid)}"><h3>{_e(run_title(run))}</h3>'
        f'<p>{details} &middot; <a href="#row-{_e(rid)}">back to the table</a></p>'
        f'<img src="figures/{_e(rid)}.png" loading="lazy" alt="{_e(run_title(run))}" '
        f'width="1200" height="900"></section>'
    )


def html_page(results: Mapping[str, Any], ids: Sequence[str], table: str,
              pace: bool = False) -> str:
    runs = results["runs"]
    pace_block = ('<h2>Pace on the path</h2>\n<p>Steady lap time over the fastest lap the '
                  "run could keep (the time-optimal lap under the same wheel limits, or the "
                  "reference's own period where that is slower) against the largest distance "
                  "from the path after the settling time.</p>\n"
                  '<img src="pace.png" alt="lap time against path error per scenario">'
                  if pace else "")
    sections = "\n".join(_html_run_section(run, rid) for run, rid in zip(runs, ids, strict=True))
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>holonomic-mpc tracking report</title>
<style>
{_CSS}
</style>
</head>
<body>
<h1>Tracking benchmark report</h1>
<h2>Benchmark</h2>
{_html_meta(results.get("meta") or {})}
<h2>Summary</h2>
<p>{len(runs)} runs; rows grouped by scenario; the best RMS position error of each scenario
in bold. Click a controller for its figure.</p>
{table}
<img src="summary.png" alt="summary: controllers across scenarios">
{pace_block}
<h2>Runs</h2>
{sections}
</body>
</html>
"""
