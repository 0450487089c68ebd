"""The report's ``index.html``: self-contained (inline CSS, no JavaScript).

Order: a table of contents, the headline (MPC against the best baseline, each
controller's wins and median errors, the position and heading dot chart: the first
screen; a single run's metrics and figure instead), the terms, one overlay figure per
scenario, the full table (collapsible), the setup (collapsible), then one section per run.
"""

from __future__ import annotations

import html
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .headline import (
    HEADING_FLOOR,
    POSITION_FLOOR,
    TIE_TOLERANCE,
    Comparison,
    Headline,
    Ranking,
    floored,
    follows_path,
    median,
)
from .results import (
    Run,
    counted,
    format_value,
    metric_value,
    run_skip,
    run_title,
    scenario_of,
    scenario_title,
    settings_value,
)
from .tables import CONTROLLER_CELL, RMS_CELL, TABLE_HEADERS, Row, failures_text
from .terms import setting_rows, settings_line, terms_paragraphs

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
div.first div.side { flex: 0 0 27em; }
table.wins td { white-space: nowrap; }
nav.toc { font-size: 0.9em; margin: 0.1em 0 0.4em; }
table.versus th.row { text-align: left; font-weight: normal; background: #f8f8f8; }
caption { text-align: left; font-size: 0.92em; color: #444; }
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


def _median_text(values: Sequence[float], floor: float, scale: float) -> str:
    """The median of finite ``values`` [SI] scaled, ``< floor`` below the floor."""
    value = median(values)
    return floored(value, floor, scale, "").strip() if math.isfinite(value) else "-"


def _controllers_table(headline: Headline, runs: Sequence[Run]) -> str:
    """Per ranked controller in focus: scenarios won (alone or tied), median RMS position
    [mm] and heading [deg] errors."""
    ranked = {entry[0] for ranking in headline.rankings for entry in ranking.entries}
    controllers = [name for name in dict.fromkeys(str(run["controller"]) for run in runs)
                   if name in ranked]  # path followers are stated in the sentence instead
    wins = dict(headline.wins)
    tied = Counter(name for ranking in headline.rankings if len(ranking.winners) > 1
                   for name in ranking.winners)
    rows = []
    for name in sorted(controllers, key=lambda n: -wins.get(n, 0)):
        indices = [i for ranking in headline.rankings for c, _, i in ranking.entries if c == name]
        position = [metric_value(runs[i], "rms_position_error") for i in indices]
        heading = [metric_value(runs[i], "rms_heading_error") for i in indices]
        won = f"{wins.get(name, 0)}" + (f" ({tied[name]} tied)" if tied.get(name) else "")
        rows.append(f"<tr><td class=\"text\">{_e(name)}</td><td>{_e(won)}</td>"
                    f"<td>{_e(_median_text(position, POSITION_FLOOR, 1e3))}</td>"
                    f"<td>{_e(_median_text(heading, HEADING_FLOOR, 180.0 / math.pi))}</td></tr>")
    return (f'<table class="wins"><caption>Each controller {_e(headline.focus)} '
            f"({counted(len(headline.rankings), 'scenario')}); median RMS errors</caption>"
            "<thead><tr><th>controller</th><th>lowest in</th>"
            "<th>position [mm]</th><th>heading [deg]</th></tr>"
            f"</thead><tbody>{''.join(rows)}</tbody></table>")


def _versus_cells(comparison: Comparison) -> list[str]:
    """One column of the MPC-against-baseline table (see :func:`_versus_table`)."""
    ratios = comparison.position_ratios
    position = [floored(value, POSITION_FLOOR, 1e3, "") for value in
                comparison.medians("position")]
    heading = [floored(value, HEADING_FLOOR, 180.0 / math.pi, "") for value in
               comparison.medians("heading")]
    return [str(comparison.scenarios),
            f"{comparison.wins} / {comparison.ties} / {comparison.losses}",
            f"{median(ratios):.2g}\u00d7" if ratios else "-",
            " : ".join(text.strip() for text in position),
            " : ".join(text.strip() for text in heading)]


def _versus_table(headline: Headline) -> str:
    """MPC (the best variant per scenario) against the best baseline, a column beyond and
    one inside the limits: scenarios, MPC lower / tie / higher in RMS position error, the
    median ratio, and the median errors of both (position [mm], heading [deg])."""
    if headline.comparison is None:
        return ""
    columns = [(headline.focus, _versus_cells(headline.comparison))]
    if headline.inside is not None:
        columns.append(("inside the wheel limits", _versus_cells(headline.inside)))
    names = ("scenarios", "MPC lower / tie / higher", "median ratio MPC : baseline",
             "median RMS pos. err. [mm], MPC : baseline",
             "median RMS heading err. [deg], MPC : baseline")
    head = "".join(f"<th>{_e(title)}</th>" for title, _ in columns)
    rows = "".join(f'<tr><th class="row">{_e(name)}</th>'
                   + "".join(f"<td>{_e(cells[i])}</td>" for _, cells in columns) + "</tr>"
                   for i, name in enumerate(names))
    return ('<table class="versus"><caption>MPC (its best variant per scenario) against the '
            f"best baseline, RMS errors</caption><thead><tr><th></th>{head}</tr></thead>"
            f"<tbody>{rows}</tbody></table>")


def _single_table(run: Run) -> str:
    """One run's main metrics, for a report of that run alone."""
    rows = [("RMS position error", floored(metric_value(run, "rms_position_error"),
                                           POSITION_FLOOR, 1e3, "mm")),
            ("max position error", floored(metric_value(run, "max_position_error"),
                                           POSITION_FLOOR, 1e3, "mm")),
            ("RMS heading error", floored(metric_value(run, "rms_heading_error"),
                                          HEADING_FLOOR, 180.0 / math.pi, "deg")),
            ("max path error", floored(metric_value(run, "max_cross_track_error"),
                                       POSITION_FLOOR, 1e3, "mm")),
            ("peak wheel command / limit", format_value(run["metrics"].get(
                "max_wheel_speed_ratio"))),
            ("tick time p50 / p99", f"{format_value(run['metrics'].get('tick_time_p50'), 1e3)}"
                                    f" / {format_value(run['metrics'].get('tick_time_p99'), 1e3)}"
                                    " ms")]
    body = "".join(f'<tr><th>{_e(name)}</th><td>{_e(value)}</td></tr>' for name, value in rows)
    return f'<table class="meta"><caption>after the settling time</caption>{body}</table>'


def _headline(headline: Headline, runs: Sequence[Run], settings: Mapping[str, Any],
              ids: Sequence[str]) -> str:
    line = settings_line(settings)
    terms = (f'<p class="terms">Settings: {_e(line)}. Errors and peak ratios after the '
             "settling time (shaded on time plots); see <a href=\"#terms\">terms</a>.</p>"
             if line else "")
    if headline.single is not None:
        rid = ids[0]
        first = (f'<div class="side">{_single_table(headline.single)}</div>'
                 f'<figure><img src="figures/{_e(rid)}.png" alt="the run\'s figure" '
                 'width="1200" height="900"><figcaption>The run: path with the predicted '
                 "plans [m], errors [mm, deg], wheel commands against their limits [rad/s], "
                 'tick times [ms] (<a href="#runs">below</a>).</figcaption></figure>')
    else:
        first = (f'<div class="side">{_versus_table(headline)}'
                 f"{_controllers_table(headline, runs)}</div>"
                 '<figure><img src="headline.png" alt="RMS position and heading error of '
                 'every controller per scenario"><figcaption>One row per scenario (in '
                 "brackets: the reference's peak wheel speed / limit), one dot per "
                 "controller (MPC variants as circles above the row's middle, the baselines "
                 "as squares below), the lowest outlined.</figcaption></figure>")
    rest = "".join(" " + _e(text) for text in headline.sentences[1:])
    return f"""<section id="headline">
<p class="lead"><b>{_e(headline.sentences[0])}</b>{rest}</p>
{terms}
<div class="first">
{first}
</div>
</section>"""


# --------------------------------------------------------------------------- sections


def _scenario_section(item: ScenarioFigure, runs: Sequence[Run], ids: Sequence[str]) -> str:
    ranking = item.ranking
    ratio = f"{ranking.peak_ratio:.2f}" if math.isfinite(ranking.peak_ratio) else "-"
    def link(name: str, index: int) -> str:
        return f'<a href="#{_e(ids[index])}">{_e(name)}</a>'

    below = [link(name, index) for name, rms, index in ranking.entries if rms < POSITION_FLOOR]
    above = [f"{link(name, index)} {_e(floored(rms, POSITION_FLOOR, 1e3, 'mm'))}"
             for name, rms, index in ranking.entries if not rms < POSITION_FLOOR]
    floor = f"{1e3 * POSITION_FLOOR:g} mm"
    parts = [f"below {floor} (not ranked): {', '.join(below)}"] if below else []
    if above:
        order = "" if len(ranking.entries) == 1 else ", lowest first"
        parts.append(f"{'above it' if below else 'RMS position error'}{order}: "
                     f"{', '.join(above)}")
    tied = [name for name in ranking.winners if ranking.entries[0][1] >= POSITION_FLOOR]
    tie = f" A tie (within {TIE_TOLERANCE:.0%}): {', '.join(tied)}." if len(tied) > 1 else ""
    text = "; ".join(parts)
    text = text[0].upper() + text[1:] if below else text
    return (f'<section class="scenario"><h3>{_e(scenario_title(ranking.scenario, ratio))}</h3>'
            f"<p>{text}.{_e(tie)}</p>"
            f'<img src="{_e(item.src)}" loading="lazy" alt="{_e(scenario_title(ranking.scenario))}"'
            ' width="1000" height="460"></section>')


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


def _title(runs: Sequence[Run], scenarios: int) -> str:
    """``"3 runs, 1 scenario"``, or for one run ``"mpc on mecanum / figureeight"``."""
    if len(runs) == 1:
        labels = [label for label in scenario_of(runs[0]) if label not in ("-", "")]
        return f"{runs[0]['controller']} on {' / '.join(labels)}"
    return f"{counted(len(runs), 'run')}, {counted(scenarios, 'scenario')}"


_CONTENTS = (("headline", "Headline"), ("terms", "Terms"), ("scenarios", "Per scenario"),
             ("table", "Full table"), ("setup", "Setup"), ("runs", "Runs"))


def html_page(results: Mapping[str, Any], ids: Sequence[str], table: str, headline: Headline,
              scenarios: Sequence[ScenarioFigure], pace: bool = False) -> str:
    """The whole page: a table of contents, the headline (the first screen), the terms,
    the scenarios in page order, the full table, the setup, the runs."""
    runs = results["runs"]
    meta = results.get("meta") or {}
    settings = meta.get("settings") if isinstance(meta.get("settings"), Mapping) else {}
    pace_block = ('<h3>Pace on the path</h3>\n<p>Steady lap time over the fastest lap the '
                  "run could keep (the time-optimal lap under the same wheel limits, or the "
                  "reference's own period where that is slower) against the largest distance "
                  "from the path after the settling time.</p>\n"
                  '<img src="pace.png" alt="lap time against path error, a panel per speed">'
                  if pace else "")
    sections = "\n".join(_scenario_section(item, runs, ids) for item in scenarios)
    run_sections = "\n".join(_run_section(run, rid) for run, rid in zip(runs, ids, strict=True))
    terms = terms_paragraphs(
        speeds=any(str(run["speed"]) not in ("-", "") for run in runs),
        skip=any(run_skip(run, settings_value(results, "skip")) > 0 for run in runs),
        followers=any(follows_path(run) for run in runs),
        compared=headline.comparison is not None,
        ranked=any(len(ranking.entries) > 1 for ranking in headline.rankings))
    contents = " \u00b7 ".join(f'<a href="#{key}">{name}</a>' for key, name in _CONTENTS)
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
<h1>Tracking report: {_e(_title(runs, len(scenarios)))}</h1>
<nav class="toc">Contents: {contents}</nav>
{_headline(headline, runs, settings or {}, ids)}
<h2 id="terms">Terms</h2>
{"".join(f"<p>{_e(text)}</p>" for text in terms)}
<h2 id="scenarios">Per scenario</h2>
{sections}
<details id="table"><summary>Full table ({counted(len(runs), "run")}; the best RMS position
error of each scenario in bold; click a controller for its figure)</summary>
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
