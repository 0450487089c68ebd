"""The report's ``index.html``: self-contained (inline CSS, no JavaScript).

Order: the headline (who won where, a summary figure and a path overlay: the first
screen), the terms, one overlay figure per scenario, the full table (collapsible), the
setup (collapsible), then one section per run.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .headline import Headline, Ranking
from .results import Run, counted, format_value, run_title, scenario_title
from .tables import CONTROLLER_CELL, RMS_CELL, TABLE_HEADERS, Row, failures_text
from .terms import TERMS_PARAGRAPH, setting_rows, settings_line

_CSS = """
body { font-family: system-ui, sans-serif; margin: 0.6em auto; max-width: 1260px; color: #222;
       padding: 0 0.8em; }
h1 { font-size: 1.45em; margin: 0.2em 0; }
h2 { font-size: 1.2em; margin: 0.9em 0 0.3em; }
h1, h2, h3 { font-weight: 600; }
p { margin: 0.35em 0; }
p.terms { color: #444; font-size: 0.92em; }
p.lead { font-size: 1.08em; }
table { border-collapse: collapse; font-size: 0.88em; margin-bottom: 0.6em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; position: sticky; top: 0; }
td.text { text-align: left; }
tbody.scenario { border-top: 3px solid #888; }
tbody.scenario tr:nth-child(even) { background: #fafafa; }
td.best { font-weight: bold; background: #e8f5e9; }
table.meta td, table.meta th { text-align: left; }
img { max-width: 100%; height: auto; border: 1px solid #ddd; }
div.first { display: flex; gap: 0.8em; align-items: flex-start; }
div.first figure { margin: 0; flex: 1 1 0; min-width: 0; }
figcaption { font-size: 0.85em; color: #444; }
section.run, section.scenario { margin-top: 1.5em; }
details { margin: 0.8em 0; }
summary { cursor: pointer; font-weight: 600; font-size: 1.1em; }
div.wide { overflow-x: auto; }
code { background: #f4f4f4; padding: 0 0.2em; }
""".strip()


def _e(value: object) -> str:
    return html.escape(str(value))


@dataclass(frozen=True)
class ScenarioFigure:
    """A scenario's overlay figure: its ranking and the figure's path beside the page."""

    ranking: Ranking
    src: str


# --------------------------------------------------------------------------- headline


def _wins_table(headline: Headline, runs: Sequence[Run]) -> str:
    ranked = {entry[0] for ranking in headline.rankings for entry in ranking.entries}
    controllers = [name for name in dict.fromkeys(str(run["controller"]) for run in runs)
                   if name in ranked]  # path followers are stated in the sentence instead
    wins = dict(headline.wins)
    rows = []
    for name in sorted(controllers, key=lambda n: -wins.get(n, 0)):
        errors = [1e3 * rms for ranking in headline.rankings for c, rms, _ in ranking.entries
                  if c == name and math.isfinite(rms)]
        median = float(np.median(errors)) if errors else math.nan
        rows.append(f"<tr><td class=\"text\">{_e(name)}</td><td>{wins.get(name, 0)}</td>"
                    f"<td>{_e(format_value(median))}</td></tr>")
    return (f'<table class="wins"><caption>{_e(headline.focus)}, after the settling time'
            "</caption><thead><tr><th>controller</th><th>scenarios won</th>"
            "<th>median RMS pos. err. [mm]</th></tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>")


def _headline(headline: Headline, runs: Sequence[Run], settings: Mapping[str, Any],
              overlay: ScenarioFigure | None) -> str:
    line = settings_line(settings)
    terms = (f'<p class="terms">Settings: {_e(line)}. Errors and peak ratios after the '
             "settling time (shaded on time plots); see <a href=\"#terms\">terms</a>.</p>"
             if line else "")
    figure = ""
    if overlay is not None:
        figure = (f'<figure><img src="{_e(overlay.src)}" alt="paths of every controller">'
                  f"<figcaption>{_e(scenario_title(overlay.ranking.scenario))}: every "
                  "controller on one path plot [m] and their position error [mm]."
                  "</figcaption></figure>")
    return f"""<section id="headline">
<p class="lead"><b>{_e(headline.sentence)}</b></p>
{terms}
<div class="first">
<figure style="flex-grow: 0.8">{_wins_table(headline, runs)}
<img src="headline.png" alt="lowest RMS position error per scenario">
<figcaption>One row per scenario (in brackets: the reference's peak wheel speed / limit),
one dot per controller.</figcaption></figure>
{figure}
</div>
</section>"""


# --------------------------------------------------------------------------- sections


def _scenario_section(item: ScenarioFigure, runs: Sequence[Run], ids: Sequence[str]) -> str:
    ranking = item.ranking
    ratio = f"{ranking.peak_ratio:.2f}" if math.isfinite(ranking.peak_ratio) else "-"
    ranked = ", ".join(
        f'<a href="#{_e(ids[index])}">{_e(name)}</a> {_e(format_value(rms, 1e3))} mm'
        for name, rms, index in ranking.entries)
    return (f'<section class="scenario"><h3>{_e(scenario_title(ranking.scenario, ratio))}</h3>'
            f"<p>RMS position error, lowest first: {ranked}.</p>"
            f'<img src="{_e(item.src)}" loading="lazy" alt="{_e(" / ".join(ranking.scenario))}"'
            ' width="1000" height="420"></section>')


def _key_value_table(caption: str, mapping: object) -> str:
    if not isinstance(mapping, Mapping) or not mapping:
        return ""
    rows = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in mapping.items())
    return f'<table class="meta"><caption>{_e(caption)}</caption>{rows}</table>'


def _settings_table(settings: object) -> str:
    if not isinstance(settings, Mapping) or not settings:
        return ""
    rows = "".join(f"<tr><th>{_e(name)}</th><td>{_e(value)}</td><td>{_e(unit)}</td>"
                   f"<td>{_e(meaning)}</td></tr>"
                   for name, value, unit, meaning in setting_rows(settings))
    return ('<table class="meta"><caption>settings</caption><thead><tr><th>setting</th>'
            f"<th>value</th><th>unit</th><th>meaning</th></tr></thead>{rows}</table>")


def _setup(meta: Mapping[str, Any]) -> str:
    parts = [
        f"<p>Command: <code>{_e(meta.get('command', '-'))}</code><br>"
        f"Created: {_e(meta.get('created', '-'))}</p>",
        _settings_table(meta.get("settings")),
        _key_value_table("machine", meta.get("machine")),
    ]
    return "\n".join(part for part in parts if part)


def html_table(groups: Sequence[Sequence[Row]]) -> str:
    """The full table, one ``tbody`` per scenario, the best RMS of each in bold."""
    text_cells = set(range(CONTROLLER_CELL + 1)) - {TABLE_HEADERS.index("reference peak / limit")}
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
    return (f'<div class="wide"><table class="summary"><thead><tr>{head}</tr></thead>'
            f"{''.join(bodies)}</table></div>")


def _run_section(run: Run, rid: str) -> str:
    metrics = run["metrics"]
    details = (
        f"failures: {_e(failures_text(metrics))}; solve time p50 / p99: "
        f"{_e(format_value(metrics.get('solve_time_p50'), 1e3))} / "
        f"{_e(format_value(metrics.get('solve_time_p99'), 1e3))} ms; tick max: "
        f"{_e(format_value(metrics.get('tick_time_max'), 1e3))} ms"
    )
    series = run.get("series")
    steered = isinstance(series, Mapping) and bool(series.get("steer_rate")) and bool(
        series.get("steer_rate_limit"))  # the figure's steering row (run_figure)
    return (f'<section class="run" id="{_e(rid)}"><h3>{_e(run_title(run))}</h3>'
            f'<p>{details} &middot; <a href="#row-{_e(rid)}">back to the table</a></p>'
            f'<img src="figures/{_e(rid)}.png" loading="lazy" alt="{_e(run_title(run))}" '
            f'width="1200" height="{1200 if steered else 900}"></section>')


def html_page(results: Mapping[str, Any], ids: Sequence[str], table: str, headline: Headline,
              scenarios: Sequence[ScenarioFigure], pace: bool = False) -> str:
    """The whole page; ``scenarios`` in page order, the first one in focus opens it."""
    runs = results["runs"]
    meta = results.get("meta") or {}
    settings = meta.get("settings") if isinstance(meta.get("settings"), Mapping) else {}
    focus = {ranking.scenario for ranking in headline.rankings}
    overlay = next((item for item in scenarios if item.ranking.scenario in focus), None)
    pace_block = ('<h3>Pace on the path</h3>\n<p>Steady lap time over the fastest lap the '
                  "run could keep (the time-optimal lap under the same wheel limits, or the "
                  "reference's own period where that is slower) against the largest distance "
                  "from the path after the settling time.</p>\n"
                  '<img src="pace.png" alt="lap time against path error, a panel per speed">'
                  if pace else "")
    sections = "\n".join(_scenario_section(item, runs, ids) for item in scenarios)
    run_sections = "\n".join(_run_section(run, rid) for run, rid in zip(runs, ids, strict=True))
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
<h1>Tracking report: {counted(len(runs), "run")}, {counted(len(scenarios), "scenario")}</h1>
{_headline(headline, runs, settings or {}, overlay)}
<h2 id="terms">Terms</h2>
<p>{_e(TERMS_PARAGRAPH)}</p>
<h2 id="scenarios">Per scenario</h2>
{sections}
<details id="table"><summary>Full table ({len(runs)} runs; the best RMS position error of
each scenario in bold; click a controller for its figure)</summary>
{table}
<img src="summary.png" alt="summary: controllers across scenarios" loading="lazy">
{pace_block}
</details>
<details id="setup"><summary>Setup: command, settings with units, machine</summary>
{_setup(meta)}
</details>
<h2 id="runs">Runs</h2>
{run_sections}
</body>
</html>
"""
