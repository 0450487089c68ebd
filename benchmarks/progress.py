"""Progress of long commands: one display, one ETA.

On a terminal (stdout a TTY) finished items print as lines above a ``rich`` progress bar
(done/total, elapsed, the ETA) that disappears at the end; anywhere else (CI logs, pipes,
files, tests) each finished item is one plain flushed line that ends with the ETA. The ETA
comes from an :class:`~benchmarks.eta.EtaEstimator` when the command gives one that has a
plan (the benchmark: per controller kind, and its report), otherwise from the items' mean
pace. ``rich`` is imported only here, and only for a terminal: never by ``mpc``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from types import TracebackType
from typing import Any, TextIO

from benchmarks.eta import EtaEstimator, format_seconds


def is_terminal(stream: TextIO | None = None) -> bool:
    """Whether ``stream`` (default: stdout) is an interactive terminal."""
    stream = sys.stdout if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a real stream
        return False


class Progress:
    """Progress of ``total`` items described as ``description``; a context manager.

    Args:
        total: items expected (0: not known yet; set it with :meth:`update`).
        description: what is counted, e.g. ``"runs"``, shown left of the bar.
        live: draw the bar; None: if stdout is a terminal and ``rich`` is installed.
        console: a ``rich.console.Console`` to draw on (tests); default: stdout's.
        estimator: where the ETA comes from once it has a plan (default: the items' pace).
        clock: seconds from any origin, for the fallback ETA (tests pass a fake).

    Every ETA shown is kept in :attr:`log` as ``(elapsed, eta)`` pairs [s].
    """

    def __init__(self, total: int, description: str, *, live: bool | None = None,
                 console: Any = None, estimator: EtaEstimator | None = None,
                 clock: Callable[[], float] = time.perf_counter) -> None:
        self.total, self.description, self.completed = total, description, 0
        self.live = is_terminal() if live is None else live
        self.estimator = estimator
        self.clock = clock
        self.started = self._stage_started = clock()
        self.log: list[tuple[float, float]] = []
        self._bar: Any = None
        self._task: Any = None
        self._console = console
        if self.live:
            try:
                import rich.progress  # noqa: F401  (only to know it is there)
            except ImportError:
                self.live = False

    def eta(self) -> float | None:
        """Seconds left [s] (None: not known yet), appended to :attr:`log`."""
        if self.estimator is not None and (self.estimator.runs or self.estimator.planned):
            left = self.estimator.eta()
        elif 0 < self.completed <= self.total:
            pace = (self.clock() - self._stage_started) / self.completed
            left = pace * (self.total - self.completed)
        else:
            left = None
        if left is not None:
            self.log.append((self.clock() - self.started, left))
        return left

    def __enter__(self) -> Progress:
        if self.live:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                ProgressColumn,
                TextColumn,
                TimeElapsedColumn,
            )
            from rich.progress import Progress as Bar
            from rich.text import Text

            owner = self

            class EtaColumn(ProgressColumn):
                """The ETA of the whole command, from its estimator."""

                def render(self, task: Any) -> Text:
                    return Text(format_seconds(owner.eta()), style="progress.remaining")

            self._bar = Bar(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("elapsed"), TimeElapsedColumn(), TextColumn("eta"), EtaColumn(),
                console=self._console or Console(), transient=True)
            self._bar.start()
            self._task = self._bar.add_task(self.description, total=self.total or None)
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None

    def print(self, text: str) -> None:
        """A line of output (above the bar on a terminal)."""
        if self._bar is not None:
            self._bar.console.print(text, markup=False, highlight=False, soft_wrap=True)
        else:
            print(text, flush=True)

    def advance(self, line: str | None = None) -> None:
        """One more item done; ``line`` (if any) printed for it."""
        self.update(self.completed + 1, self.total, line)

    def update(self, completed: int, total: int, line: str | None = None) -> None:
        """``completed`` of ``total`` items done; ``line`` (if any) printed, off a terminal
        with the ETA at its end."""
        self.completed, self.total = completed, total
        left = self.eta()
        if line is not None:
            self.print(line if self._bar is not None else f"{line}  eta {format_seconds(left)}")
        if self._bar is not None:
            self._bar.update(self._task, completed=completed, total=total or None)

    def stage(self, description: str, total: int) -> None:
        """A new stage of the same command (e.g. the report after the runs): the bar counts
        its ``total`` items from 0; the ETA goes on."""
        self.description, self.completed, self.total = description, 0, total
        self._stage_started = self.clock()
        if self._bar is not None:
            self._bar.update(self._task, description=description, completed=0,
                             total=total or None)


__all__ = ["Progress", "is_terminal"]
