"""The lookahead grid (:mod:`mpc.control.lookahead`): every window it hands out is the
reference sampled at exactly ``time + offsets`` (the independent answer: the trajectory's
own ``sample``), on a regular clock from a grid sampled once per window, on a clock with
jitter sampled as asked; a reference that fails beyond the window does not fail it."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from mpc import Controller
from mpc.control.lookahead import Lookahead
from mpc.control.timing import ReferenceWindow
from mpc.model import TickInput, TrackingModel, Weights
from mpc.robots import preset
from mpc.sim import simulate
from trajectories import (
    Circle,
    FigureEight,
    FunctionHeading,
    SpinHeading,
    Trajectory,
    TrajectoryError,
)

DT = 0.05
HORIZON = 10
OFFSETS = DT * np.arange(HORIZON + 1.0)


def assert_window(trajectory: Trajectory, ahead: Lookahead, time: float,
                  offsets: np.ndarray) -> None:
    pose, velocity = ahead.window(time)
    direct = trajectory.sample(time + offsets)
    np.testing.assert_allclose(pose, direct.pose, rtol=0, atol=1e-12)
    np.testing.assert_allclose(velocity, direct.velocity, rtol=0, atol=1e-12)


def test_regular_clock_reads_the_grid() -> None:
    trajectory = FigureEight(1.5, 9.0, heading="tangent")
    ahead = Lookahead(trajectory, OFFSETS, DT)
    ticks = 200
    for k in range(ticks):
        assert_window(trajectory, ahead, k * DT, OFFSETS)
    # The first tick's window, then a grid of two windows sharing a point (21 points)
    # every 11 ticks.
    assert ahead.gridded
    assert ahead.samples == 1 + int(np.ceil((ticks - 1) / (HORIZON + 1)))


def test_clock_with_jitter_is_sampled_as_asked() -> None:
    trajectory = FigureEight(1.5, 9.0, heading="tangent")
    ahead = Lookahead(trajectory, OFFSETS, DT)
    times = np.arange(60) * DT + np.random.default_rng(3).uniform(-1e-3, 1e-3, 60)
    for time in times:
        assert_window(trajectory, ahead, float(time), OFFSETS)
    assert ahead.samples == times.size


def test_clock_that_jumps_back_or_ahead() -> None:
    trajectory = Circle(1.0, 6.0, heading="tangent")
    ahead = Lookahead(trajectory, OFFSETS, DT)
    for time in (0.0, DT, 2 * DT, 0.0, 40 * DT, 41 * DT, 5 * DT, 5 * DT, 1e4 + DT):
        assert_window(trajectory, ahead, time, OFFSETS)


@pytest.mark.parametrize(("tick", "gridded"), [(DT / 5, True), (0.013, False)])
def test_short_first_stage(tick: float, gridded: bool) -> None:
    """A tick shorter than the stages: offsets (0, tick + k dt); on the grid of ticks when
    dt is a whole number of them."""
    offsets = np.concatenate(([0.0], tick + DT * np.arange(HORIZON)))
    trajectory = FigureEight(1.5, 9.0, heading="fixed")
    ahead = Lookahead(trajectory, offsets, tick)
    assert ahead.gridded is gridded
    for k in range(80):
        assert_window(trajectory, ahead, k * tick, offsets)
    assert ahead.samples < 20 if gridded else ahead.samples == 80


def _not_finite_after_one_second(t: np.ndarray) -> np.ndarray:
    return np.where(t < 1.0, 0.1 * t, np.inf)


def _raising_after_one_second(t: np.ndarray) -> np.ndarray:
    if np.max(t) >= 1.0:
        raise ValueError("no heading after 1 s")
    return 0.1 * t


@pytest.mark.parametrize(("angle", "error", "message"), [
    (_not_finite_after_one_second, TrajectoryError, "non-finite"),
    (_raising_after_one_second, ValueError, "no heading after 1 s")])
def test_reference_failing_beyond_the_window(angle: Callable[[np.ndarray], np.ndarray],
                                             error: type[Exception], message: str) -> None:
    """A heading that is not finite from t = 1 s on, or whose callable raises its own
    error there: windows before it are served (the grid reaching past it is dropped), the
    first window that reaches it fails as it did without the grid."""
    trajectory = Circle(1.0, 6.0, heading=FunctionHeading(angle, rate=lambda t: 0.1 + 0 * t,
                                                          accel=lambda t: 0 * t))
    ahead = Lookahead(trajectory, OFFSETS, DT)
    last = 1.0 - OFFSETS[-1] - DT  # the last window that ends before 1 s
    for k in range(int(round(last / DT)) + 1):
        assert_window(trajectory, ahead, k * DT, OFFSETS)
    with pytest.raises(error, match=message):
        ahead.window(1.0 - OFFSETS[-1] + DT)


@pytest.mark.parametrize(("heading", "tick"), [("tangent", DT), ("spin", DT),
                                                ("tangent", DT / 2), ("spin", DT / 4)])
def test_window_terms_read_from_the_grid_are_the_windows_own(heading: str,
                                                              tick: float) -> None:
    """On the grid the tick's feedforward and directions are gathered from terms evaluated
    over the whole grid: the same, to rounding, as the terms evaluated on the tick's own
    window (its headings moved by whole turns to the robot's: a spinning reference), with
    stages of one tick and with a first stage shorter than the rest."""
    model = TrackingModel(preset("omni4"), HORIZON, DT, Weights(), tick=tick)
    spec = SpinHeading(3.0) if heading == "spin" else heading
    trajectory = FigureEight(1.5, 9.0, heading=spec)
    grid_tick, own_tick = TickInput(model.layouts), TickInput(model.layouts)
    grid = ReferenceWindow(trajectory, model, grid_tick)
    own = ReferenceWindow(trajectory, model, own_tick)
    for k in range(60):
        time = k * tick
        heading_now = float(trajectory.sample(time).pose[2]) + 2.0 * np.pi * (k % 3 - 1)
        grid.fill(time, heading_now)
        own.fill_at(time + model.offsets, heading_now)
        for name in ("poses_ref", "twists_ref", "directions"):
            np.testing.assert_allclose(getattr(grid_tick, name), getattr(own_tick, name),
                                       rtol=0, atol=1e-12, err_msg=name)
    assert grid.lookahead.samples < 10


@pytest.mark.parametrize("index", [[0], [0, 1, 2, 3], [0, 1, 3, 5, 7], [0, 2, 3, 4, 7, 10, 11]])
def test_strided_rows_are_the_index_gathered(index: list[int]) -> None:
    from mpc.control.lookahead import Strided

    rows = np.array(index)
    grid = np.random.default_rng(2).normal(size=(30, 3))
    out = np.empty((rows.size, 3))
    for first in (0, 5, 30 - rows[-1] - 1):
        Strided(rows).gather(grid, first, out)
        np.testing.assert_array_equal(out, grid[first + rows])


class CountingTrajectory:
    """A trajectory that counts the points it is sampled at."""

    def __init__(self, trajectory: Trajectory) -> None:
        self.trajectory, self.points = trajectory, 0

    def sample(self, times: np.ndarray) -> object:
        self.points += np.size(times)
        return self.trajectory.sample(times)


def test_window_on_a_clock_with_jitter_samples_only_its_points() -> None:
    """Through the window the controller fills (time mode, stages twice the tick): a clock
    with jitter samples N+1 points a tick, no grid; a regular clock far fewer."""
    model = TrackingModel(preset("omni4"), HORIZON, 2 * DT, Weights(), tick=DT)
    counting = CountingTrajectory(FigureEight(1.5, 9.0, heading="tangent"))
    window = ReferenceWindow(counting, model, TickInput(model.layouts))  # type: ignore[arg-type]
    ticks = 50
    jitter = np.random.default_rng(8).uniform(-1e-3, 1e-3, ticks)
    for k in range(ticks):
        window.fill(k * DT + float(jitter[k]), 0.0)
    assert counting.points == ticks * (HORIZON + 1)
    counting.points = 0
    for k in range(ticks):
        window.fill(k * DT, 0.0)
    assert counting.points < ticks * (HORIZON + 1) / 4


def test_a_tick_much_shorter_than_the_stages_samples_each_window() -> None:
    """A grid fill would need more than MAX_POINTS points (1 ms ticks, 0.1 s stages): each
    window is sampled on its own, so no tick carries a fill of thousands of points."""
    from mpc.control.lookahead import MAX_POINTS

    offsets = np.concatenate(([0.0], 0.001 + 0.1 * np.arange(20.0)))
    ahead = Lookahead(FigureEight(1.5, 9.0), offsets, 0.001)
    assert 2 * 1901 + 1 > MAX_POINTS and not ahead.gridded
    assert Lookahead(FigureEight(1.5, 9.0), OFFSETS, DT).gridded


def test_controller_commands_match_sampling_every_window() -> None:
    """The same commands, to rounding, as a controller that samples each window afresh
    (its lookahead made to see every clock as off the grid)."""
    robot = preset("mecanum")
    trajectory = FigureEight(1.2, 8.0, heading="tangent")
    grid = Controller(robot, trajectory, horizon=HORIZON, dt=DT, solver="daqp")
    fresh = Controller(robot, trajectory, horizon=HORIZON, dt=DT, solver="daqp")
    fresh._window.lookahead.gridded = False
    a, b = simulate(grid, 4.0), simulate(fresh, 4.0)
    assert grid._window.lookahead.samples < 20 < fresh._window.lookahead.samples
    np.testing.assert_allclose(a.twist_command, b.twist_command, rtol=0, atol=1e-9)
