"""A report folder from one or many runs: figures, ``summary.md`` and ``index.html``.

A report folder holds::

    index.html              self-contained page (inline CSS, no JavaScript)
    summary.md              the full table in Markdown
    headline.png            RMS position and heading error of every controller per scenario
                            in focus (beyond the limits where there are such), a dot each
    scenarios/<id>.png      every controller of a scenario on one path plot
    summary.png             controllers compared across scenarios
    pace.png                lap time against path error per scenario (periodic references)
    figures/<run_id>.png    one 2x2 figure per run
    results.json            the runs as data (written by :func:`report`; ``mpc-bench``
                            keeps its own beside the report folder)

:func:`write_report` draws a results document (``mpc-bench``'s ``results.json``);
:func:`report` first packs results of your own (:class:`~mpc.sim.SimResult` from
:func:`~mpc.sim.simulate` or :class:`~mpc.sim.Recorder`) into such a document.
"""

from __future__ import annotations

import datetime
import json
import math
import multiprocessing
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from mpc.sim.result import SimResult
from mpc.validation import non_negative, shown

from .compare import (
    controllers_of,
    headline_figure,
    scenario_figure,
    write_pace_figure,
    write_summary_figure,
)
from .headline import headline, rankings
from .page import ScenarioFigure, html_page, html_table
from .record import run_record
from .results import (
    ReportError,
    Run,
    load_results,
    read_series,
    safe_name,
    scenario_of,
    scenario_title,
    settings_value,
    unique_run_ids,
    validate_results,
)
from .run_figure import write_run_figure
from .style import save
from .tables import grouped_rows, markdown_table

DEFAULT_DT = 0.05  # [s] for runs whose series and settings both lack a tick


def write_report(results: Mapping[str, Any], out_dir: str | Path,
                 on_figure: Callable[[int, int], None] | None = None,
                 workers: int = 1) -> Path:
    """Write the figures, ``summary.md`` and ``index.html`` of a results document into
    ``out_dir`` (created); return the page's path.

    Each run's figure is ``figures/<run_id>.png`` (repeated ids get ``-2``, ``-3``...).
    ``on_figure(i, total)`` is called after each written figure, ``i`` from 1 to ``total``
    = runs + scenarios + 2 (the headline and summary figures are the last). With
    ``workers`` > 1 the runs' figures are drawn on that many spawned processes (the same
    files); like any spawned process they import the calling script, so call this under
    ``if __name__ == "__main__":`` in a script.

    Raises:
        ReportError: ``results`` lacks ``"runs"`` or a required key of a run, a series
            has the wrong shape, or there are no runs.
    """
    validate_results(results)
    runs: list[Run] = list(results["runs"])
    if not runs:
        raise ReportError("results: no runs to report")
    out = report_folder(out_dir)
    try:
        (out / "figures").mkdir(exist_ok=True)
        (out / "scenarios").mkdir(exist_ok=True)
    except OSError as error:
        raise ReportError(f"out_dir {str(out)!r}: cannot create the report's folders: "
                          f"{error.strerror or error}") from None
    ids = unique_run_ids(runs)
    dt = settings_value(results, "dt")
    skip = settings_value(results, "skip")
    default_skip = skip if math.isfinite(skip) else 0.0
    order = rankings(runs)
    total = len(runs) + len(order) + 2
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if on_figure is not None:
            on_figure(done, total)

    series = [read_series(run, rid, default_dt=dt if math.isfinite(dt) else DEFAULT_DT,
                          default_skip=default_skip) for run, rid in zip(runs, ids, strict=True)]
    _draw_runs([(run, data, out / "figures" / f"{rid}.png")
                for run, data, rid in zip(runs, series, ids, strict=True)], workers, tick)
    controllers = controllers_of(runs)
    scenarios = []
    for ranking in order:
        members = [index for index, run in enumerate(runs)  # path followers drawn too
                   if scenario_of(run) == ranking.scenario]
        src = f"scenarios/{safe_name(ranking.scenario)}.png"
        ratio = f"{ranking.peak_ratio:.2f}" if math.isfinite(ranking.peak_ratio) else "-"
        save(scenario_figure([runs[i] for i in members], [series[i] for i in members],
                             controllers, scenario_title(ranking.scenario, ratio)), out / src)
        scenarios.append(ScenarioFigure(ranking, src))
        tick()
    lead = headline(runs)
    save(headline_figure(lead, runs), out / "headline.png")
    tick()
    write_summary_figure(runs, dt, out / "summary.png")
    pace = write_pace_figure(runs, out / "pace.png")
    tick()
    groups = grouped_rows(runs, ids)
    (out / "summary.md").write_text(markdown_table(groups), encoding="utf-8")
    index = out / "index.html"
    index.write_text(html_page(results, ids, html_table(groups), lead, scenarios, pace),
                     encoding="utf-8")
    return index


def _draw_runs(jobs: Sequence[tuple[Run, Any, Path]], workers: int,
               tick: Callable[[], None]) -> None:
    """Each run's figure, here or on ``workers`` fresh processes (spawned: nothing of this
    process's state, threads or open figures, is carried into them)."""
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ReportError(f"workers must be an integer >= 1, got {shown(workers)}")
    if workers == 1 or len(jobs) < 2 * workers:
        for job in jobs:
            write_run_figure(*job)
            tick()
        return
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        for future in as_completed([pool.submit(write_run_figure, *job) for job in jobs]):
            future.result()
            tick()


Results = (SimResult | Mapping[str, Any] | Sequence[SimResult | Mapping[str, Any]] | str
           | os.PathLike[str])


def report_folder(out_dir: object) -> Path:
    """``out_dir`` as a folder that exists (created with its parents), or ReportError naming
    it: not a path, an existing file, or a folder that cannot be created."""
    if not isinstance(out_dir, (str, os.PathLike)):
        raise ReportError(f"out_dir must be a folder path (str or os.PathLike), "
                          f"got {shown(out_dir)}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ReportError(f"out_dir {str(out)!r} exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ReportError(f"out_dir {str(out)!r}: cannot create the folder: "
                          f"{error.strerror or error}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise ReportError(f"out_dir {str(out)!r} is not writable")
    return out


def results_document(results: Results, *, skip: float = 0.0,
                     labels: Mapping[str, Any] | None = None,
                     command: str = "mpc.plot.report") -> dict[str, Any]:
    """Runs of your own as a results document (what :func:`write_report` draws).

    Args:
        results: one :class:`~mpc.sim.SimResult`; a mapping from controller name to a
            result (several controllers on one scenario); a sequence of results (named
            ``run 1``, ``run 2``...); run records of :func:`~mpc.plot.run_record` in place of
            any result; a whole document (``{"runs": [...]}``, returned as is), or the
            path of one (a ``results.json`` that ``mpc-bench`` or :func:`report` wrote).
        skip: settling time [s] left out of the metrics of the results packed here.
        labels: :func:`run_record` keywords for every result packed here (e.g.
            ``layout``, ``trajectory``, ``speed``, ``peak_ratio``).
        command: what made the runs, shown on the page.
    """
    if isinstance(results, (str, os.PathLike)):
        return load_results(results)
    if isinstance(results, Mapping) and "runs" in results:
        return dict(results)
    named: list[tuple[str | None, SimResult | Mapping[str, Any]]]
    if isinstance(results, SimResult):
        named = [(None, results)]
    elif isinstance(results, Mapping) and "series" in results:
        named = [(None, results)]
    elif isinstance(results, Mapping):
        named = [(str(name), value) for name, value in results.items()]
    elif isinstance(results, Sequence) and not isinstance(results, (str, bytes)):
        named = [(None if len(results) == 1 else f"run {i}", value)
                 for i, value in enumerate(results, start=1)]
    else:
        raise ReportError("results must be a SimResult, a run record, a mapping of names to "
                          f"them, a sequence of them or a results document; got {shown(results)}")
    runs: list[dict[str, Any]] = []
    dt = math.nan
    for name, value in named:
        if isinstance(value, SimResult):
            keywords = dict(labels or {})
            if name is not None:
                keywords["controller"] = name
            runs.append(run_record(value, skip=skip, **keywords))
            dt = value.dt if math.isnan(dt) else dt
        elif isinstance(value, Mapping) and "series" in value:
            runs.append({**value, **({} if name is None else {"controller": name})})
        else:
            raise ReportError(f"results: {name or 'entry'} is neither a SimResult nor a run "
                              f"record, got {type(value).__name__}")
    settings: dict[str, Any] = {"skip": float(skip)}
    if math.isfinite(dt):
        settings = {"dt": dt, **settings}
    created = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return {"meta": {"command": command, "created": created, "settings": settings},
            "runs": runs}


def report(results: Results, out_dir: str | Path, *, skip: float = 0.0,
           labels: Mapping[str, Any] | None = None,
           on_figure: Callable[[int, int], None] | None = None) -> Path:
    """Write the report page of one or many runs into ``out_dir``; return ``index.html``.

    ``results`` is anything :func:`results_document` takes (a result, ``{name: result}``,
    a list of results or run records, or a results document); ``skip`` [s] is the settling
    time left out of the metrics and shaded on the time plots. The runs are also saved as
    ``out_dir/results.json`` (``mpc-bench report`` redraws it).

    Raises:
        ReportError: ``results`` is none of those, or a run record is malformed.
    """
    skip = non_negative("skip [s]", skip, ReportError)
    if labels is not None and not isinstance(labels, Mapping):
        raise ReportError(f"labels must be a mapping of run_record keywords or None, "
                          f"got {shown(labels)}")
    document = results_document(results, skip=skip, labels=labels)
    validate_results(document)
    out = report_folder(out_dir)
    try:
        (out / "results.json").write_text(json.dumps(document), encoding="utf-8")
    except OSError as error:
        raise ReportError(f"out_dir {str(out)!r}: cannot write results.json: "
                          f"{error.strerror or error}") from None
    return write_report(document, out, on_figure=on_figure)
