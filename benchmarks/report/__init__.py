"""The benchmark's report: :mod:`mpc.plot` draws it, from ``results.json``.

``mpc-bench`` packs each run with :func:`mpc.plot.run_record` (as a run of your own would
be) and draws the report with :func:`mpc.plot.write_report`, so a loop of your own recorded
with :class:`mpc.sim.Recorder` gets the same figures and page. This module keeps the names
``benchmarks.cli`` imports.
"""

from __future__ import annotations

from mpc.plot import ReportError, load_results, run_id, validate_results, write_report

__all__ = ["ReportError", "load_results", "run_id", "validate_results", "write_report"]
