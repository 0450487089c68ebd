"""The compiled tick for swerve robots (:mod:`mpc.tick.steered`): its graph forms of the
clamp's steering fraction, the clamp and the module commands against the Python
functions on seeded random cases; the compiled library, its virtual machine and the Python
tick over recorded closed loops inside and beyond the limits and through a reference that
fails; what it still refuses, by name.

The Python tick is run with its two swerve shortcuts off (guard faces solved only when a
plan breaks one, rows kept while a plan stays inside the disks), as the compiled tick has
every face in daqp's problem: ``python_swerve``. The virtual machine solves with the same
daqp (the Python module) and gives the Python tick's commands to 1e-9. The compiled
library links the casadi wheel's daqp, another release (0.5.1 against the module's
0.11): daqp accepts a plan within ``primal_tol`` (1e-6, in whitened rows) of a bound, and
on ticks where a face or an acceleration row is that close to active the two releases may
end on different active sets; their commands then differ by about that much (the largest
difference seen over these loops was 7.4e-6 rad/s) and the next ticks' guesses carry it
for a few ticks. Hence :data:`LIBRARY_TOLERANCE` for the library against the others.
"""

from __future__ import annotations

import ctypes
import math
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from tick_loop import (
    DT,
    HORIZON,
    TICKS,
    Broken,
    cmake_example,
    example_input,
    plant_step,
    same_reuse_rule,
    sanitized_example,
)
from toolchain import COMPILED_PATH, needs_cmake, needs_compiler

import mpc
import mpc.robots.wheels.swerve.limits as swerve_limits
import mpc.tick.build
from mpc import Command, Controller, ControllerError, Status
from mpc.control.clamp import clamp_command
from mpc.control.lookahead import Lookahead
from mpc.robots import preset, swerve
from mpc.tick import UnsupportedTickError
from mpc.tick.steered import Steering
from trajectories import FigureEight

#: The compiled library against the Python tick and the virtual machine (module docstring).
LIBRARY_TOLERANCE = 1e-4


@contextmanager
def no_guard_faces() -> Iterator[None]:
    """Swerve limits built with every face a row daqp solves with (no guards)."""
    saved = swerve_limits.GUARD_FACES
    swerve_limits.GUARD_FACES = ()
    try:
        yield
    finally:
        swerve_limits.GUARD_FACES = saved


def python_swerve(trajectory: FigureEight) -> Controller:
    """The Python tick with its swerve shortcuts off (module docstring)."""
    with no_guard_faces():
        controller = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT)
    controller.solver.limits.inside = None  # no rows kept from the last tick
    return controller


def record(trajectory: FigureEight) -> tuple[list[np.ndarray], list[Command]]:
    with same_reuse_rule():
        controller = python_swerve(trajectory)
        pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
        poses, commands = [], []
        for k in range(TICKS):
            command = controller.step(pose, k * DT)
            poses.append(pose)
            commands.append(command)
            pose = plant_step(pose, command.twist)
    return poses, commands


def assert_same(expected: list[Command], got: list[Command], tolerance: float) -> None:
    for tick, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert a.status is b.status, tick
        assert a.consecutive_failures == b.consecutive_failures, tick
        assert b.steer_angles is not None and a.steer_angles is not None
        for name in ("wheel_speeds", "twist", "steer_angles", "predicted_poses"):
            np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=0,
                                       atol=tolerance, err_msg=f"{name}, tick {tick}")


def assert_safe(commands: list[Command]) -> None:
    """No NaN; no module beyond its speed, acceleration or steering-rate limit (the angle
    change a tick, modulo the flip rule's half turn)."""
    robot = preset("swerve")
    last, angles = np.zeros(3), np.zeros(robot.n_wheels)
    reach = robot.max_steer_rate * DT * (1 + 1e-9)
    for command in commands:
        assert command.steer_angles is not None
        assert np.all(np.isfinite(command.wheel_speeds))
        assert np.all(np.isfinite(command.steer_angles))
        assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        change = robot.wheel_speeds(command.twist - last)
        assert np.all(change <= robot.max_wheel_accel * DT * (1 + 1e-9))
        turn = np.mod(command.steer_angles - angles + math.pi / 2, math.pi) - math.pi / 2
        assert np.all(np.abs(turn) <= reach)
        last, angles = command.twist, command.steer_angles


SCENARIOS = {
    # name: (reference class, figure-eight period [s])
    "inside": (FigureEight, 16.0),
    "beyond": (FigureEight, 6.0),
    "far beyond": (FigureEight, 3.0),  # modules turning past their reach: the clamp's turn
    "failing reference": (Broken, 16.0),
}


@pytest.mark.parametrize("name", SCENARIOS)
def test_compiled_swerve_matches_the_python_tick(name: str) -> None:
    kind, period = SCENARIOS[name]
    trajectory = kind(1.0, period, heading="tangent")
    poses, expected = record(trajectory)
    if name == "failing reference":
        assert {Status.SOLVED, Status.PREVIOUS_PLAN, Status.STOPPING} <= {
            command.status for command in expected}
    virtual = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT,
                         compiled="virtual-machine")
    got_virtual = [virtual.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert_same(expected, got_virtual, 1e-9)
    compiled = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT, compiled=True)
    assert compiled.tick_path == COMPILED_PATH
    got = [compiled.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert_same(expected, got, LIBRARY_TOLERANCE)
    assert_same(got_virtual, got, LIBRARY_TOLERANCE)
    assert_safe(got)
    assert_safe(got_virtual)
    assert all(0.0 < command.tick_time < 1.0 for command in got + got_virtual)  # [s]
    if "beyond" in name:  # the plans ride the limits, the clamp steps in
        assert sum(command.clamped for command in expected) > TICKS // 4


def test_the_default_python_tick_gives_the_same_commands() -> None:
    """The Python tick with its shortcuts on (guard faces solved again when a plan breaks
    one, rows kept while the plans stay inside the disks, kept rows refilled late): exact
    where they hold, and here the virtual machine gives its commands to 1e-9 too."""
    trajectory = FigureEight(1.0, 3.0, heading=0.0)
    with same_reuse_rule():
        python = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT)
        virtual = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT,
                             compiled="virtual-machine")
        pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
        expected, got = [], []
        for k in range(TICKS // 2):
            expected.append(python.step(pose, k * DT))
            got.append(virtual.step(pose, k * DT))
            pose = plant_step(pose, expected[-1].twist)
    assert_same(expected, got, 1e-9)
    solver = python.solver
    assert solver.guarded_solves > 0 and solver.kept_rows > 0 and solver.late_refills > 0


def test_reset_with_steer_angles_starts_from_them() -> None:
    """``reset(last_twist, steer_angles)``: both ticks start from the given angles (the
    first command turns the modules from there, within the steering rate)."""
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    pose = trajectory.sample(0.0).pose
    angles = np.array([1.2, -0.4, 2.9, -3.0])
    with same_reuse_rule():
        python = python_swerve(trajectory)
        compiled = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT,
                              compiled=True)
        commands = []
        for controller in (python, compiled):
            controller.step(pose, 0.0)
            controller.reset(last_twist=np.zeros(3), steer_angles=angles)
            commands.append(controller.step(pose, 0.05))
    assert_same(commands[:1], commands[1:], LIBRARY_TOLERANCE)
    turn = np.mod(commands[1].steer_angles - angles + math.pi / 2, math.pi) - math.pi / 2
    assert np.all(np.abs(turn) <= preset("swerve").max_steer_rate * DT * (1 + 1e-9))


def _random_cases(rng: np.random.Generator, robot: object, count: int
                  ) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(last, target, steer angles): last within the limits, the modules mostly along it
    (as a tick leaves them) or anywhere; targets near last, far from it, or at rest."""
    top = 1.4  # [m/s, rad/s] about the swerve preset's limits
    for case in range(count):
        last = robot.desaturate(rng.uniform(-top, top, 3) * rng.choice([0.0, 0.02, 1.0]))
        if case % 3 == 0:
            angles = rng.uniform(-math.pi, math.pi, robot.n_wheels)
        else:
            angles = robot.wheel_commands(last, rng.uniform(-math.pi, math.pi,
                                                            robot.n_wheels))[1]
        kind = case % 4
        if kind == 0:
            target = last + rng.normal(0.0, 0.05, 3)
        elif kind == 1:
            target = rng.uniform(-1.5 * top, 1.5 * top, 3)
        elif kind == 2:
            target = np.zeros(3)
        else:
            target = last * rng.uniform(-1.0, 1.0) + rng.normal(0.0, 0.3, 3)
        yield last, target, angles


def test_the_steering_graphs_match_the_python_clamp_and_commands() -> None:
    """``turn_fraction``, the whole clamp and the module commands as graphs against
    :func:`~mpc.robots.wheels.swerve.limits.turn_fraction`,
    :func:`~mpc.control.clamp.clamp_command` and ``SwerveRobot.wheel_commands`` with the
    forward kinematics, on 1,500 seeded random cases (the fraction met strictly inside
    (0, 1), at 0 and at 1)."""
    robot = preset("swerve")
    assert robot.planar_modules is not None
    steering = Steering(robot, robot.planar_modules, np.full(HORIZON, DT), DT)
    last, target, steer = ca.SX.sym("last", 3), ca.SX.sym("target", 3), ca.SX.sym("steer", 4)
    fraction = ca.Function("fraction", [last, target, steer],
                           [steering.turn_fraction(last, target, steer)])
    clamped, _ = steering.clamped(target, last, steer)
    speeds, angles, driven = steering.commands(clamped, target, steer)
    whole = ca.Function("whole", [last, target, steer], [clamped, speeds, angles, driven])
    rng = np.random.default_rng(37)
    met = {"inside": 0, "zero": 0, "one": 0}
    for last_value, target_value, steer_value in _random_cases(rng, robot, 1500):
        expected = swerve_limits.turn_fraction(robot, last_value, target_value, steer_value, DT)
        got = float(fraction(last_value, target_value, steer_value))
        assert got == pytest.approx(expected, abs=1e-9), (last_value, target_value,
                                                          steer_value)
        met["zero" if expected == 0.0 else "one" if expected == 1.0 else "inside"] += 1
        twist, _ = clamp_command(robot, target_value, last_value, DT, steer_value)
        wheel_speeds, steer_angles = robot.wheel_commands(twist, steer_value, target_value, DT)
        out = [np.array(value).ravel() for value in whole(last_value, target_value,
                                                          steer_value)]
        np.testing.assert_allclose(out[0], twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(out[1], wheel_speeds, rtol=0, atol=1e-9)
        turn = np.mod(out[2] - steer_angles + math.pi, 2 * math.pi) - math.pi
        np.testing.assert_allclose(turn, 0.0, rtol=0, atol=1e-9)
        np.testing.assert_allclose(out[3], robot.forward_kinematics(wheel_speeds,
                                                                    steer_angles),
                                   rtol=0, atol=1e-9)
    assert min(met.values()) >= 50, met


@pytest.mark.parametrize("robot, named", [
    (lambda: swerve(module_positions=[[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3], [-0.3, -0.3]],
                    wheel_radius=0.05, max_wheel_speed=30.0, max_steer_rate=12.0,
                    steer_range=(-math.pi, math.pi)), "a steering range"),
])
def test_swerve_robots_it_does_not_cover_are_refused_by_name(robot: object,
                                                             named: str) -> None:
    with pytest.raises(UnsupportedTickError, match="no steering range") as error:
        Controller(robot(), FigureEight(1.0, 16.0), horizon=HORIZON,  # type: ignore[operator]
                   compiled=True)
    assert named in str(error.value)


def test_polygon_rows_are_refused() -> None:
    with pytest.raises(ControllerError, match="polygon_sides=16"):
        Controller(preset("swerve"), FigureEight(1.0, 16.0), horizon=HORIZON,
                   polygon_sides=16, compiled=True)


@needs_cmake
def test_the_exported_swerve_library_gives_the_compiled_ticks_commands(tmp_path: Path) -> None:
    """``mpc.export_c`` of a swerve controller, built with CMake: its example program, fed
    the recorded ticks beyond the limits, gives the compiled tick's statuses, twists, wheel
    speeds and steer angles to 1e-9 (the same C and the same daqp), the Python tick's to
    :data:`LIBRARY_TOLERANCE`; built with AddressSanitizer and UndefinedBehaviorSanitizer
    (any report fatal), it runs the same ticks clean and gives the same commands."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    poses, expected = record(trajectory)
    compiled = Controller(preset("swerve"), trajectory, horizon=HORIZON, dt=DT, compiled=True)
    source = mpc.export_c(compiled, tmp_path / "src")
    program = cmake_example(source, tmp_path / "build")
    ahead = Lookahead(trajectory, compiled.model.offsets, DT)
    text = example_input(poses, [ahead.window(k * DT) for k in range(len(poses))])
    done = subprocess.run([str(program)], input=text, check=True, capture_output=True,
                          text=True)
    rows = np.array([line.split() for line in done.stdout.splitlines()], dtype=float)
    got = [compiled.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert rows.shape == (len(poses), 1 + 3 + 4 + 4)
    for tick, (row, command, reference) in enumerate(zip(rows, got, expected, strict=True)):
        assert int(row[0]) == 0 and command.status is Status.SOLVED, tick
        assert command.steer_angles is not None
        values = np.concatenate([command.twist, command.wheel_speeds, command.steer_angles])
        np.testing.assert_allclose(row[1:], values, rtol=0, atol=1e-9, err_msg=str(tick))
        np.testing.assert_allclose(row[4:8], reference.wheel_speeds, rtol=0,
                                   atol=LIBRARY_TOLERANCE)
    sanitized = sanitized_example(source, tmp_path / "sanitized")
    done = subprocess.run([str(sanitized)], input=text, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "runtime error" not in done.stderr
    again = np.array([line.split() for line in done.stdout.splitlines()], dtype=float)
    np.testing.assert_allclose(again, rows, rtol=0, atol=1e-9)


@needs_compiler
def test_the_row_whitening_in_c_is_the_graphs() -> None:
    """``tick.c``'s ``mpc_tick_whiten_moving`` (swerve's rows whitened every tick) against
    the generated ``mpc_tick_whiten_rows`` in the same library, on seeded random factors and
    rows: the same numbers (each entry summed in the same order), every row at once and, the
    factor kept, the moving rows only (the others left as they were)."""
    robot = preset("swerve")
    controller = Controller(robot, FigureEight(1.0, 16.0), horizon=HORIZON, dt=DT,
                            compiled=True)
    assert controller._compiled is not None
    graphs = controller._compiled.graphs
    library, private = mpc.tick.build.compiled_library(graphs)
    lib = ctypes.CDLL(str(library))
    if private:
        library.unlink()
    function = graphs.whiten_rows
    sizes = [ctypes.c_longlong() for _ in range(4)]
    lib.mpc_tick_whiten_rows_work(*[ctypes.byref(size) for size in sizes])
    rng = np.random.default_rng(7)
    inverse, values = rng.normal(size=function.nnz_in(0)), rng.normal(size=function.nnz_in(1))
    expected, got = np.zeros(function.nnz_out(0)), np.full(function.nnz_out(0), np.nan)
    arguments = (ctypes.c_void_p * max(sizes[0].value, 2))(inverse.ctypes.data,
                                                           values.ctypes.data)
    results = (ctypes.c_void_p * max(sizes[1].value, 1))(expected.ctypes.data)
    iw = np.zeros(max(sizes[2].value, 1), dtype=np.int64)
    w = np.zeros(max(sizes[3].value, 1))
    lib.mpc_tick_whiten_rows.argtypes = [ctypes.c_void_p] * 4 + [ctypes.c_int]
    assert lib.mpc_tick_whiten_rows(arguments, results, iw.ctypes.data, w.ctypes.data, 0) == 0
    lib.mpc_tick_whiten_moving.argtypes = [ctypes.c_void_p] * 3 + [ctypes.c_int]
    lib.mpc_tick_whiten_moving(inverse.ctypes.data, values.ctypes.data, got.ctypes.data, 1)
    np.testing.assert_array_equal(got, expected)
    assert np.abs(expected).max() > 0
    # new values of the moving rows' entries (the others are constants), the factor kept
    pattern = function.sparsity_in(1)
    moves = np.array(graphs.rows_move)[np.array(pattern.row())]
    values[moves] = rng.normal(size=int(moves.sum()))
    assert lib.mpc_tick_whiten_rows(arguments, results, iw.ctypes.data, w.ctypes.data, 0) == 0
    lib.mpc_tick_whiten_moving(inverse.ctypes.data, values.ctypes.data, got.ctypes.data, 0)
    np.testing.assert_array_equal(got, expected)
    assert 0 < sum(graphs.rows_move) < len(graphs.rows_move)
