"""The controller's behaviour tick by tick: fallbacks, bad input, swerve output, reset.

Closed-loop tracking (acceptance) is in test_acceptance.py.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from closed_loop import DT, Loop, check_command, off_start, too_fast_circle

from mpc import Command, Controller, ControllerError, Status
from mpc.profiling import TickProfile
from mpc.robots import SwerveRobot, preset
from mpc.sim import simulate
from mpc.solvers import SolveResult
from trajectories import Circle, FigureEight

# Fallbacks ----------------------------------------------------------------------------


def failed_result(horizon: int) -> SolveResult:
    return SolveResult(success=False, status="injected failure",
                       poses=np.full((horizon + 1, 3), np.nan),
                       twists=np.full((horizon, 3), np.nan), solve_time=0.0, iterations=0)


def test_fallback_sequence_through_a_failure_streak(monkeypatch: pytest.MonkeyPatch) -> None:
    """While the last plan lasts, a streak replays it (the stage each tick falls in), then
    as many ticks of the reference feedforward, then a stop ramp within the acceleration
    limits; then recovery. Plan: one 0.05 s stage, then 9 of 0.1 s: it lasts 19 ticks,
    and tick j of the streak (at j * 0.05 s) falls in stage (j + 1) // 2."""
    horizon = 10
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    controller = Controller(robot, trajectory, horizon=horizon, dt=DT, stage_dt=2 * DT)
    lasts = 19
    loop = Loop(controller, trajectory.sample(0.0).pose)
    solve = controller.solver.solve
    plans: list[SolveResult] = []

    def recording(*args: Any, **kwargs: Any) -> SolveResult:
        result = solve(*args, **kwargs)
        plans.append(result)
        return result

    monkeypatch.setattr(controller.solver, "solve", recording)
    for _ in range(20):
        assert loop.step().status is Status.SOLVED
    plan = plans[-1].twists.copy()

    monkeypatch.setattr(controller.solver, "solve", lambda *a, **k: failed_result(horizon))
    stopping: list[np.ndarray] = []
    for failures in range(1, 2 * lasts + 12):
        t = loop.tick * DT
        command = loop.step()
        assert command.consecutive_failures == failures
        assert command.solver_status == "injected failure"
        if failures < lasts:
            assert command.status is Status.PREVIOUS_PLAN
            np.testing.assert_allclose(command.twist, plan[(failures + 1) // 2], atol=1e-9)
        elif failures < 2 * lasts:
            assert command.status is Status.FEEDFORWARD
            # The reference's own twist over this tick (the robot is on the reference).
            np.testing.assert_allclose(command.twist, trajectory.body_twist(t + DT / 2),
                                       atol=1e-4)
        else:
            assert command.status is Status.STOPPING
            stopping.append(command.twist)
    speeds = np.linalg.norm(stopping, axis=1)
    assert np.all(np.diff(speeds) <= 1e-12)  # the ramp only slows down
    np.testing.assert_array_equal(stopping[-1], np.zeros(3))  # and it stops exactly
    np.testing.assert_array_equal(command.wheel_speeds, np.zeros(robot.n_wheels))

    monkeypatch.setattr(controller.solver, "solve", recording)
    command = loop.step()
    assert command.status is Status.SOLVED
    assert command.consecutive_failures == 0


def test_failure_on_the_first_tick_goes_to_feedforward(monkeypatch: pytest.MonkeyPatch) -> None:
    """No plan yet: the first fallback is the feedforward (desaturated into the limits)."""
    horizon = 5
    trajectory = Circle(1.0, 12.0, heading=0.0)
    controller = Controller(preset("omni3"), trajectory, horizon=horizon)
    monkeypatch.setattr(controller.solver, "solve", lambda *a, **k: failed_result(horizon))
    command = controller.step(trajectory.sample(0.0).pose, 0.0)
    assert command.status is Status.FEEDFORWARD
    assert command.consecutive_failures == 1


@pytest.mark.parametrize("robot_name", ["mecanum", "swerve"])
def test_random_failures_and_random_inputs_never_break_a_limit(
    robot_name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """30% of solves fail (seeded), poses and times are random: never NaN, never a limit
    violation, and consecutive_failures counts the streak."""
    robot = preset(robot_name)
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    # headings whole turns from the reference's on purpose, the first tick's too
    controller = Controller(robot, trajectory, horizon=8, allow_unusual=True)
    solve = controller.solver.solve
    rng = np.random.default_rng(42)
    monkeypatch.setattr(
        controller.solver, "solve",
        lambda *a, **k: failed_result(8) if rng.uniform() < 0.3 else solve(*a, **k))
    last, streak = np.zeros(3), 0
    for _ in range(150):
        t = float(rng.uniform(0.0, 30.0))
        pose = trajectory.sample(t).pose + rng.normal(0.0, [0.3, 0.3, 1.0])
        pose[2] += 2 * math.pi * rng.integers(-3, 4)
        command = controller.step(pose, t)
        check_command(robot, command, last)
        streak = 0 if command.status is Status.SOLVED else streak + 1
        assert command.consecutive_failures == streak
        last = command.twist


# Bad input -------------------------------------------------------------------------------


TRAJECTORY = Circle(1.0, 12.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"solver": "gurobi"}, r"unknown solver 'gurobi'.*'osqp'.*'ipopt'"),
        ({"horizon": 0}, "horizon must be an integer >= 1"),
        ({"horizon": 2.5}, "horizon must be an integer in 1..1000"),
        ({"dt": 0.0}, r"dt \[s\] must be a finite number > 0"),
        ({"dt": -0.05}, r"dt \[s\] must be a finite number > 0"),
        ({"dt": math.nan}, r"dt \[s\] must be a finite number > 0"),
        ({"dt": True}, r"dt \[s\] must be a finite number > 0"),
        ({"time_scaling": "no"}, "time_scaling must be True or False"),
        ({"mode": "contour"}, r"unknown mode 'contour'.*'time', 'path'"),
        ({"mode": "path", "max_progress_rate": 0.5}, "max_progress_rate must be >= 1"),
        ({"max_iter": 0}, "max_iter must be an integer >= 1"),
        ({"polygon_sides": 5}, "polygon_sides must be an even integer >= 4"),
        ({"polygon_sides": 8, "solver": "ipopt"}, "polygon_sides applies to the QP paths"),
        ({"weights": {"pose": 1.0, "bogus": 2.0}}, r"unknown weight name\(s\) \['bogus'\]"),
        ({"weights": {"pose": [1.0, 2.0]}}, r"weight 'pose' must be .* shape \(3,\).*\(2,\)"),
        ({"weights": {"twist": -1.0}}, "weight 'twist' must be finite and >= 0"),
        ({"delay_ticks": -1}, "delay_ticks must be an integer >= 0"),
        ({"command_ramp": "yes"}, "command_ramp must be True or False, got 'yes'"),
        ({"trajectory": "circle"}, "trajectory must be a trajectories.Trajectory, got str"),
        ({"robot": "mecanum"}, "robot must be an mpc.robots.Robot, got str"),
    ],
)
def test_bad_constructor_arguments_raise(kwargs: dict[str, object], message: str) -> None:
    arguments: dict[str, object] = {"robot": preset("mecanum"), "trajectory": TRAJECTORY}
    arguments.update(kwargs)
    with pytest.raises(ControllerError, match=message) as error:
        Controller(**arguments)  # type: ignore[arg-type]
    assert isinstance(error.value, ValueError)


@pytest.mark.parametrize(
    ("pose", "t", "message"),
    [
        ([math.nan, 0.0, 0.0], 0.0, "pose must be finite"),
        ([0.0, math.inf, 0.0], 0.0, "pose must be finite"),
        ([0.0, 0.0], 0.0, r"pose must have shape \(3,\).*got shape \(2,\)"),
        ([[0.0, 0.0, 0.0]], 0.0, r"pose must have shape \(3,\)"),
        (["a", 0.0, 0.0], 0.0, "pose must be 3 numbers"),
        ([0.0, 0.0, 0.0], math.nan, "t must be a finite time"),
        ([0.0, 0.0, 0.0], math.inf, "t must be a finite time"),
        ([0.0, 0.0, 0.0], "1.0", "t must be a finite time"),
    ],
)
def test_bad_step_arguments_raise(pose: object, t: object, message: str) -> None:
    controller = Controller(preset("mecanum"), TRAJECTORY)
    with pytest.raises(ControllerError, match=message) as error:
        controller.step(pose, t)  # type: ignore[arg-type]
    assert isinstance(error.value, ValueError)


def test_bad_reset_and_trajectory_raise() -> None:
    controller = Controller(preset("mecanum"), TRAJECTORY)
    with pytest.raises(ControllerError, match="last_twist must be finite"):
        controller.reset(last_twist=[0.0, math.nan, 0.0])
    with pytest.raises(ControllerError, match=r"last_twist must have shape \(3,\)"):
        controller.reset(last_twist=[0.0, 0.0])
    with pytest.raises(ControllerError, match="trajectory must be a trajectories.Trajectory"):
        controller.trajectory = None  # type: ignore[assignment]
    assert controller.trajectory is TRAJECTORY


# Swerve ----------------------------------------------------------------------------------


def swerve_preset() -> SwerveRobot:
    robot = preset("swerve")
    if not isinstance(robot, SwerveRobot):
        raise AssertionError("the swerve preset is a SwerveRobot")
    return robot


def steer_of(command: Command) -> np.ndarray:
    if command.steer_angles is None:
        raise AssertionError("a swerve command carries steer angles")
    return command.steer_angles


def scripted_solver(controller: Controller, twists: Callable[[int], np.ndarray]
                    ) -> Callable[..., SolveResult]:
    """A solver that always 'succeeds' with the constant plan ``twists(call)``."""
    calls = [0]
    n = controller.horizon

    def solve(*args: object, **kwargs: object) -> SolveResult:
        twist = twists(calls[0])
        calls[0] += 1
        return SolveResult(True, "solved", np.zeros((n + 1, 3)), np.tile(twist, (n, 1)), 0.0, 1)

    return solve


def test_swerve_modules_flip_instead_of_turning_half_a_turn(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Forward, then the same speed backwards: every module keeps its steer angle 0 and
    drives with negative speed (the flip rule against the previous command), instead of
    steering to pi."""
    robot = swerve_preset()
    controller = Controller(robot, TRAJECTORY, horizon=5)
    forward = np.array([0.5, 0.0, 0.0])
    monkeypatch.setattr(controller.solver, "solve", scripted_solver(
        controller, lambda call: forward if call < 10 else -forward))
    commands = [controller.step(np.zeros(3), k * DT) for k in range(25)]
    ahead, reversed_ = commands[9], commands[-1]
    np.testing.assert_allclose(ahead.twist, forward, atol=1e-12)  # through the accel ramp
    np.testing.assert_allclose(steer_of(ahead), 0.0, atol=1e-12)
    assert np.all(ahead.wheel_speeds > 0)
    np.testing.assert_allclose(reversed_.twist, -forward, atol=1e-12)
    np.testing.assert_allclose(steer_of(reversed_), 0.0, atol=1e-12)
    np.testing.assert_allclose(reversed_.wheel_speeds, -0.5 / robot.wheel_radius)
    for command in commands:  # no tick ever asks for a half turn
        np.testing.assert_allclose(steer_of(command), 0.0, atol=1e-12)


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_swerve_modules_turn_at_their_rate_before_driving(
    side: float, monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Modules at 0 rad asked to drive exactly sideways (+-90 deg: no flip): the robot waits
    while the modules turn towards +-90 deg at 12 rad/s (0.6 rad a tick), then drives,
    and no command ever turns a module faster than that."""
    robot = swerve_preset()
    controller = Controller(robot, TRAJECTORY, horizon=5)
    monkeypatch.setattr(controller.solver, "solve", scripted_solver(
        controller, lambda call: np.array([0.0, 0.1 * side, 0.0])))
    commands = [controller.step(np.zeros(3), k * DT) for k in range(5)]
    angles = [steer_of(c) for c in commands]
    np.testing.assert_allclose(angles[0], 0.6 * side, atol=1e-12)
    np.testing.assert_allclose(angles[1], 1.2 * side, atol=1e-12)
    np.testing.assert_allclose(commands[0].twist, 0.0, atol=1e-12)  # waiting, wheels still
    np.testing.assert_array_equal(commands[0].wheel_speeds, 0.0)
    np.testing.assert_allclose(angles[3], math.pi / 2 * side, atol=1e-9)
    assert np.all(commands[4].wheel_speeds > 0)  # driving along the turned modules
    turns = np.abs(np.diff(np.vstack([np.zeros(4), angles]), axis=0))
    assert turns.max() <= robot.max_steer_rate * DT * (1 + 1e-9)


# Reset, new trajectories -------------------------------------------------------------


@pytest.mark.parametrize("solver", ["osqp", "ipopt"])
def test_reset_makes_a_second_run_repeat_the_first(solver: str) -> None:
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    controller = Controller(robot, trajectory, solver=solver)
    first = simulate(controller, 2.0, initial_pose=off_start(trajectory))
    second = simulate(controller, 2.0, initial_pose=off_start(trajectory))  # resets first
    np.testing.assert_allclose(second.wheel_command, first.wheel_command, atol=1e-9)
    np.testing.assert_allclose(second.pose, first.pose, atol=1e-9)


def test_reset_with_last_twist_limits_the_first_step_from_it() -> None:
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    controller = Controller(robot, trajectory)
    moving = np.array([0.0, -0.5, 0.0])  # opposite to the reference's (0, +0.52, 0)
    controller.reset(last_twist=moving)
    command = controller.step(trajectory.sample(0.0).pose, 0.0)
    check_command(robot, command, moving)
    # The plan wants the other way: the first step goes as far from `moving` as a wheel's
    # acceleration limit allows (by the QP's rows or the clamp), no further.
    assert robot.max_wheel_accel is not None
    change = robot.wheel_magnitudes(command.twist - moving) / (robot.max_wheel_accel * DT)
    assert change.max() == pytest.approx(1.0, rel=1e-6)
    controller.reset()
    command = controller.step(trajectory.sample(0.0).pose, 0.0)
    check_command(robot, command, np.zeros(3))


def test_new_trajectory_starts_without_the_old_path_lag() -> None:
    robot = preset("mecanum")
    too_fast = too_fast_circle(robot, overload=1.5)
    controller = Controller(robot, too_fast, mode="path")
    loop = Loop(controller, too_fast.sample(0.0).pose)
    for _ in range(100):
        command = loop.step()
    assert command.reference_time < (loop.tick - 1) * DT - 1.0  # it did fall behind
    controller.trajectory = Circle(1.0, 30.0, heading=0.0)  # slow: no scaling needed
    command = loop.step()
    assert command.reference_time == pytest.approx((loop.tick - 1) * DT)




def test_time_scaling_is_deprecated_for_path_mode() -> None:
    with pytest.warns(DeprecationWarning, match="mode='path'"):
        controller = Controller(preset("mecanum"), TRAJECTORY, time_scaling=True)
    assert controller.mode == "path"
    with pytest.warns(DeprecationWarning):
        assert Controller(preset("mecanum"), TRAJECTORY, time_scaling=False).mode == "time"


# Profiling -----------------------------------------------------------------------------


@pytest.mark.parametrize("solver", ["daqp", "osqp", "ipopt"])
def test_profile_marks_every_phase_of_every_tick(solver: str) -> None:
    """With a TickProfile set, each tick records the controller's phases and the solver's
    own; the phases add up to the tick's wall time; without one nothing is recorded."""
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    controller = Controller(robot, trajectory, horizon=10, solver=solver)
    loop = Loop(controller, trajectory.sample(0.0).pose)
    for _ in range(3):
        loop.step()
    profile = TickProfile()
    controller.profile = profile
    assert controller.solver.profile is profile
    ticks = 5
    began = time.perf_counter()
    for _ in range(ticks):
        loop.step()
    elapsed = time.perf_counter() - began
    phases = profile.samples
    for phase in ("check and predict", "reference", "warm start", "solve (rest)",
                  "clamp and commands"):
        assert len(phases[phase]) == ticks
    if solver == "daqp":
        for phase in ("solve: model", "solve: condense", "solve: whiten", "solve: daqp update",
                      "solve: daqp solve", "solve: checks", "solve: result"):
            assert len(phases[phase]) == ticks
    recorded = sum(sum(values) for values in phases.values())
    assert 0.0 < recorded <= elapsed
    assert "mean tick" in profile.table()
    controller.profile = None
    assert controller.solver.profile is None
    for _ in range(2):
        loop.step()
    assert all(len(values) == ticks or name == "solve: hessian"
               for name, values in phases.items())
    with pytest.raises(ControllerError, match="TickProfile"):
        controller.profile = "yes"  # type: ignore[assignment]


# Logging -------------------------------------------------------------------------------


def test_fallbacks_are_logged_when_they_start_and_end_not_per_tick(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    controller = Controller(robot, trajectory, horizon=10)
    loop = Loop(controller, trajectory.sample(0.0).pose)
    solve = controller.solver.solve
    with caplog.at_level(logging.INFO, logger="mpc"):
        for _ in range(3):
            loop.step()
        assert not caplog.records
        monkeypatch.setattr(controller.solver, "solve", lambda *a, **k: failed_result(10))
        for _ in range(5):
            loop.step()
        monkeypatch.setattr(controller.solver, "solve", solve)
        loop.step()
    messages = [(r.levelname, r.getMessage()) for r in caplog.records]
    assert messages == [("WARNING", "falling back: injected failure"),
                        ("INFO", "solved again after 5 failed ticks")]


@pytest.mark.parametrize(("last_twist", "needle"), [
    ([1e300, 0.0, 0.0], "beyond its limit"),
    ([5.0, 0.0, 0.0], "beyond its limit"),
    ("abc", "last_twist must be 3 numbers"),
    ([True, 0.0, 0.0], "last_twist must be 3 numbers"),
    ([0.1, 0.0], "last_twist must have shape (3,)"),
])
@pytest.mark.parametrize("name", ["mecanum", "swerve", "mpo700"])
def test_reset_refuses_a_last_twist_the_wheels_cannot_drive(name: str, last_twist: Any,
                                                             needle: str) -> None:
    """The twist the robot is executing is checked like any input, and against the wheel
    speed limits: a command stepped from one beyond them went out beyond them too."""
    controller = Controller(preset(name), Circle(0.5, 10.0))
    with pytest.raises(ControllerError, match="last_twist") as raised:
        controller.reset(last_twist=last_twist)
    assert needle in str(raised.value)


@pytest.mark.parametrize("name", ["mecanum", "swerve"])
def test_reset_scales_a_measured_twist_a_little_beyond_the_limits_into_them(name: str) -> None:
    """Odometry at top speed reads a few percent over the limits: up to MEASURED_SLACK over,
    the twist is scaled into the limits (the next command starts from there), not refused
    (a ROS node resetting on its odometry would throw)."""
    from mpc.control.controller import MEASURED_SLACK

    robot = preset(name)
    controller = Controller(robot, Circle(0.5, 10.0))
    top = robot.desaturate(np.array([100.0, 30.0, 2.0]))  # at the limits
    controller.reset(last_twist=top * (1.0 + 0.9 * MEASURED_SLACK))
    assert robot.speed_ratio(controller._last) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(controller._last / np.linalg.norm(controller._last),
                               top / np.linalg.norm(top), atol=1e-12)  # the same direction
    with pytest.raises(ControllerError, match="by more than 10%"):
        controller.reset(last_twist=top * (1.0 + 1.1 * MEASURED_SLACK))


def test_step_arguments_that_do_not_fit_its_signature_are_the_projects_error() -> None:
    controller = Controller(preset("mecanum"), Circle(0.5, 10.0))
    pose = controller.trajectory.sample(0.0).pose
    with pytest.raises(ControllerError, match="unknown keyword argument.*'speed'"):
        controller.step(pose=pose, t=0.0, speed=1)  # type: ignore[call-arg]
    with pytest.raises(ControllerError, match="its parameters are pose, t, steer_angles"):
        controller.step(pose, 0.0, None, 5)  # type: ignore[call-arg]
    assert controller.step(pose, 0.0).wheel_speeds.shape == (4,)


_COMPILER = os.environ.get("CC") or "gcc"


@pytest.mark.skipif(shutil.which(_COMPILER) is None, reason=f"no C compiler ({_COMPILER})")
@pytest.mark.parametrize(("layout", "mode"), [("mecanum", "time"), ("swerve", "path")])
def test_jit_compiled_terms_give_the_same_commands(layout: str, mode: str) -> None:
    """``jit=True`` evaluates the tick's CasADi terms as compiled C: the same commands, to
    the last bit, as CasADi's virtual machine, tick after tick (a turning reference, so the
    Hessian is rebuilt and the swerve faces turn)."""
    robot = preset(layout)
    trajectory = FigureEight(1.0, 8.0, heading="tangent")
    runs = [simulate(Controller(robot, trajectory, horizon=4, mode=mode, jit=jit), 3.0)
            for jit in (False, True)]
    np.testing.assert_array_equal(runs[1].twist_command, runs[0].twist_command)
    np.testing.assert_array_equal(runs[1].wheel_actual, runs[0].wheel_actual)


def test_jit_errors_say_what_was_expected(monkeypatch: pytest.MonkeyPatch) -> None:
    """jit takes a bool, applies to daqp only, and a compiler that cannot run is a
    ControllerError naming what was tried (no temporary files left behind)."""
    robot, trajectory = preset("mecanum"), FigureEight(1.0, 12.0)
    with pytest.raises(ControllerError, match="jit must be True, False or 'auto', got 'yes'"):
        Controller(robot, trajectory, horizon=3, jit="yes")
    with pytest.raises(ControllerError, match="jit must be True, False or 'auto', got 1"):
        Controller(robot, trajectory, horizon=3, jit=1)  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match="solver 'osqp' does not use them"):
        Controller(robot, trajectory, horizon=3, solver="osqp", jit=True)
    monkeypatch.setenv("CC", "/nonexistent/cc")
    before = set(os.listdir(tempfile.gettempdir()))
    with pytest.raises(ControllerError, match=r"needs a C compiler.*/nonexistent/cc"):
        Controller(robot, trajectory, horizon=3, jit=True)
    left = {name for name in set(os.listdir(tempfile.gettempdir())) - before
            if name.startswith("mpc-jit-")}
    assert not left


def test_jit_auto_compiles_where_it_can(monkeypatch: pytest.MonkeyPatch) -> None:
    """``jit="auto"``: compiled C where the compiler works (:attr:`Controller.jit` True), the
    virtual machine where it does not and for solvers without terms to compile (False);
    the same commands either way."""
    robot, trajectory = preset("mecanum"), FigureEight(1.0, 12.0)
    default = Controller(robot, trajectory, horizon=3)
    assert default.jit is False
    assert Controller(robot, trajectory, horizon=3, solver="osqp", jit="auto").jit is False
    monkeypatch.setenv("CC", "/nonexistent/cc")
    fallen_back = Controller(robot, trajectory, horizon=3, jit="auto")
    assert fallen_back.jit is False
    runs = [simulate(default, 1.0), simulate(fallen_back, 1.0)]
    if shutil.which(_COMPILER) is not None:
        monkeypatch.delenv("CC")
        compiled = Controller(robot, trajectory, horizon=3, jit="auto")
        assert compiled.jit is True
        runs.append(simulate(compiled, 1.0))
    for run in runs[1:]:
        np.testing.assert_array_equal(run.twist_command, runs[0].twist_command)


def test_reset_keeps_a_measured_twist_that_a_failed_wheel_reads_as_rounding() -> None:
    """A twist that leaves a failed wheel at rest up to rounding is kept (it was scaled to
    zero: the failed wheel's infinite speed ratio)."""
    robot = preset("mecanum").derated({0: 0.0})
    assert robot.rest_projector is not None
    moving = robot.rest_projector @ np.array([0.5, 0.0, 0.0])
    noisy = moving + np.linalg.pinv(robot.wheel_blocks[0].reshape(-1, 3))[:, 0] * 5e-10
    controller = Controller(robot, Circle(0.5, 10.0))
    controller.reset(last_twist=noisy)
    np.testing.assert_allclose(controller._last, moving, atol=1e-9)
    assert np.linalg.norm(controller._last) > 0.1


def test_only_ticks_from_a_cold_guess_are_solved_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """A tick that fails from a cold guess (the reference's: the first tick, every tick
    after a failed one) is solved once more from the held command; a tick that fails from
    the last plan is not (at most two solves a tick, one from a warm guess)."""
    controller = Controller(preset("mecanum"), Circle(0.5, 10.0))
    calls: list[bool] = []
    fail: set[int] = set()
    solve = controller.solver.solve

    def failing(tick: Any) -> Any:
        calls.append(True)
        result = solve(tick)
        if len(calls) - 1 in fail:
            return dataclasses.replace(result, success=False, status="injected")
        return result

    monkeypatch.setattr(controller.solver, "solve", failing)
    pose = controller.trajectory.sample(0.0).pose
    fail.update(range(100))  # every solve fails: each tick is cold, each solved twice
    for k in range(5):
        controller.step(pose, 0.05 * k)
    assert len(calls) == 10
    controller.reset()
    calls.clear()
    fail.clear()
    fail.add(2)  # tick 0 cold and solved, tick 1 warm, tick 2 warm and fails: no second solve
    statuses = [controller.step(pose, 0.05 * k).status for k in range(4)]
    assert statuses[:2] == [Status.SOLVED, Status.SOLVED] and statuses[2] is not Status.SOLVED
    assert statuses[3] is Status.SOLVED and len(calls) == 4  # tick 3 cold, solved at once
    fail.clear()
    calls.clear()
    controller.reset()
    fail.add(0)  # after reset() the first tick is cold: failed, then solved again
    assert controller.step(pose, 0.0).status is Status.SOLVED and len(calls) == 2
