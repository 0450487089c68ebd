"""Progress of long commands: plain lines off a terminal, a bar with an ETA on one."""

from __future__ import annotations

import io
import subprocess
import sys

import pytest

from benchmarks.eta import (
    OTHER_FIGURE_SECONDS,
    REPORT_START_TICKS,
    RUN_FIGURE_TICKS,
    EtaEstimator,
    PlannedRun,
    eta_errors,
    format_seconds,
    prior_factor,
)
from benchmarks.progress import Progress, is_terminal


def test_plain_lines_when_not_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    assert not is_terminal()  # pytest captures stdout
    clock = FakeClock()
    with Progress(3, "runs", clock=clock) as progress:
        assert not progress.live
        progress.print("header")
        clock.now = 10.0
        progress.advance("[1/3] first")
        progress.advance()
        progress.update(3, 3, "[3/3] last")
    assert capsys.readouterr().out == "header\n[1/3] first  eta 0:20\n[3/3] last  eta 0:00\n"
    assert progress.completed == 3


def test_live_bar_on_a_terminal_shows_count_and_eta() -> None:
    console = pytest.importorskip("rich.console")
    screen = io.StringIO()
    terminal = console.Console(file=screen, force_terminal=True, width=120)
    with Progress(4, "runs", live=True, console=terminal) as progress:
        assert progress.live
        progress.advance("[1/4] mecanum figure8 fixed inside a-very-long-controller-name")
        progress.advance("[2/4] done")
        progress._bar.refresh()  # what the bar's own thread does 10 times a second
        drawn = screen.getvalue()
    assert "[1/4] mecanum figure8 fixed inside a-very-long-controller-name" in drawn
    assert "2/4" in drawn and "eta" in drawn and "elapsed" in drawn


def test_class_is_a_context_manager_that_survives_an_error() -> None:
    console = pytest.importorskip("rich.console")
    terminal = console.Console(file=io.StringIO(), force_terminal=True)
    progress = Progress(2, "runs", live=True, console=terminal)
    with pytest.raises(RuntimeError), progress:
        raise RuntimeError("a run crashed")
    assert progress._bar is None  # stopped: the terminal is left clean


def test_the_control_path_never_imports_rich() -> None:
    code = ("import sys, mpc, mpc.sim, trajectories, benchmarks.progress\n"
            "import benchmarks.cli\n"
            "assert not any(name.split('.')[0] == 'rich' for name in sys.modules), 'rich'\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


class FakeClock:
    """Seconds set by the test."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_eta_learns_seconds_per_tick_per_kind_with_a_prior_for_unseen_kinds() -> None:
    clock = FakeClock()
    estimator = EtaEstimator(clock)
    slow, fast = PlannedRun("mpc-ipopt", 100), PlannedRun("ff-p-clip", 100)
    estimator.plan_runs([slow, fast, slow, fast], workers=1)
    assert estimator.eta() is None  # nothing to learn from yet
    clock.now = 10.0
    estimator.run_finished(0, 10.0)  # 0.1 s a tick of ipopt
    # ff-p-clip unseen: priced at ipopt's rate over their prior factors
    fast_prior = 10.0 * prior_factor("ff-p-clip") / prior_factor("mpc-ipopt")
    assert estimator.eta() == pytest.approx(fast_prior + 10.0 + fast_prior)
    clock.now = 11.0
    estimator.run_finished(1, 1.0)  # its own rate from now on
    assert estimator.eta() == pytest.approx(10.0 + 1.0)
    clock.now = 15.0  # the third run, 4 s in: 6 s of it left
    assert estimator.eta() == pytest.approx(6.0 + 1.0)
    clock.now = 30.0  # running late: not less than nothing
    assert estimator.eta() == pytest.approx(0.0 + 1.0)
    assert [elapsed for elapsed, _ in estimator.log] == [10.0, 11.0, 15.0, 30.0]


def test_eta_prices_a_run_half_by_its_ticks_half_by_its_kinds_mean() -> None:
    """A kind's runs start longest first; the shorter ones to come are priced half at the
    kind's seconds per tick, half at its mean seconds a run."""
    clock = FakeClock()
    estimator = EtaEstimator(clock)
    estimator.plan_runs([PlannedRun("k", 400), PlannedRun("k", 200), PlannedRun("k", 100)],
                        workers=1)
    clock.now = 4.0
    estimator.run_finished(0, 4.0)  # 0.01 s a tick, 4 s a run
    assert estimator.eta() == pytest.approx(0.5 * (2.0 + 4.0) + 0.5 * (1.0 + 4.0))


def test_eta_of_parallel_workers_follows_the_queue() -> None:
    clock = FakeClock()
    estimator = EtaEstimator(clock)
    runs = [PlannedRun("a", 100), PlannedRun("a", 100), PlannedRun("b", 10),
            PlannedRun("b", 10), PlannedRun("b", 10)]
    estimator.plan_runs(runs, workers=2)
    clock.now = 4.0
    estimator.run_finished(1, 4.0)  # "a": 0.04 s a tick; run 0 is 4 s into its 4 s
    # worker 1 takes runs 2, 3 (prior of "b" = "a"'s rate, factor 1: 0.4 s each) while
    # worker 0 ends run 0 now and takes run 4: the last ends 0.8 s from now
    assert estimator.eta() == pytest.approx(0.8)
    clock.now = 4.2
    estimator.run_finished(2, 0.1)  # "b": 0.01 s a tick; run 3 began at 4.2 and run 0,
    # overdue, is taken to end now: run 4 follows it on that worker
    assert estimator.eta() == pytest.approx(0.1)


def test_eta_counts_the_report_from_priors_then_from_its_figures() -> None:
    clock = FakeClock()
    estimator = EtaEstimator(clock)
    estimator.plan_runs([PlannedRun("a", 10)], workers=2)
    estimator.plan_report(run_figures=4, other_figures=3)
    clock.now = 1.0
    estimator.run_finished(0, 1.0)
    tick = 0.1  # [s] the run's: the report's priors are in ticks of the runs
    assert estimator.tick_seconds() == pytest.approx(tick)
    prior = tick * (REPORT_START_TICKS + 4 * RUN_FIGURE_TICKS / 2) + 3 * OTHER_FIGURE_SECONDS
    assert estimator.eta() == pytest.approx(prior)
    estimator.report_started()
    for done, at in enumerate((3.0, 4.0, 5.0), start=1):  # run figures 1 s apart
        clock.now = at
        estimator.report_progress(done, 7)
    # one run figure left at 1 s, then the others at their prior
    assert estimator.eta() == pytest.approx(1.0 + 3 * OTHER_FIGURE_SECONDS)
    for done, at in ((4, 6.0), (5, 8.0)):  # then one other figure took 2 s
        clock.now = at
        estimator.report_progress(done, 7)
    assert estimator.eta() == pytest.approx(2 * 2.0)
    clock.now = 9.0
    assert estimator.eta() == pytest.approx(3.0)  # 1 s into the next
    estimator.report_progress(7, 7)
    assert estimator.eta() == 0.0


def test_eta_errors_compare_the_log_with_the_time_left() -> None:
    log = [(1.0, 9.0), (5.0, 6.0), (9.0, 0.5)]
    errors = eta_errors(log, 10.0)
    assert errors == pytest.approx({0.1: 0.0, 0.5: 0.2, 0.9: -0.5})
    assert format_seconds(None) == "-:--" and format_seconds(61.4) == "1:01"
    assert format_seconds(3725) == "1:02:05"


def test_progress_shows_the_estimators_eta_and_logs_it(
        capsys: pytest.CaptureFixture[str]) -> None:
    clock = FakeClock()
    estimator = EtaEstimator(clock)
    estimator.plan_runs([PlannedRun("a", 10)] * 3, workers=1)
    with Progress(3, "runs", estimator=estimator, clock=clock) as progress:
        clock.now = 2.0
        estimator.run_finished(0, 2.0)
        progress.advance("[1/3] first (2.0 s)")
    assert capsys.readouterr().out == "[1/3] first (2.0 s)  eta 0:04\n"
    assert progress.log == [(2.0, 4.0)]


def test_progress_without_an_estimator_takes_the_mean_pace(
        capsys: pytest.CaptureFixture[str]) -> None:
    clock = FakeClock()
    with Progress(4, "trials", clock=clock) as progress:
        clock.now = 3.0
        progress.advance("one")
        progress.stage("report", 10)  # a new stage counts from its own start
        clock.now = 5.0
        progress.update(5, 10, "half")
    assert capsys.readouterr().out == "one  eta 0:09\nhalf  eta 0:02\n"


def test_runs_start_with_one_of_each_kind() -> None:
    from benchmarks.executor import RunSpec, start_order

    trajectory = {"shape": "circle", "heading": "fixed", "period": 5.0}
    specs = [RunSpec("omni3", trajectory, name, duration=length)
             for name, length in (("ff-p-clip", 4.0), ("mpc-ipopt", 2.0), ("mpc-ipopt", 3.0),
                                  ("mpc-daqp", 1.0), ("ff-p-clip", 9.0))]
    order = start_order(specs)
    assert sorted(order) == list(range(len(specs)))
    assert [specs[i].controller for i in order[:3]] == ["mpc-ipopt", "ff-p-clip", "mpc-daqp"]
    assert order == [2, 4, 3, 1, 0]  # the costliest of each kind, then longest first
