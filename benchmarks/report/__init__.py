"""The benchmark's report: :mod:`mpc.plot` draws it, from ``results.json``.

``mpc-bench`` packs each run with :func:`mpc.plot.run_record` (as a run of your own would
be) and draws the report with :func:`mpc.plot.write_report`, so a loop of your own recorded
with :class:`mpc.sim.Recorder` gets the same figures and page. This module keeps the names
``benchmarks.cli`` imports, and :func:`verdict`, the headline in one line.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from mpc.plot import ReportError, load_results, run_id, validate_results, write_report
from mpc.plot.headline import headline

__all__ = ["ReportError", "load_results", "run_id", "validate_results", "verdict",
           "write_report"]


def verdict(runs: Sequence[Mapping[str, Any]]) -> str:
    """The report's headline in one line for the terminal
    (:attr:`mpc.plot.headline.Headline.verdict`), e.g. ``"beyond the wheel limits, MPC
    beats the best baseline in 18 of 20 scenarios (2 ties, 0 losses): a median 0.53x its
    RMS position error"``."""
    return headline(runs).verdict
