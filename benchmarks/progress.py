"""Progress of long commands: a live bar with an ETA on a terminal, plain lines elsewhere.

On a terminal (stdout a TTY) finished items print as lines above a ``rich`` progress bar
(done/total, elapsed, time remaining) that disappears at the end; anywhere else (CI logs,
pipes, files, tests) each finished item is one plain flushed line, nothing else. ``rich``
is imported only here, and only for a terminal: never by ``mpc`` (the control path).
"""

from __future__ import annotations

import sys
from types import TracebackType
from typing import Any, TextIO


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
    """

    def __init__(self, total: int, description: str, *, live: bool | None = None,
                 console: Any = None) -> None:
        self.total, self.description, self.completed = total, description, 0
        self.live = is_terminal() if live is None else live
        self._bar: Any = None
        self._task: Any = None
        self._console = console
        if self.live:
            try:
                import rich.progress  # noqa: F401  (only to know it is there)
            except ImportError:
                self.live = False

    def __enter__(self) -> Progress:
        if self.live:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.progress import Progress as Bar

            self._bar = Bar(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("elapsed"), TimeElapsedColumn(), TextColumn("eta"),
                TimeRemainingColumn(), console=self._console or Console(), transient=True)
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
        """``completed`` of ``total`` items done; ``line`` (if any) printed."""
        self.completed, self.total = completed, total
        if line is not None:
            self.print(line)
        if self._bar is not None:
            self._bar.update(self._task, completed=completed, total=total or None)


__all__ = ["Progress", "is_terminal"]
