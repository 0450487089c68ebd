"""The compiled tick for axle-offset swerve modules (:mod:`mpc.tick.offset`, the ``mpo700``
preset) and for powered casters (:mod:`mpc.tick.casters`, the ``caster4`` preset): their
graph forms of the clamp (the axle offset's steering-fraction search) and of the commands
against the Python functions on seeded random cases; the compiled library, its virtual
machine and the Python tick over recorded closed loops (a plant that differs from the
model) inside and beyond the limits and through a reference that fails; the exported
libraries; the refusals.

The virtual machine solves with the Python tick's daqp (the module, 0.11) and gives its
commands to 1e-9. The compiled library links the casadi wheel's daqp (0.5.1): where a row
sits within daqp's ``primal_tol`` of its bound the two releases may end on different
active sets (tests/test_compiled_swerve.py), hence :data:`LIBRARY_TOLERANCE` (and
:data:`CASTER_LIBRARY_TOLERANCE`). Each robot's library is compiled once for the module
(the library cache keeps it; every controller of the same set-up loads it).
"""

from __future__ import annotations

import math
import subprocess
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
from toolchain import COMPILED_PATH, needs_cmake

import mpc
import mpc.robots.wheels.swerve.limits as swerve_limits
from mpc import Command, Controller, Status
from mpc.control.clamp import clamp_command
from mpc.control.lookahead import Lookahead
from mpc.control.wheel_output import wheel_commands
from mpc.robots import caster, preset, swerve
from mpc.tick import UnsupportedTickError
from mpc.tick.casters import CasterSteering, caster_modules
from mpc.tick.offset import AxleSteering, axle_modules
from trajectories import FigureEight

#: The compiled library against the Python tick and the virtual machine (module docstring).
LIBRARY_TOLERANCE = 1e-4

SCENARIOS = {
    # name: (reference class, figure-eight period [s])
    "inside": (FigureEight, 16.0),
    "beyond": (FigureEight, 6.0),
    "far beyond": (FigureEight, 3.0),  # modules turning past their reach, drives cut
    "failing reference": (Broken, 16.0),
}


def record(trajectory: FigureEight) -> tuple[list[np.ndarray], list[Command]]:
    """The Python tick of the mpo700 preset in a closed loop on the plant with slip: the
    poses it was given and its commands."""
    with same_reuse_rule():
        controller = Controller(preset("mpo700"), trajectory, horizon=HORIZON, dt=DT)
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
    """No NaN; no drive beyond its limit (the axle offset's ``L (omega + turn / dt) / r``
    in), no module turned more than its steering rate allows in a tick (modulo the flip's
    half turn)."""
    robot = preset("mpo700")
    angles = np.zeros(robot.n_wheels)
    reach = robot.max_steer_rate * DT * (1 + 1e-9)
    for command in commands:
        assert command.steer_angles is not None
        assert np.all(np.isfinite(command.wheel_speeds))
        assert np.all(np.isfinite(command.steer_angles))
        assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        turn = np.mod(command.steer_angles - angles + math.pi / 2, math.pi) - math.pi / 2
        assert np.all(np.abs(turn) <= reach)
        angles = command.steer_angles


@pytest.mark.parametrize("name", SCENARIOS)
def test_compiled_mpo700_matches_the_python_tick(name: str) -> None:
    kind, period = SCENARIOS[name]
    trajectory = kind(1.0, period, heading="tangent")
    poses, expected = record(trajectory)
    if name == "failing reference":
        assert {Status.SOLVED, Status.PREVIOUS_PLAN, Status.STOPPING} <= {
            command.status for command in expected}
    virtual = Controller(preset("mpo700"), trajectory, horizon=HORIZON, dt=DT,
                         compiled="virtual-machine")
    got_virtual = [virtual.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert_same(expected, got_virtual, 1e-9)
    compiled = Controller(preset("mpo700"), trajectory, horizon=HORIZON, dt=DT,
                          compiled=True)
    assert compiled.tick_path == COMPILED_PATH
    got = [compiled.step(pose, k * DT) for k, pose in enumerate(poses)]
    assert_same(expected, got, LIBRARY_TOLERANCE)
    assert_same(got_virtual, got, LIBRARY_TOLERANCE)
    assert_safe(got)
    assert_safe(got_virtual)
    if "beyond" in name:  # the plans ride the limits, the clamp steps in
        assert sum(command.clamped for command in expected) > TICKS // 4


def test_reset_with_steer_angles_starts_from_them() -> None:
    """``reset(last_twist, steer_angles)``: both ticks start from the given angles."""
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    pose = trajectory.sample(0.0).pose
    angles = np.array([1.2, -0.4, 2.9, -3.0])
    with same_reuse_rule():
        python = Controller(preset("mpo700"), trajectory, horizon=HORIZON, dt=DT)
        compiled = Controller(preset("mpo700"), trajectory, horizon=HORIZON, dt=DT,
                              compiled=True)
        commands = []
        for controller in (python, compiled):
            controller.step(pose, 0.0)
            controller.reset(last_twist=np.zeros(3), steer_angles=angles)
            commands.append(controller.step(pose, 0.05))
    assert_same(commands[:1], commands[1:], LIBRARY_TOLERANCE)
    turn = np.mod(commands[1].steer_angles - angles + math.pi / 2, math.pi) - math.pi / 2
    assert np.all(np.abs(turn) <= preset("mpo700").max_steer_rate * DT * (1 + 1e-9))


def test_the_axle_graphs_match_the_python_clamp_and_commands() -> None:
    """``steering_fraction`` (the closed-form turn, then the drives' search), the whole
    clamp and the module commands with the twist they drive, as graphs, against
    :func:`~mpc.robots.wheels.swerve.limits.steering_fraction`,
    :func:`~mpc.control.clamp.clamp_command` and
    :func:`~mpc.control.wheel_output.wheel_commands`, on 1,500 seeded random cases (the
    fraction met at 0, at 1, inside (0, 1), and cut by the drives' search)."""
    robot = preset("mpo700")
    steering = AxleSteering(robot, axle_modules(robot), np.full(HORIZON, DT), DT)
    last, target, steer = ca.SX.sym("last", 3), ca.SX.sym("target", 3), ca.SX.sym("steer", 4)
    fraction = ca.Function("fraction", [last, target, steer],
                           [steering.steering_fraction(last, target, steer)])
    clamped, _ = steering.clamped(target, last, steer)
    speeds, angles, driven = steering.commands(clamped, target, steer)
    whole = ca.Function("whole", [last, target, steer], [clamped, speeds, angles, driven])
    rng = np.random.default_rng(37)
    met = {"zero": 0, "one": 0, "inside": 0, "searched": 0}
    top = 1.0  # [m/s, rad/s] about the preset's limits
    for case in range(1500):
        last_value = robot.desaturate(rng.uniform(-top, top, 3) * rng.choice([0.0, 0.02, 1.0]))
        steer_value = (rng.uniform(-math.pi, math.pi, 4) if case % 3 == 0 else
                       robot.wheel_commands(last_value, rng.uniform(-math.pi, math.pi, 4))[1])
        target_value = (last_value + rng.normal(0.0, 0.05, 3), rng.uniform(-1.5, 1.5, 3) * top,
                        np.zeros(3), last_value * rng.uniform(-1.0, 1.0)
                        + rng.normal(0.0, 0.3, 3))[case % 4]
        expected = swerve_limits.steering_fraction(robot, last_value, target_value,
                                                   steer_value, DT)
        turn = swerve_limits.turn_fraction(robot, last_value, target_value, steer_value, DT)
        got = float(fraction(last_value, target_value, steer_value))
        assert got == pytest.approx(expected, abs=1e-9), case
        met["zero" if expected == 0.0 else "one" if expected == 1.0 else "inside"] += 1
        met["searched"] += int(0.0 < expected < turn)
        twist, _ = clamp_command(robot, target_value, last_value, DT, steer_value)
        sent, wheel_speeds, _, _, steer_angles = wheel_commands(
            robot, twist, target_value, steer_value, None, None, DT, np.full(HORIZON, DT), {})
        out = [np.array(value).ravel() for value in whole(last_value, target_value,
                                                          steer_value)]
        np.testing.assert_allclose(out[0], twist, rtol=0, atol=1e-9, err_msg=str(case))
        np.testing.assert_allclose(out[1], wheel_speeds, rtol=0, atol=1e-9, err_msg=str(case))
        turned = np.mod(out[2] - steer_angles + math.pi, 2 * math.pi) - math.pi
        np.testing.assert_allclose(turned, 0.0, rtol=0, atol=1e-9, err_msg=str(case))
        np.testing.assert_allclose(out[3], sent, rtol=0, atol=1e-9, err_msg=str(case))
    assert min(met.values()) >= 50, met


@pytest.mark.parametrize("options, named", [
    ({"steer_range": (-math.pi, math.pi)}, "a steering range"),
])
def test_axle_offsets_with_what_it_does_not_cover_are_refused_by_name(
        options: dict[str, object], named: str) -> None:
    robot = swerve(module_positions=[[0.24, 0.2], [0.24, -0.2], [-0.24, 0.2], [-0.24, -0.2]],
                   wheel_radius=0.09, max_wheel_speed=12.0, max_steer_rate=24.0,
                   axle_offset=0.045, **options)  # type: ignore[arg-type]
    with pytest.raises(UnsupportedTickError, match="no steering range") as error:
        Controller(robot, FigureEight(1.0, 16.0), horizon=HORIZON, compiled=True)
    assert named in str(error.value)


@needs_cmake
def test_the_exported_mpo700_library_gives_the_compiled_ticks_commands(tmp_path: Path) -> None:
    """``mpc.export_c`` of an mpo700 controller, built with CMake: its example program, fed
    the recorded ticks beyond the limits, gives the compiled tick's statuses, twists, wheel
    speeds and steer angles to 1e-9, the Python tick's to :data:`LIBRARY_TOLERANCE`; built
    with AddressSanitizer and UndefinedBehaviorSanitizer (any report fatal), it runs the
    same ticks clean and gives the same commands."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    poses, expected = record(trajectory)
    compiled = Controller(preset("mpo700"), trajectory, horizon=HORIZON, dt=DT, compiled=True)
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
    # (tick.c's constant-rows path with steer angles: built with the sanitizers too)
    sanitized = sanitized_example(source, tmp_path / "sanitized")
    done = subprocess.run([str(sanitized)], input=text, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "runtime error" not in done.stderr
    again = np.array([line.split() for line in done.stdout.splitlines()], dtype=float)
    np.testing.assert_allclose(again, rows, rtol=0, atol=1e-9)


# -- powered casters (mpc.tick.casters, the caster4 preset) --------------------------------

#: The compiled library against the Python tick on the casters' loops: daqp's tolerance
#: (as above), except beyond the limits at 6 s, where the plans ride several drive and
#: steer rows of a stage at once (more active rows than a stage's three twist components)
#: and the two daqp releases end on different active sets, by up to 1.3e-7 at first
#: (tick 52 of 240); the casters' rows move with the guess, so the next plans carry that
#: further: up to 2.2e-2 rad/s in a steer rate and 1.9e-3 in a twist component on the
#: worst tick measured (daqp iterations 41 against 27 there). That scenario is also run in
#: each tick's own closed loop (:func:`test_the_compiled_casters_track_as_the_python_tick`).
CASTER_LIBRARY_TOLERANCE = {"inside": LIBRARY_TOLERANCE, "beyond": 5e-2,
                            "far beyond": LIBRARY_TOLERANCE,
                            "failing reference": LIBRARY_TOLERANCE}

CASTER_SCENARIOS = {
    "inside": (FigureEight, 16.0),
    "beyond": (FigureEight, 6.0),
    "far beyond": (FigureEight, 3.0),
    "failing reference": (Broken, 16.0),
}


def caster_plant(pose: np.ndarray, angles: np.ndarray,
                 command: Command) -> tuple[np.ndarray, np.ndarray]:
    """A caster plant that differs from the model: the commanded drive and steer rates held
    over the tick, 3 % drive slip, the body moving by the least-squares map of the joint
    rates at the angles as they turn (five Euler substeps; the model predicts the angles
    by RK4 and integrates SE(2) exactly)."""
    robot = preset("caster4")
    assert command.steer_rates is not None
    pose, angles = pose.copy(), angles.copy()
    for _ in range(5):
        twist = robot.joint_twist(command.wheel_speeds * 0.97, command.steer_rates, angles)
        c, s = math.cos(pose[2]), math.sin(pose[2])
        pose += DT / 5 * np.array([c * twist[0] - s * twist[1], s * twist[0] + c * twist[1],
                                   twist[2]])
        angles += DT / 5 * command.steer_rates
    return pose, angles


def caster_loop(controller: Controller, trajectory: FigureEight
                ) -> tuple[list[np.ndarray], list[np.ndarray], list[Command]]:
    """``controller`` in a closed loop on :func:`caster_plant` from a start 0.15 m off
    with the casters straight ahead: the poses, the measured angles and the commands."""
    pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
    angles = np.zeros(4)
    poses, measured, commands = [], [], []
    for k in range(TICKS):
        command = controller.step(pose, k * DT, steer_angles=angles)
        poses.append(pose)
        measured.append(angles)
        commands.append(command)
        pose, angles = caster_plant(pose, angles, command)
    return poses, measured, commands


def assert_same_casters(expected: list[Command], got: list[Command], tolerance: float) -> None:
    for tick, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert a.status is b.status, tick
        assert a.consecutive_failures == b.consecutive_failures, tick
        for name in ("wheel_speeds", "twist", "steer_angles", "steer_rates",
                     "predicted_poses"):
            np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=0,
                                       atol=tolerance, err_msg=f"{name}, tick {tick}")


def assert_safe_casters(commands: list[Command]) -> None:
    """No NaN; no drive or steer rate beyond its limit."""
    robot = preset("caster4")
    for command in commands:
        assert command.steer_rates is not None
        assert np.all(np.isfinite(command.wheel_speeds))
        assert np.all(np.isfinite(command.steer_rates))
        assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        assert np.all(np.abs(command.steer_rates) <= robot.max_steer_rates * (1 + 1e-9))


@pytest.mark.parametrize("name", CASTER_SCENARIOS)
def test_compiled_casters_match_the_python_tick(name: str) -> None:
    kind, period = CASTER_SCENARIOS[name]
    trajectory = kind(1.0, period, heading="tangent")
    with same_reuse_rule():
        python = Controller(preset("caster4"), trajectory, horizon=HORIZON, dt=DT)
        poses, measured, expected = caster_loop(python, trajectory)
    if name == "failing reference":
        assert {Status.SOLVED, Status.PREVIOUS_PLAN, Status.STOPPING} <= {
            command.status for command in expected}
    got: dict[str, list[Command]] = {}
    for compiled in ("virtual-machine", True):
        controller = Controller(preset("caster4"), trajectory, horizon=HORIZON, dt=DT,
                                compiled=compiled)
        assert controller.tick_path == (COMPILED_PATH if compiled is True else compiled)
        got[str(compiled)] = [
            controller.step(pose, k * DT, steer_angles=angles)
            for k, (pose, angles) in enumerate(zip(poses, measured, strict=True))]
    assert_same_casters(expected, got["virtual-machine"], 1e-9)
    assert_same_casters(expected, got["True"], CASTER_LIBRARY_TOLERANCE[name])
    for commands in got.values():
        assert_safe_casters(commands)
    assert_safe_casters(expected)


def test_the_compiled_casters_track_as_the_python_tick() -> None:
    """Beyond the limits (6 s), each tick in its own closed loop on the caster plant: the
    compiled library's RMS position error within 2 % of the Python tick's, every command
    within the joint limits."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    errors = []
    for compiled in (False, True):
        with same_reuse_rule():
            controller = Controller(preset("caster4"), trajectory, horizon=HORIZON, dt=DT,
                                    compiled=compiled)
            poses, _, commands = caster_loop(controller, trajectory)
        assert_safe_casters(commands)
        reference = np.array([trajectory.sample(k * DT).pose[:2] for k in range(TICKS)])
        gap = np.array(poses)[TICKS // 4:, :2] - reference[TICKS // 4:]
        errors.append(float(np.sqrt(np.mean(np.sum(gap**2, axis=1)))))
    assert errors[1] == pytest.approx(errors[0], rel=0.02), errors


def test_the_caster_graphs_match_the_python_clamp_and_commands() -> None:
    """The clamp (:func:`~mpc.robots.wheels.caster.limits.clamp_at`), the joint rates held
    over the tick (:func:`~mpc.control.wheel_output.tick_rates`) and the fallback's
    ``desaturate`` as graphs against the Python functions, on 1,500 seeded random cases
    (each of the clamp's three outcomes at least 200 times: the target kept, a step from
    the last command, the target scaled)."""
    robot = preset("caster4")
    steering = CasterSteering(robot, caster_modules(robot), np.full(HORIZON, DT), DT)
    last, target, steer = ca.SX.sym("last", 3), ca.SX.sym("target", 3), ca.SX.sym("steer", 4)
    clamped, _ = steering.clamped(target, last, steer)
    speeds, angles, driven = steering.commands(clamped, target, steer)
    whole = ca.Function("whole", [last, target, steer],
                        [clamped, speeds, angles, driven, steering.desaturated(target)])
    rng = np.random.default_rng(37)
    met = {"kept": 0, "stepped": 0, "scaled": 0}
    bound = np.concatenate([robot.max_wheel_speed, robot.max_steer_rates])
    for case in range(1500):
        steer_value = rng.uniform(-math.pi, math.pi, 4)
        last_value = rng.uniform(-1.0, 1.0, 3) * rng.choice([0.0, 0.1, 0.5])
        target_value = (last_value + rng.normal(0.0, 0.05, 3), rng.uniform(-1.5, 1.5, 3),
                        last_value * rng.uniform(-1.0, 1.0) + rng.normal(0.0, 0.3, 3))[case % 3]
        rows = np.vstack(robot.joint_rows(steer_value))
        within = np.abs(rows @ target_value) <= bound * (1 + 1e-12) + 1e-12
        start = np.abs(rows @ last_value) <= bound * (1 + 1e-12) + 1e-12
        met["kept" if within.all() else "stepped" if start.all() else "scaled"] += 1
        twist, _ = clamp_command(robot, target_value, last_value, DT, steer_value)
        sent, drive, _, _, steer_angles = wheel_commands(
            robot, twist, target_value, steer_value, steer_value, None, DT,
            np.full(HORIZON, DT), {})
        out = [np.array(value).ravel() for value in whole(last_value, target_value,
                                                          steer_value)]
        for got, want in zip(out, (twist, drive, steer_angles, sent,
                                   robot.desaturate(target_value)), strict=True):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-9, err_msg=str(case))
    assert min(met.values()) >= 200, met


@pytest.mark.parametrize("options, named", [
    ({"max_wheel_accel": 40.0}, "an acceleration limit"),
])
def test_casters_it_does_not_cover_are_refused_by_name(options: dict[str, object],
                                                       named: str) -> None:
    robot = caster(positions=[[0.24, 0.19], [0.24, -0.19], [-0.24, 0.19], [-0.24, -0.19]],
                   offset=0.045, wheel_radius=0.088, max_wheel_speed=15.0, max_steer_rate=8.0,
                   **options)  # type: ignore[arg-type]
    with pytest.raises(UnsupportedTickError, match="powered casters") as error:
        Controller(robot, FigureEight(1.0, 16.0), horizon=HORIZON, compiled=True)
    assert named in str(error.value)
    with pytest.raises(UnsupportedTickError, match="mode='path' on a caster robot"):
        Controller(preset("caster4"), FigureEight(1.0, 16.0), horizon=HORIZON, mode="path",
                   compiled=True)


@needs_cmake
def test_the_exported_caster_library_gives_the_compiled_ticks_commands(tmp_path: Path) -> None:
    """``mpc.export_c`` of a caster controller, built with CMake: its example program, fed
    the recorded ticks (the pose, the reference window, the measured steer angles), gives
    the compiled tick's statuses, twists, drive rates and steer angles to 1e-9."""
    trajectory = FigureEight(1.0, 3.0, heading="tangent")
    with same_reuse_rule():
        python = Controller(preset("caster4"), trajectory, horizon=HORIZON, dt=DT)
        poses, measured, _ = caster_loop(python, trajectory)
    compiled = Controller(preset("caster4"), trajectory, horizon=HORIZON, dt=DT,
                          compiled=True)
    source = mpc.export_c(compiled, tmp_path / "src")
    program = cmake_example(source, tmp_path / "build")
    ahead = Lookahead(trajectory, compiled.model.offsets, DT)
    text = example_input(poses, [ahead.window(k * DT) for k in range(len(poses))])
    text = "".join(line + " " + " ".join(repr(float(a)) for a in angles) + "\n"
                   for line, angles in zip(text.splitlines(), measured, strict=True))
    done = subprocess.run([str(program)], input=text, check=True, capture_output=True,
                          text=True)
    rows = np.array([line.split() for line in done.stdout.splitlines()], dtype=float)
    got = [compiled.step(pose, k * DT, steer_angles=angles)
           for k, (pose, angles) in enumerate(zip(poses, measured, strict=True))]
    assert rows.shape == (len(poses), 1 + 3 + 4 + 4)
    for tick, (row, command) in enumerate(zip(rows, got, strict=True)):
        assert int(row[0]) == 0 and command.status is Status.SOLVED, tick
        values = np.concatenate([command.twist, command.wheel_speeds, command.steer_angles])
        np.testing.assert_allclose(row[1:], values, rtol=0, atol=1e-9, err_msg=str(tick))
