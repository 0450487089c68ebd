"""Tracking reports from saved benchmark results: figures, an HTML page, a Markdown table.

This package is the only part of the project that imports matplotlib (in
:mod:`.figures`). It works from the plain dicts and lists of ``results.json`` (see
:func:`load_results`) and never imports a solver.

A report directory holds::

    index.html              self-contained page (inline CSS, no JavaScript)
    summary.md              the summary table in Markdown
    summary.png             controllers compared across scenarios
    pace.png                lap time against path error per scenario (periodic references)
    figures/<run_id>.png    one 2x2 figure per run

Units: results store SI units (m, rad, s, rad/s); the report shows lengths in mm,
angles in deg and times in ms.

Modules: :mod:`.results` (loading and reading results), :mod:`.figures`,
:mod:`.tables` and :mod:`.page`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .figures import write_pace_figure, write_run_figure, write_summary_figure
from .page import html_page, html_table
from .results import (
    ReportError,
    Run,
    load_results,
    read_series,
    run_id,
    unique_run_ids,
    validate_results,
)
from .tables import grouped_rows, markdown_table

__all__ = ["ReportError", "load_results", "run_id", "validate_results", "write_report"]


def _settings_dt(results: Mapping[str, Any]) -> float:
    """The controller period from ``meta.settings.dt`` [s]; NaN when absent."""
    settings = (results.get("meta") or {}).get("settings") or {}
    dt = settings.get("dt") if isinstance(settings, Mapping) else None
    return float(dt) if isinstance(dt, (int, float)) and dt > 0 else math.nan


def write_report(
    results: Mapping[str, Any],
    out_dir: Path,
    on_figure: Callable[[int, int], None] | None = None,
) -> Path:
    """Write figures, ``summary.md`` and ``index.html`` into ``out_dir``; return the page's path.

    ``out_dir`` and ``out_dir/figures`` are created. Each run's figure is named
    ``figures/<run_id>.png`` (repeated ids get ``-2``, ``-3``...). ``on_figure(i, total)``
    is called after each written figure, ``i`` from 1 to ``total`` = runs + 1 (the
    summary figure is the last).

    Raises:
        ReportError: ``results`` lacks ``"runs"`` or a required key of a run, or a
            series has the wrong shape.
    """
    validate_results(results)
    out_dir = Path(out_dir)
    figures = out_dir / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    runs: list[Run] = list(results["runs"])
    ids = unique_run_ids(runs)
    dt = _settings_dt(results)
    total = len(runs) + 1
    for index, (run, rid) in enumerate(zip(runs, ids, strict=True), start=1):
        data = read_series(run, rid, default_dt=dt if math.isfinite(dt) else 0.05)
        write_run_figure(run, data, figures / f"{rid}.png")
        if on_figure is not None:
            on_figure(index, total)
    write_summary_figure(runs, dt, out_dir / "summary.png")
    pace = write_pace_figure(runs, out_dir / "pace.png")
    if on_figure is not None:
        on_figure(total, total)
    groups = grouped_rows(runs, ids)
    (out_dir / "summary.md").write_text(markdown_table(groups), encoding="utf-8")
    index_path = out_dir / "index.html"
    index_path.write_text(html_page(results, ids, html_table(groups), pace), encoding="utf-8")
    return index_path
