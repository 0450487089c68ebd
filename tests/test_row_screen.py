"""Rows left out of daqp's problem while no plan needs them (motor rows,
:mod:`mpc.solvers.row_screen`): the bookkeeping by hand, and each tick's plan against the same
QP given every row."""

from __future__ import annotations

import daqp
import numpy as np
import pytest

from benchmarks.motors import scenario_reference
from mpc import Controller
from mpc.model.layout import TickInput
from mpc.robots import motor_preset, preset
from mpc.robots.limits import StageLimits, overshoot, stage_values
from mpc.sim import simulate
from mpc.solvers.dense import DenseSolver, _whiten_stages
from mpc.solvers.row_screen import SCREEN_AFTER, RowScreen

DT = 0.05


def stage_rows(horizon: int = 3) -> StageLimits:
    """Four rows a stage: |vx| <= 1, |vy| <= 2, |omega| <= 3, |vx - vx_before| <= 0.5."""
    now = np.zeros((horizon, 4, 3))
    before = np.zeros((horizon, 4, 3))
    now[:, 0, 0] = now[:, 1, 1] = now[:, 2, 2] = now[:, 3, 0] = 1.0
    before[:, 3, 0] = -1.0
    upper = np.tile([1.0, 2.0, 3.0, 0.5], (horizon, 1))
    return StageLimits(now=now, before=before, lower=-upper, upper=upper, constant=True,
                       change_times=np.full(horizon, DT), screened=True)


def needing(screen: RowScreen, places: list[int]) -> np.ndarray:
    """Multipliers (the solver's row order) with ``places`` active at the middle stage."""
    multipliers = np.zeros(screen.horizon * screen.stage_rows + screen.extra)
    for place in places:
        multipliers[screen.stage_rows + place] = 0.5
    return multipliers


def test_rows_no_plan_needs_for_screen_after_ticks_leave_and_the_stage_rows_come_first() -> None:
    limits = stage_rows()
    screen = RowScreen(limits, extra=2)
    assert screen.rows is None and screen.size == 3 * 4 + 2
    for _ in range(SCREEN_AFTER):
        assert not screen.retire(limits)
        screen.solved(needing(screen, [1]))
    assert screen.retire(limits)
    np.testing.assert_array_equal(screen.in_play, [False, True, False, False])
    np.testing.assert_array_equal(screen.rows, [1, 5, 9, 12, 13])  # then the extra rows
    assert screen.size == 5
    daqp_multipliers = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    every = screen.full(daqp_multipliers)
    np.testing.assert_array_equal(every, [0, 0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.3, 0, 0, 0.4, 0.5])
    np.testing.assert_array_equal(screen.picked(every), daqp_multipliers)
    screen.admit(np.array([3]), limits)
    np.testing.assert_array_equal(screen.rows, [1, 3, 5, 7, 9, 11, 12, 13])
    screen.reset()
    assert screen.rows is None and screen.in_play.all()


def test_a_row_needed_again_stays_and_daqp_keeps_at_least_one_row() -> None:
    limits = stage_rows()
    screen = RowScreen(limits, extra=0)
    for tick in range(SCREEN_AFTER + 10):
        screen.solved(needing(screen, [2] if tick == 30 else []))
    assert screen.retire(limits)  # nothing needed 0, 1, 3 for SCREEN_AFTER ticks; 2 was at 30
    np.testing.assert_array_equal(screen.in_play, [False, False, True, False])
    for _ in range(SCREEN_AFTER):
        screen.solved(needing(screen, []))
    assert not screen.retire(limits)  # every row stale: the last one needed stays
    np.testing.assert_array_equal(screen.in_play, [False, False, True, False])
    screen.solved(needing(screen, [0]), again=True)  # a second solve: the same tick
    screen.admit(np.array([0]), limits)  # broken by a plan: back, needed as of now
    assert screen.retire(limits)  # and row 2, stale, leaves
    np.testing.assert_array_equal(screen.in_play, [True, False, False, False])


def test_equality_rows_never_leave() -> None:
    limits = stage_rows()
    limits.lower[1, 2] = limits.upper[1, 2] = 0.0  # omega = 0 at stage 1
    screen = RowScreen(limits, extra=0)
    for _ in range(SCREEN_AFTER):
        screen.solved(needing(screen, [1]))
    assert screen.retire(limits)
    np.testing.assert_array_equal(screen.in_play, [False, True, True, False])


def test_broken_finds_the_rows_out_of_play_a_plan_breaks_at_any_stage() -> None:
    limits = stage_rows()
    screen = RowScreen(limits, extra=0)
    for _ in range(SCREEN_AFTER):
        screen.solved(needing(screen, [1]))
    screen.retire(limits)  # rows 0, 2, 3 out
    last = np.array([0.9, 0.0, 0.0])
    within = np.array([[0.95, 1.9, 2.0], [0.9, -2.5, -3.0], [0.5, 0.0, 0.0]])
    assert screen.broken(limits, within, last).size == 0  # row 1 (|vy| <= 2) is in play
    rounding = within.copy()
    rounding[1, 2] = -3.0 - 1e-12  # past |omega| <= 3 by rounding only
    assert screen.broken(limits, rounding, last).size == 0
    spin = within.copy()
    spin[2, 2] = 3.1
    np.testing.assert_array_equal(screen.broken(limits, spin, last), [2])
    # Row 3 holds the change from the command before: stage 0's from ``last``.
    np.testing.assert_array_equal(screen.broken(limits, within, np.array([0.2, 0.0, 0.0])),
                                  [3])
    jump = within.copy()
    jump[2, 0] = -0.9  # 0.9 -> -0.9 between stages 1 and 2, and past |vx| <= 1: no
    np.testing.assert_array_equal(screen.broken(limits, jump, last), [3])


def test_robots_without_a_motor_model_hand_daqp_every_row() -> None:
    robot = preset("swerve")
    controller = Controller(robot, scenario_reference("figure8", "fixed", robot, 0.8),
                            horizon=20, dt=DT, solver="daqp")
    solver = controller.solver
    assert isinstance(solver, DenseSolver) and solver._screen is None


@pytest.mark.parametrize(("layout", "mode", "ratio"), [("swerve", "time", 0.8),
                                                       ("ball3", "time", 1.0),
                                                       ("mecanum", "path", 0.8)])
def test_every_plan_with_rows_left_out_is_the_plan_of_every_row(layout: str, mode: str,
                                                                 ratio: float) -> None:
    """Each tick's plan, rows left out of daqp's problem (71 of the swerve's 96 a stage at
    0.8 of the motor model), against the same QP with every row solved cold in a model of
    its own: within every row, and the same cost to daqp's tolerance (a warm and a cold
    solve of the same QP part by up to 4.4e-6 of it, with or without rows left out, on
    these runs). (Closed loops with
    and without screening part as such differences add up: the same RMS error, commands
    apart by up to 0.2 rad/s on the balls.)"""
    robot = motor_preset(layout)
    trajectory = scenario_reference("figure8", "fixed", robot.with_dynamics(None), ratio)
    controller = Controller(robot, trajectory, horizon=20, dt=DT, mode=mode)
    solver = controller.solver
    assert isinstance(solver, DenseSolver) and solver._screen is not None
    check = solver._check_screened
    gaps: list[float] = []

    def compare(tick: TickInput, screen: RowScreen, info: dict[str, object],
                lower: np.ndarray, upper: np.ndarray) -> tuple[int, dict[str, object]]:
        left_out = screen.rows is not None
        flag, info = check(tick, screen, info, lower, upper)
        if not left_out or flag <= 0:
            return flag, info
        limits, unwhiten = solver.limits, solver._unwhiten
        n, m = limits.horizon, limits.rows
        rows = np.empty((lower.size, unwhiten.shape[1]))
        _whiten_stages(limits.now, limits.before, unwhiten, rows[:n * m].reshape(n, m, -1))
        if lower.size > n * m:
            solver._extra.times(unwhiten, out=rows[n * m:])
        gradient = solver._whitened_gradient
        mine = np.linalg.solve(unwhiten, solver._step)  # the plan's step, whitened
        every = daqp.Model()
        assert every.setup(np.eye(gradient.size), gradient, rows, upper, lower,
                           np.zeros(upper.size, dtype=np.intc))[0] >= 0
        cold, _, cold_flag, _ = every.solve()
        assert cold_flag == 1
        values = rows @ mine
        assert np.all(values <= upper + 1e-6) and np.all(values >= lower - 1e-6)

        def cost(y: np.ndarray) -> float:
            return float(0.5 * y @ y + gradient @ y)

        gaps.append(abs(cost(mine) - cost(cold)) / max(1.0, abs(cost(cold))))
        return flag, info

    solver._check_screened = compare  # type: ignore[method-assign]
    simulate(controller, 6.0)
    assert len(gaps) >= 50 and max(gaps) < 2e-5  # the every-row solver's own: up to 4.4e-6
    if layout == "swerve":
        assert solver.screened_solves >= 1  # plans that broke a row left out


def test_a_second_solve_daqp_cannot_set_up_is_a_failed_tick_with_a_safe_command(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Rows a plan broke need a model of their own; daqp refusing it fails the tick with its
    own status, and the fallback sends a command within the limits."""
    robot = motor_preset("swerve")
    trajectory = scenario_reference("figure8", "fixed", robot.with_dynamics(None), 0.8)
    controller = Controller(robot, trajectory, horizon=20, dt=DT)
    solver = controller.solver
    assert isinstance(solver, DenseSolver) and solver._screen is not None
    run = simulate(controller, 3.0)  # 60 ticks: rows have left daqp's problem
    assert solver._screen.rows is not None
    solves = solver.screened_solves
    check = DenseSolver._check_screened

    def refused(self: DenseSolver, *args: object) -> tuple[int, dict[str, object]]:
        with monkeypatch.context() as inner:  # this tick's plan breaks a row left out
            inner.setattr(RowScreen, "broken",
                          lambda screen, *_: np.flatnonzero(~screen.in_play)[:1])
            inner.setattr(DenseSolver, "_set_up", lambda *_, **__: None)
            return check(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(DenseSolver, "_check_screened", refused)
    command = controller.step(run.pose[-1], 3.0)
    assert solver.screened_solves == solves + 1
    assert command.solver_status == "daqp set-up failed (with rows the plan broke)"
    assert command.status.value != "solved"
    assert np.all(np.isfinite(command.wheel_speeds))
    assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))


def test_a_second_solve_gets_what_is_left_of_the_time_limit() -> None:
    """A tick solved again (rows a plan broke, or guards) has one time limit in all: the
    second model gets the limit less the first solve's set-up and solve times, and the
    tick's first model keeps the whole limit."""
    robot = motor_preset("mecanum")
    trajectory = scenario_reference("figure8", "fixed", robot.with_dynamics(None), 0.8)
    controller = Controller(robot, trajectory, horizon=20, dt=DT, time_limit=2e-3)
    solver = controller.solver
    assert isinstance(solver, DenseSolver)
    simulate(controller, 0.1)  # the model is set up
    assert solver._solver is not None
    first = {"solve_time": 6e-4, "setup_time": 1e-4}
    second = daqp.Model()
    second.setup(np.eye(2), np.zeros(2), np.eye(2), np.ones(2), -np.ones(2),
                 np.zeros(2, dtype=np.intc))
    solver._limit_time(second, first)
    assert second.settings["time_limit"] == pytest.approx(2e-3 - 7e-4)
    assert solver._solver.settings["time_limit"] == pytest.approx(2e-3)
    solver._limit_time(second, {"solve_time": 5e-3, "setup_time": 0.0})  # spent already
    assert second.settings["time_limit"] == pytest.approx(1e-6)


def test_stage_values_and_overshoot_by_hand() -> None:
    limits = stage_rows(horizon=2)
    twists = np.array([[0.5, -1.0, 2.0], [1.2, 0.0, -3.5]])
    last = np.array([0.4, 0.0, 0.0])
    # rows: vx, vy, omega, vx - vx_before
    np.testing.assert_allclose(stage_values(limits, twists, last),
                               [[0.5, -1.0, 2.0, 0.1], [1.2, 0.0, -3.5, 0.7]])
    np.testing.assert_allclose(stage_values(limits, twists)[0, 3], 0.5)  # without u_{-1}
    np.testing.assert_allclose(overshoot(limits, stage_values(limits, twists, last)),
                               [[-0.5, -1.0, -1.0, -0.4], [0.2, -2.0, 0.5, 0.2]])
