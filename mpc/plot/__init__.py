"""Plot and report runs: one figure per run, a report page for one or many runs.

Works the same on the runs of :func:`mpc.sim.simulate`, of a loop of your own recorded by
:class:`mpc.sim.Recorder`, and of ``mpc-bench`` (whose report is drawn by this package)::

    recorder = Recorder(controller.robot, controller.trajectory, controller.dt)
    ...                                             # recorder.record(t, pose, command)
    figure = mpc.plot.plot_run(recorder.result(), skip=1.0)   # a matplotlib Figure
    mpc.plot.report({"mpc": recorder.result()}, "report/", skip=1.0)  # report/index.html

matplotlib is imported on the first call that draws, never by ``import mpc`` or
``import mpc.plot``, nor by the control path. Units: results in SI (m, rad, s, rad/s);
figures show errors in mm, angles in deg, tick times in ms.

Modules, one idea each: :mod:`.record` (a result as plain data), :mod:`.results` (reading
runs and series), :mod:`.headline` (MPC against the best baseline, who won where),
:mod:`.terms` (settings with units, what the words mean), :mod:`.tables`, :mod:`.page`
(HTML); drawing: :mod:`.style`, :mod:`.outline`, :mod:`.run_figure`, :mod:`.compare`;
:mod:`.writer` writes the report folder.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpc.errors import ReportError
from mpc.validation import checked_public as _checked_public
from mpc.validation import shown

from .record import run_record
from .results import load_results, read_series, run_id, validate_results

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from mpc.sim.result import SimResult

    from .writer import Results

__all__ = ["ReportError", "load_results", "plot_run", "report", "run_id", "run_record",
           "validate_results", "write_report"]


def plot_run(result: SimResult | Mapping[str, Any], *, skip: float = 0.0,
             controller: str = "mpc") -> Figure:
    """One run's 2x2 figure: (a) path with footprints and predicted paths [m], (b)
    time-indexed and path errors [mm] and heading error [deg], (c) wheel commands against
    their limits [rad/s], (d) tick times [ms]; the first ``skip`` seconds (left out of the
    metrics) are shaded on the time plots.

    ``result`` is a :class:`~mpc.sim.SimResult` or a run record (:func:`run_record`, a run
    of ``results.json``, whose own ``skip`` then applies). Save it with
    ``figure.savefig("run.png")``; it is on an Agg canvas (no window, no pyplot state).
    """
    from mpc.sim.result import SimResult

    from .run_figure import run_figure

    if isinstance(result, SimResult):
        run: Mapping[str, Any] = run_record(result, skip=skip, controller=controller)
    elif isinstance(result, Mapping):
        validate_results({"runs": [result]}, source="plot_run")
        run = result
    else:
        raise ReportError(f"plot_run takes a SimResult or a run record, got {shown(result)}")
    return run_figure(run, read_series(run, run_id(run), default_dt=0.05, default_skip=skip))


def report(results: Results, out_dir: str | Path, *, skip: float = 0.0,
           labels: Mapping[str, Any] | None = None,
           on_figure: Callable[[int, int], None] | None = None) -> Path:
    """Write the report page of one or many runs; see :func:`mpc.plot.writer.report`."""
    from .writer import report as write

    return write(results, out_dir, skip=skip, labels=labels, on_figure=on_figure)


def write_report(results: Mapping[str, Any], out_dir: str | Path,
                 on_figure: Callable[[int, int], None] | None = None,
                 workers: int = 1) -> Path:
    """Draw a results document (``mpc-bench``'s ``results.json``), the runs' figures on
    ``workers`` processes; see :func:`mpc.plot.writer.write_report`."""
    from .writer import write_report as write

    return write(results, out_dir, on_figure=on_figure, workers=workers)


# Arguments that do not fit a public callable's signature raise ReportError, not TypeError.
_checked_public(globals(), ReportError)
