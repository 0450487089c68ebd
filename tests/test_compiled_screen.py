"""The compiled tick's row screen (:mod:`mpc.tick.screen`, ``tick.c``): rows leave daqp's
problem and the answers stay the optimum of the problem with every row (the Python tick
with its own shortcuts off, an independent solve), rows a plan breaks come back within
the tick, a budget bounds the iterations of all of a tick's solves, and the rule says
which robots get a screen."""

from __future__ import annotations

import functools
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from tick_loop import DT, HORIZON, example_input, plant_step, same_reuse_rule, sanitized_example
from toolchain import needs_compiler

import mpc
import mpc.solvers.row_screen as row_screen
import mpc.tick.screen as screen
from mpc import Command, Controller, Status
from mpc.control.lookahead import Lookahead
from mpc.robots import motor_preset, preset
from mpc.robots.drive.motor_limits import stage_limits
from mpc.robots.wheels.swerve.limits import FACES, GUARD_FACES
from mpc.sim.motor_plant import MotorPlant, MotorPlantConfig
from mpc.tick.runners import NativeTick
from trajectories import FigureEight

#: The motor preset's loop: a figure-eight that takes the motors to their limits.
LOOP = FigureEight(1.0, 4.0, heading="tangent")
TICKS = 120
#: The library (the casadi wheel's daqp 0.5.1) against the Python tick (the daqp module's
#: 0.11): the same optimum to daqp's tolerance, scaled by each field's size (as
#: tests/test_compiled_motor_tick.py).
TOLERANCE = 1e-5

#: The row screen lives in the library's C (the virtual machine hands daqp every row).
pytestmark = needs_compiler


@contextmanager
def screen_after(ticks: int) -> Iterator[None]:
    saved = screen.SCREEN_AFTER
    screen.SCREEN_AFTER = ticks
    try:
        yield
    finally:
        screen.SCREEN_AFTER = saved


@functools.cache
def _motor_loop() -> tuple[list[np.ndarray], list[Command]]:
    """The Python tick (every motor row in daqp's problem, the compiled tick's Hessian
    rule) in a closed loop on the motor plant: its poses and commands."""
    robot = motor_preset("mecanum")
    saved = row_screen.SCREEN_AFTER
    row_screen.SCREEN_AFTER = 10**9
    try:
        with same_reuse_rule():
            controller = Controller(robot, LOOP, horizon=HORIZON, dt=DT)
            start = LOOP.sample(0.0).pose + np.array([0.1, -0.05, 0.1])
            plant = MotorPlant(robot, DT, start, MotorPlantConfig(), np.random.default_rng(0))
            poses, commands = [], []
            for k in range(TICKS):
                poses.append(plant.pose.copy())
                commands.append(controller.step(poses[-1], k * DT))
                plant.apply(commands[-1])
    finally:
        row_screen.SCREEN_AFTER = saved
    return poses, commands


def _assert_same(expected: list[Command], got: list[Command], tolerance: float) -> None:
    for tick, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert a.status is b.status, tick
        for name in ("wheel_speeds", "twist", "predicted_poses", "motor_currents"):
            value, reference = getattr(b, name), getattr(a, name)
            scale = max(1.0, float(np.abs(reference).max()))
            np.testing.assert_allclose(value, reference, rtol=0, atol=tolerance * scale,
                                       err_msg=f"{name}, tick {tick}")


def _runner(controller: Controller) -> NativeTick:
    runner = controller._compiled._runner  # type: ignore[union-attr]
    assert isinstance(runner, NativeTick)
    return runner


def test_screened_rows_leave_and_the_optimum_stays() -> None:
    """Mecanum's motor preset with rows leaving after 5 unneeded ticks: daqp solves with
    fewer rows on most ticks, some ticks are solved again with rows a plan broke, and
    every command is the Python tick's (every row) to daqp's tolerance; with the screen
    off (0) every row is in daqp's problem and nothing is solved again."""
    poses, expected = _motor_loop()
    assert all(command.status is Status.SOLVED for command in expected)
    robot = motor_preset("mecanum")
    for after in (5, 0):
        with same_reuse_rule(), screen_after(after):
            controller = Controller(robot, LOOP, horizon=HORIZON, dt=DT, compiled=True)
        assert controller.tick_path == "compiled"
        assert controller._compiled.screen_after == after  # type: ignore[union-attr]
        runner = _runner(controller)
        every = HORIZON * len(controller._compiled.graphs.screen_places)  # type: ignore[union-attr]
        rows, got = [], []
        for k, pose in enumerate(poses):
            got.append(controller.step(pose, k * DT))
            rows.append(runner.screen_counts()[0])
        again = runner.screen_counts()[1]
        _assert_same(expected, got, TOLERANCE)
        if after:
            assert sum(count < every for count in rows) > TICKS // 2, rows
            assert again >= 1  # a plan broke rows left out: solved again with them
        else:
            assert set(rows) == {every} and again == 0


def test_a_budget_bounds_every_solve_of_a_tick() -> None:
    """With ``max_iter`` given, a tick's solves (the first and those again with broken
    rows) share it: no tick reports more iterations; a tick out of iterations falls back,
    never NaN, never a wheel beyond its limit."""
    poses, _ = _motor_loop()
    robot = motor_preset("mecanum")
    with same_reuse_rule(), screen_after(5):
        controller = Controller(robot, LOOP, horizon=HORIZON, dt=DT, compiled=True,
                                max_iter=30)
    got = [controller.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert _runner(controller).screen_counts()[1] >= 1
    assert max(command.iterations for command in got) <= 30
    assert any(command.solver_status == "maximum iterations reached" for command in got)
    for command in got:
        assert np.all(np.isfinite(command.wheel_speeds))
        assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))


def test_swerve_solves_without_its_guard_faces_until_a_plan_breaks_one() -> None:
    """Swerve: the guard faces (+-45, 90 deg) start out of daqp's problem; a plan that
    turns a module far brings them
    back (a figure-eight whose modules turn past their reach); the commands are those of
    the same library with every face in."""
    trajectory = FigureEight(1.0, 3.0, heading="tangent")
    controllers = []
    for after in (screen.SCREEN_AFTER, 0):
        with same_reuse_rule(), screen_after(after):
            controllers.append(Controller(preset("swerve"), trajectory, horizon=HORIZON,
                                          dt=DT, compiled=True))
    screened, every = controllers
    places = screened._compiled.graphs.screen_places  # type: ignore[union-attr]
    guards = HORIZON * places.count(screen.GUARD)
    assert guards == HORIZON * preset("swerve").n_wheels * len(GUARD_FACES)
    pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
    first = None
    for k in range(TICKS // 2):
        a, b = screened.step(pose, k * DT), every.step(pose, k * DT)
        for name in ("wheel_speeds", "twist", "steer_angles", "predicted_poses"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0,
                                       atol=1e-6, err_msg=f"{name}, tick {k}")
        counts = _runner(screened).screen_counts()
        first = counts if first is None else first
        pose = plant_step(pose, a.twist)
    assert _runner(every).screen_counts() == (HORIZON * len(places), 0)
    # the first tick solved without the guards, then with those its plan broke
    assert first is not None and HORIZON * len(places) - guards < first[0] < HORIZON * len(
        places) and first[1] >= 1
    rows, again = _runner(screened).screen_counts()
    assert again >= 1 and rows <= HORIZON * len(places)  # a plan broke guard faces


def test_the_rule_says_which_ticks_get_a_screen() -> None:
    """A motor model with at least SCREEN_FROM_ROWS rows a stage: every place, in until
    unneeded; fewer (omni-3's 21), a robot without a motor model: none; swerve: its guard
    faces, each module's FACES faces first."""
    times = np.full(4, DT)
    mecanum = stage_limits(motor_preset("mecanum"), times, None)
    assert mecanum.rows >= screen.SCREEN_FROM_ROWS
    assert screen.screened_places(mecanum, True, 0) == (screen.UNTIL_UNNEEDED,) * mecanum.rows
    omni3 = stage_limits(motor_preset("omni3"), times, None)
    assert omni3.rows < screen.SCREEN_FROM_ROWS
    assert screen.screened_places(omni3, True, 0) == ()
    kinematic = stage_limits(preset("mecanum"), times, None)
    assert screen.screened_places(kinematic, False, 0) == ()
    swerve = Controller(preset("swerve"), LOOP, horizon=4, dt=DT, compiled="virtual-machine")
    places = swerve._compiled.graphs.screen_places  # type: ignore[union-attr]
    wheels = preset("swerve").n_wheels
    assert [p for p, kind in enumerate(places) if kind == screen.GUARD] == sorted(
        FACES * module + face for module in range(wheels) for face in GUARD_FACES)
    assert screen.screen_after(places) == screen.SCREEN_AFTER
    assert screen.screen_after(()) == 0


@pytest.mark.parametrize("after", [-1, 0])
def test_no_screen_means_every_row(after: int) -> None:
    """SCREEN_AFTER 0 or below: the controller runs with no screen."""
    with screen_after(after):
        controller = Controller(motor_preset("mecanum"), LOOP, horizon=4, dt=DT,
                                compiled="virtual-machine")
    assert controller._compiled.screen_after == 0  # type: ignore[union-attr]


def test_the_screened_export_runs_clean_under_the_sanitizers(tmp_path: Path) -> None:
    """The exported Mecanum motor library with rows leaving after 5 ticks (its main.c sets
    the controller's screen), built with AddressSanitizer and UndefinedBehaviorSanitizer
    (any report fatal), replays the motor loop clean and gives the compiled tick's
    commands (solves again included)."""
    poses, _ = _motor_loop()
    with same_reuse_rule(), screen_after(5):
        controller = Controller(motor_preset("mecanum"), LOOP, horizon=HORIZON, dt=DT,
                                compiled=True)
    source = mpc.export_c(controller, tmp_path / "src")
    assert "mpc_tick_set_screen(tick, 5);" in (source / "main.c").read_text()
    program = sanitized_example(source, tmp_path / "sanitized")
    ahead = Lookahead(LOOP, controller.model.offsets, DT)
    windows = [ahead.window(k * DT) for k in range(len(poses))]
    expected = [controller.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert _runner(controller).screen_counts()[1] >= 1
    done = subprocess.run([str(program)], input=example_input(poses, windows),
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "runtime error" not in done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == len(poses)
    statuses = (Status.SOLVED, Status.PREVIOUS_PLAN, Status.FEEDFORWARD, Status.STOPPING)
    for tick, (line, command) in enumerate(zip(lines, expected, strict=True)):
        row = np.array(line.split(), dtype=float)
        assert statuses[int(row[0])] is command.status, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:], command.wheel_speeds, rtol=0, atol=1e-9)
