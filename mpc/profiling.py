"""Where a tick's time goes: an optional stopwatch the controller and the solvers mark.

    profile = TickProfile()
    controller.profile = profile          # the solver marks its phases too
    ... controller.step(pose, t) ...       # as many ticks as you like
    print(profile.table())                 # per phase: runs, median, p99, mean a tick [us]

With no profile set (the default) the hot path pays one ``is None`` test a phase.
"""

from __future__ import annotations

import time

import numpy as np


class TickProfile:
    """Durations [s] of named phases, tick after tick (phases in the order first marked).

    A phase need not run every tick (the Hessian rebuild does not): each sample keeps the
    tick it belongs to, so the table shows how often a phase ran and its mean cost per
    tick, whose sum is the mean tick.
    """

    def __init__(self) -> None:
        self.samples: dict[str, list[float]] = {}
        self.ticks: dict[str, list[int]] = {}  # the tick of each sample
        self.count = 0  # ticks started
        self._last = 0.0

    def start(self) -> None:
        """A tick begins."""
        self.count += 1
        self._last = time.perf_counter()

    def mark(self, phase: str) -> None:
        """``phase`` ends now (it began at the previous mark or at :meth:`start`)."""
        now = time.perf_counter()
        self.samples.setdefault(phase, []).append(now - self._last)
        self.ticks.setdefault(phase, []).append(self.count)
        self._last = now

    def medians(self) -> dict[str, float]:
        """Median duration of every phase over the ticks it ran [s]."""
        return {phase: float(np.median(values)) for phase, values in self.samples.items()}

    def table(self, skip: int = 0) -> str:
        """A text table per phase: the ticks it ran, its median and p99 over those [us] and
        its mean cost per tick [us] (the first ``skip`` ticks left out); the last line sums
        the means: the mean tick."""
        ticks = max(self.count - skip, 1)
        lines = [f"{'phase':24s} {'runs':>6s} {'p50 [us]':>9s} {'p99 [us]':>9s} "
                 f"{'mean/tick':>9s}"]
        total = 0.0
        for phase, values in self.samples.items():
            kept = np.asarray(values)[np.asarray(self.ticks[phase]) > skip]
            if kept.size == 0:
                continue
            per_tick = float(kept.sum()) / ticks
            total += per_tick
            lines.append(f"{phase:24s} {kept.size:6d} {np.median(kept) * 1e6:9.1f} "
                         f"{np.percentile(kept, 99) * 1e6:9.1f} {per_tick * 1e6:9.1f}")
        lines.append(f"{'mean tick':24s} {ticks:6d} {'':9s} {'':9s} {total * 1e6:9.1f}")
        return "\n".join(lines)
