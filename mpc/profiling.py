"""Where a tick's time goes: an optional stopwatch the controller and the solvers mark.

    profile = TickProfile()
    controller.profile = profile          # the solver marks its phases too
    ... controller.step(pose, t) ...       # as many ticks as you like
    print(profile.table())                 # median and p99 of every phase [us]

With no profile set (the default) the hot path pays one ``is None`` test a phase.
"""

from __future__ import annotations

import time

import numpy as np


class TickProfile:
    """Durations [s] of named phases, tick after tick (phases in the order first marked)."""

    def __init__(self) -> None:
        self.samples: dict[str, list[float]] = {}
        self._last = 0.0

    def start(self) -> None:
        """A tick begins."""
        self._last = time.perf_counter()

    def mark(self, phase: str) -> None:
        """``phase`` ends now (it began at the previous mark or at :meth:`start`)."""
        now = time.perf_counter()
        self.samples.setdefault(phase, []).append(now - self._last)
        self._last = now

    def medians(self) -> dict[str, float]:
        """Median duration of every phase [s]."""
        return {phase: float(np.median(values)) for phase, values in self.samples.items()}

    def table(self, skip: int = 0) -> str:
        """A text table: median and p99 [us] per phase, and their sum (``skip`` first ticks
        left out)."""
        lines = [f"{'phase':24s} {'p50 [us]':>9s} {'p99 [us]':>9s}"]
        total = 0.0
        for phase, values in self.samples.items():
            kept = np.asarray(values[skip:] or values)
            total += float(np.median(kept))
            lines.append(f"{phase:24s} {np.median(kept) * 1e6:9.1f} "
                         f"{np.percentile(kept, 99) * 1e6:9.1f}")
        lines.append(f"{'sum of medians':24s} {total * 1e6:9.1f}")
        return "\n".join(lines)
