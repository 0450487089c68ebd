"""The time left of a benchmark: its runs on parallel workers, then its report.

:class:`EtaEstimator` learns, from the runs finished so far, the seconds per simulated tick
of each controller kind, and applies them to the runs still queued or running. Runs start
in the order they were planned (a process pool takes its queue first in, first out), so
the runs in flight and their ages are known; the estimate simulates the rest of the queue
on the workers and adds the report phase: the runs' figures drawn in parallel, then the
scenario and summary figures one by one. A kind with no finished run yet is priced from
the kinds that have finished, scaled by its prior cost factor (:data:`PRIOR_FACTORS`).

Every ETA it gives out is kept in :attr:`EtaEstimator.log` as ``(elapsed, eta)`` pairs [s],
so a run's estimates can be compared afterwards with the time it actually took.
"""

from __future__ import annotations

import heapq
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

#: Prior cost of a tick of each controller kind, relative to the others (a substring of
#: the kind's name; the first match counts, 1 otherwise): used until the kind has a run.
#: A tick of a fast path or a baseline costs mostly the simulation around it.
PRIOR_FACTORS: tuple[tuple[str, float], ...] = (("ipopt", 9.0), ("path", 1.4))
#: The report's costs in ticks of a run of prior factor 1, so that they follow the
#: machine's speed and load as the runs saw them: drawing one run's figure (CPU) and
#: starting the report (reading the runs, starting the drawing processes).
RUN_FIGURE_TICKS = 400.0
REPORT_START_TICKS = 1500.0
#: Prior seconds to draw one of the report's other figures (scenarios, summary; drawn one
#: at a time in this process), until one is drawn: they did not follow the runs' speed [s].
OTHER_FIGURE_SECONDS = 0.8
#: Seconds of a tick of prior factor 1 when no run was timed (a report drawn alone) [s].
DEFAULT_TICK_SECONDS = 0.003


def prior_factor(kind: str) -> float:
    """The prior relative cost of a tick of controller ``kind`` (:data:`PRIOR_FACTORS`)."""
    return next((factor for key, factor in PRIOR_FACTORS if key in kind), 1.0)


@dataclass(frozen=True)
class PlannedRun:
    """A run as the estimator sees it: its controller ``kind`` and ``ticks`` simulated."""

    kind: str
    ticks: float


class EtaEstimator:
    """Seconds left of ``runs`` on ``workers`` workers and of the report after them.

    Args:
        clock: seconds from any origin (default :func:`time.perf_counter`; a fake in tests).

    Call :meth:`plan_runs` before the runs start, :meth:`run_finished` as each ends,
    :meth:`plan_report` with the report's size once the runs are known, and
    :meth:`report_progress` as its figures are drawn. :meth:`eta` is the time left [s].
    """

    def __init__(self, clock: Callable[[], float] = time.perf_counter) -> None:
        self.clock = clock
        self.started = clock()
        self.log: list[tuple[float, float]] = []  # (elapsed, eta) [s], as given out
        self.runs: list[PlannedRun] = []
        self.workers = 1
        self._seconds: dict[int, float] = {}  # planned position -> seconds it took
        self._finish_times: list[float] = []  # clock of each finished run, in order
        self._runs_started_at = self.started
        self._runs_ended_at: float | None = None
        self._report: tuple[int, int] | None = None  # (run figures, other figures)
        self._report_done = 0
        self._report_started_at: float | None = None
        self._report_stamps: list[float] = []  # clock of each drawn figure

    @property
    def planned(self) -> bool:
        """Whether the estimator has a plan (runs or a report) to estimate from."""
        return bool(self.runs) or self._report is not None

    # -- the runs ---------------------------------------------------------------------------
    def plan_runs(self, runs: Sequence[PlannedRun], workers: int) -> None:
        """The runs in the order they start, on ``workers`` parallel workers (>= 1)."""
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.runs, self.workers = list(runs), workers
        self._seconds, self._finish_times = {}, []
        self._runs_started_at, self._runs_ended_at = self.clock(), None
        if not self.runs:
            self._runs_ended_at = self._runs_started_at

    def run_finished(self, position: int, seconds: float) -> None:
        """The run at ``position`` of the plan took ``seconds`` [s] (its own wall time)."""
        if not 0 <= position < len(self.runs) or position in self._seconds:
            raise ValueError(f"run {position} is not a planned run still running")
        self._seconds[position] = max(0.0, float(seconds))
        now = self.clock()
        self._finish_times.append(now)
        if len(self._seconds) == len(self.runs):
            self._runs_ended_at = now

    def _spent(self) -> dict[str, tuple[float, float]]:
        """Seconds and ticks of the finished runs, per kind."""
        spent: dict[str, tuple[float, float]] = {}
        for position, seconds in self._seconds.items():
            run = self.runs[position]
            before = spent.get(run.kind, (0.0, 0.0))
            spent[run.kind] = (before[0] + seconds, before[1] + max(run.ticks, 1.0))
        return spent

    def tick_seconds(self) -> float | None:
        """Seconds of a tick of prior factor 1 as the finished runs price it (weighted by
        their ticks); None before any run has finished [s]."""
        spent = self._spent()
        ticks = sum(ticks for _, ticks in spent.values())
        if not ticks:
            return None
        return sum(seconds / prior_factor(kind) for kind, (seconds, _) in spent.items()) / ticks

    def _rates(self) -> dict[str, float]:
        """Seconds per tick of every planned kind: its own runs', or a prior from the others'."""
        unit = self.tick_seconds()
        if unit is None:
            return {}
        own = {kind: seconds / ticks for kind, (seconds, ticks) in self._spent().items()}
        return {run.kind: own.get(run.kind, unit * prior_factor(run.kind)) for run in self.runs}

    def _means(self) -> dict[str, float]:
        """The mean seconds of a finished run, per kind [s]."""
        counts = Counter(self.runs[position].kind for position in self._seconds)
        return {kind: seconds / counts[kind] for kind, (seconds, _) in self._spent().items()}

    def _expected(self, rates: Mapping[str, float], means: Mapping[str, float],
                  run: PlannedRun) -> float:
        """The seconds ``run`` is expected to take [s]: half its kind's seconds per tick
        times its ticks, half the mean seconds of that kind's finished runs. The runs start
        longest first and a run's cost is not in proportion to its ticks (a short run beyond
        the limits makes IPOPT iterate more a tick; every run has a set-up), so each alone
        prices the later runs wrong, in opposite directions."""
        per_tick = rates[run.kind] * max(run.ticks, 1.0)
        mean = means.get(run.kind)
        return per_tick if mean is None else 0.5 * (per_tick + mean)

    def runs_left(self) -> float | None:
        """Seconds until the last run ends; None before any run has finished."""
        if self._runs_ended_at is not None:
            return 0.0
        rates = self._rates()
        if not rates:
            return None
        means = self._means()
        now, workers = self.clock(), self.workers
        # run j starts at the start (j < workers) or when the (j - workers + 1)-th run ends
        started = min(len(self.runs), len(self._finish_times) + workers)
        free: list[float] = []
        for position in range(started):
            if position in self._seconds:
                continue
            began = (self._runs_started_at if position < workers
                     else self._finish_times[position - workers])
            expected = self._expected(rates, means, self.runs[position])
            free.append(now + max(expected - (now - began), 0.0))
        free += [now] * (workers - len(free))
        heapq.heapify(free)
        for run in self.runs[started:]:
            heapq.heappush(free, heapq.heappop(free) + self._expected(rates, means, run))
        return max(free) - now

    # -- the report -------------------------------------------------------------------------
    def plan_report(self, run_figures: int, other_figures: int) -> None:
        """The report to come: ``run_figures`` drawn on the workers, then ``other_figures``
        one after another (0 and 0: no report)."""
        self._report = (max(0, run_figures), max(0, other_figures))

    def report_started(self) -> None:
        """The report begins now (its start-up counted from here)."""
        self._report_started_at = self.clock()

    def report_progress(self, done: int, total: int) -> None:
        """``done`` of the report's ``total`` figures drawn."""
        now = self.clock()
        if self._report_started_at is None:
            self._report_started_at = self._runs_ended_at or now
        runs_part = self._report[0] if self._report else 0
        self._report = (min(runs_part, total), max(0, total - min(runs_part, total)))
        self._report_stamps += [now] * max(0, done - self._report_done)
        self._report_done = done

    def report_left(self) -> float:
        """Seconds the report still needs [s]: priors in ticks of the runs until it has drawn
        figures, then the pace of its own figures (the runs' in parallel, then the others
        one at a time)."""
        if self._report is None:
            return 0.0
        run_figures, others = self._report
        done, stamps, now = self._report_done, self._report_stamps, self.clock()
        parallel = min(self.workers, max(run_figures, 1))
        tick = self.tick_seconds() or DEFAULT_TICK_SECONDS
        drawn_runs = min(done, run_figures)
        if drawn_runs >= 2:  # wall seconds between run figures, the workers all drawing
            run_pace = (stamps[drawn_runs - 1] - stamps[0]) / (drawn_runs - 1)
        else:
            run_pace = RUN_FIGURE_TICKS * tick / parallel
        drawn_others = done - drawn_runs
        if drawn_others >= 1:
            begin = stamps[run_figures - 1] if run_figures else (
                self._report_started_at or now)
            other_pace = (stamps[done - 1] - begin) / drawn_others
        else:
            other_pace = OTHER_FIGURE_SECONDS
        if done == 0:
            began = self._report_started_at
            start = REPORT_START_TICKS * tick
            start = start if began is None else max(start - (now - began), 0.0)
            return start + run_figures * run_pace + others * other_pace
        left = (run_figures - drawn_runs) * run_pace + (others - drawn_others) * other_pace
        return max(left - (now - stamps[-1]), 0.0)

    # -- together ---------------------------------------------------------------------------
    def eta(self) -> float | None:
        """Seconds left of the runs and the report; None until a run has finished (and
        no report has begun). Each value given out is appended to :attr:`log`."""
        runs = self.runs_left()
        if runs is None:
            return None
        left = runs + self.report_left()
        self.log.append((self.clock() - self.started, left))
        return left


def format_seconds(seconds: float | None) -> str:
    """``m:ss`` (``h:mm:ss`` from an hour), ``-:--`` for an unknown time."""
    if seconds is None:
        return "-:--"
    whole = int(round(seconds))
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


def eta_errors(log: Sequence[tuple[float, float]], total: float,
               fractions: Sequence[float] = (0.1, 0.5, 0.9)) -> Mapping[float, float]:
    """The relative error of the ETA given closest before each fraction of ``total`` [s]
    of elapsed time: ``(eta - actual left) / actual left``."""
    errors: dict[float, float] = {}
    for fraction in fractions:
        before = [(elapsed, eta) for elapsed, eta in log if elapsed <= fraction * total]
        if before:
            elapsed, eta = before[-1]
            errors[fraction] = (eta - (total - elapsed)) / (total - elapsed)
    return errors


__all__ = ["EtaEstimator", "PlannedRun", "eta_errors", "format_seconds", "prior_factor"]
