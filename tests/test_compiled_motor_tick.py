"""The compiled tick on motor-aware robots (:mod:`mpc.tick.motors`): the motor rows, the
motor clamp and the feedforward as graphs against the Python tick's own functions on
random plans; the compiled library, its virtual machine and the Python tick giving the
same commands over a recorded closed loop on the motor plant (the Python tick's row screen
off: a shortcut of its own, :mod:`mpc.solvers.row_screen`); every command within the
motors' voltage, current and traction limits by a model written out here; swerve's
motor preset refused by name."""

from __future__ import annotations

import functools
import math
import subprocess
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from tick_loop import (
    DT,
    HORIZON,
    Broken,
    cmake_example,
    example_input,
    plant_step,
    same_reuse_rule,
)
from toolchain import COMPILED_PATH, needs_cmake

import mpc
import mpc.solvers.row_screen as row_screen
from benchmarks.compiled_tick import compiled_section
from benchmarks.scenarios import ScenarioError, reference
from mpc import Command, Controller, Status
from mpc.control.clamp import clamp_command
from mpc.control.lookahead import Lookahead
from mpc.robots import motor_preset
from mpc.robots.base import Robot
from mpc.robots.drive.dynamics import GRAVITY, bus_voltage
from mpc.robots.drive.motor_limits import (
    MotorStageLimits,
    stage_limits,
    update_stage_limits,
)
from mpc.robots.drive.motor_step import first_step_feedforward
from mpc.robots.limits import stage_values
from mpc.sim.motor_plant import MotorPlant, MotorPlantConfig
from mpc.tick import UnsupportedTickError
from mpc.tick.graphs import _clamped
from mpc.tick.motors import motor_clamp, motor_feedforward, motor_graphs, motor_wheels
from trajectories import FigureEight

LAYOUTS = ("mecanum", "ball3", "omni3")
LOOP_TICKS = 160
#: The closed loops' reference: a figure-eight that takes the motors to their limits.
LOOP = FigureEight(1.0, 4.0, heading="tangent")


def _random_plan(rng: np.random.Generator, stages: int) -> tuple[np.ndarray, np.ndarray]:
    """Guess twists (stages, 3) and a last command: brisk, turning, some at rest."""
    guess = rng.normal(size=(stages, 3)) * [1.0, 1.0, 3.0]
    guess[rng.random(stages) < 0.2] = 0.0
    return guess, rng.normal(size=3) * [1.0, 1.0, 3.0]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_motor_rows_are_the_python_refill(layout: str) -> None:
    """The rows, their Coriolis and bus-sag terms and bounds, stage 0 widened to the last
    command: the graph's against update_stage_limits' on 30 random plans (unequal stage
    times), to rounding; the bounds on the step from the guess as the Python tick takes
    them (stage 0's part on the last command in its bounds)."""
    robot = motor_preset(layout)
    stages = 5
    times = np.array([0.03, 0.05, 0.05, 0.1, 0.1])
    limits = stage_limits(robot, times, None)
    assert isinstance(limits, MotorStageLimits)
    graphs = motor_graphs(robot, limits)
    guess_sym, last_sym = ca.MX.sym("guess", 3, stages), ca.MX.sym("last", 3)
    rows, lower, upper = graphs.stage_rows(guess_sym, last_sym)
    function = ca.Function("rows", [guess_sym, last_sym], [rows, lower, upper])
    rng = np.random.default_rng(7)
    m = limits.rows
    for _ in range(30):
        guess, last = _random_plan(rng, stages)
        update_stage_limits(robot, limits, guess, last, None)
        got_rows, got_lower, got_upper = (np.asarray(value) for value in function(guess.T, last))
        now = got_rows[:, :stages * m].T.reshape(stages, m, 3)
        before = got_rows[:, stages * m:].T.reshape(stages, m, 3)
        at_guess = stage_values(limits, guess, last)
        for got, expected in ((now, limits.now), (before, limits.before),
                              (got_lower.reshape(stages, m), limits.lower - at_guess),
                              (got_upper.reshape(stages, m), limits.upper - at_guess)):
            np.testing.assert_allclose(got, expected, rtol=0,
                                       atol=1e-12 * max(1.0, np.abs(expected).max()))


@pytest.mark.parametrize("layout", LAYOUTS)
def test_motor_clamp_and_feedforward_are_the_python_ones(layout: str) -> None:
    """The clamp (speed scaling, then the motor passes with the bus-sag bisection and the
    traction disks) and the feedforward, as graphs, against clamp_command and
    first_step_feedforward on 200 random steps, many of them cut by the motors."""
    robot = motor_preset(layout)
    wheels = motor_wheels(robot)
    target, last = ca.SX.sym("target", 3), ca.SX.sym("last", 3)
    kinematic, _ = _clamped(wheels, target, last, DT)
    twist = motor_clamp(robot, wheels, kinematic, last, DT)
    function = ca.Function("clamp", [target, last],
                           [twist, motor_feedforward(robot, last, twist, DT)])
    rng = np.random.default_rng(3)
    cut = 0
    n = robot.n_wheels
    for _ in range(200):
        last_value = rng.normal(size=3) * [0.8, 0.8, 2.0]
        aim = last_value + rng.normal(size=3) * [0.3, 0.3, 1.0] * rng.choice([0.1, 1.0, 5.0])
        expected, changed = clamp_command(robot, aim, last_value, DT)
        got, values = (np.asarray(value).ravel() for value in function(aim, last_value))
        cut += changed
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
        feedforward = first_step_feedforward(robot, last_value, expected, DT, None)
        assert feedforward is not None
        forces, torques, currents, vectors = feedforward
        np.testing.assert_allclose(values, np.concatenate(
            [forces, torques, currents, vectors.ravel()]), rtol=1e-12, atol=1e-9)
        assert values.size == 5 * n
    assert cut > 50  # the motor passes were exercised


@functools.cache
def _motor_loop(layout: str) -> tuple[list[np.ndarray], list[Command]]:
    """A closed loop of the Python tick (the compiled tick's Hessian rule, no row screen)
    on the motor plant, following :data:`LOOP` from off it: the poses it was given and its
    commands (recorded once a session)."""
    robot = motor_preset(layout)
    trajectory = LOOP
    saved = row_screen.SCREEN_AFTER
    row_screen.SCREEN_AFTER = 10**9  # every motor row in daqp's problem, as the compiled tick
    try:
        return _loop(robot, trajectory)
    finally:
        row_screen.SCREEN_AFTER = saved


def _loop(robot: Robot, trajectory: FigureEight) -> tuple[list[np.ndarray], list[Command]]:
    with same_reuse_rule():
        controller = Controller(robot, trajectory, horizon=HORIZON, dt=DT)
        start = trajectory.sample(0.0).pose + np.array([0.1, -0.05, 0.1])
        plant = MotorPlant(robot, DT, start, MotorPlantConfig(), np.random.default_rng(0))
        poses, commands = [], []
        for k in range(LOOP_TICKS):
            pose = plant.pose.copy()
            command = controller.step(pose, k * DT)
            poses.append(pose)
            commands.append(command)
            plant.apply(command)
    return poses, commands


def _assert_same(expected: list[Command], got: list[Command], tolerance: float) -> None:
    for tick, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert a.status is b.status, tick
        assert a.consecutive_failures == b.consecutive_failures, tick
        for name in ("wheel_speeds", "twist", "predicted_poses", "wheel_forces",
                     "motor_torques", "motor_currents", "contact_forces"):
            value, reference = getattr(b, name), getattr(a, name)
            scale = max(1.0, float(np.abs(reference).max()))
            np.testing.assert_allclose(value, reference, rtol=0, atol=tolerance * scale,
                                       err_msg=f"{name}, tick {tick}")


def _assert_within_motors(robot: Robot, commands: list[Command]) -> int:
    """Every command's step from the one before within the motors, by a model written out
    here (not the planner's tables): minimum-norm wheel efforts ``pinv(W') M a`` plus the
    wheels' inertia, at both ends of the step (each end's Coriolis term), the voltage
    ``w / kv + R T / kt`` within the bus under that end's power, the torque within the
    current limit, each contact's force within ``mu N`` (equal static loads: the presets
    are balanced about their centres); or, where holding the last command already breaks
    a limit (a fast turn's Coriolis term alone), no further beyond it than holding does:
    the clamp's rule. Returns how many steps came within 2 % of a limit."""
    dyn = robot.dynamics
    assert dyn is not None
    motor = dyn.motor.with_reduction(dyn.gearing)  # WPILib's DCMotor, at the wheel
    kv, kt, resistance = motor.kv, motor.kt, motor.R
    blocks = robot.wheel_blocks[:, 0, :]  # (n, 3)
    mass = np.diag([dyn.mass, dyn.mass, dyn.yaw_inertia])
    efforts = np.linalg.pinv(blocks.T) @ mass  # wheel torque per body acceleration
    positions = np.round(robot.wheel_positions, 9)
    contacts = sorted({tuple(p) for p in positions.tolist()})
    load = dyn.mass * GRAVITY / len(contacts)
    assert np.allclose(np.array(contacts).mean(axis=0), 0.0, atol=1e-9)
    torque_limit = (math.inf if dyn.current_limit is None
                    else motor.torque(dyn.current_limit * motor.count))
    friction = math.inf if dyn.friction is None else dyn.friction

    def used(speed_twist: np.ndarray, change: np.ndarray, turning: np.ndarray) -> np.ndarray:
        """Each limit's share used: voltages over the bus, torques, contact forces."""
        acceleration = change + np.array([-turning[2] * turning[1],
                                          turning[2] * turning[0], 0.0])
        effort = efforts @ acceleration
        torque = effort + dyn.wheel_inertia * (blocks @ change)
        volts = blocks @ speed_twist / kv + resistance * torque / kt
        bus = bus_voltage(dyn.battery_voltage, dyn.battery_resistance,
                          float(volts @ torque) / kt)
        forces = [np.hypot(*(blocks[np.all(positions == point, axis=1), :2]
                             * effort[np.all(positions == point, axis=1), None]).sum(axis=0))
                  for point in contacts]
        return np.concatenate([np.abs(volts) / bus, np.abs(torque) / torque_limit,
                               np.array(forces) / (friction * load)])

    last, near = np.zeros(3), 0
    for command in commands:
        twist = command.twist
        change = (twist - last) / DT
        held = np.maximum(used(last, np.zeros(3), last), 1.0)
        for end in (last, twist):
            share = used(end, change, end)
            assert np.all(share <= held * (1 + 1e-9)), (share, held)
            near += bool(np.any(share > 0.98))
        last = twist
    return near


@pytest.mark.parametrize("layout", ["mecanum", "ball3"])
def test_compiled_motor_tick_matches_the_python_tick(layout: str) -> None:
    """160 ticks on the motor plant (a figure-eight that takes the motors to their limits, a
    start off the reference): the compiled library and its virtual machine replaying the
    poses the Python tick was given give its statuses, commands, plans and feedforward,
    never NaN, every command within the motors. The virtual machine (the daqp module, as
    the Python tick) to 1e-9; the library links the casadi wheel's daqp 0.5.1, another
    release (pivot tolerance 1e-6 against 1e-8; both take rows met to 1e-6 as met), and
    its solutions of the motor QPs agree to that tolerance, not to rounding (measured:
    2.3e-6 in a ball3 twist, 1e-12 on Mecanum): 1e-5. Tolerances scaled by each field's
    size."""
    trajectory = LOOP
    poses, expected = _motor_loop(layout)
    robot = motor_preset(layout)
    assert sum(c.status is Status.SOLVED for c in expected) == LOOP_TICKS
    with same_reuse_rule():
        compiled = Controller(robot, trajectory, horizon=HORIZON, dt=DT, compiled=True)
        machine = Controller(robot, trajectory, horizon=HORIZON, dt=DT,
                             compiled="virtual-machine")
    assert compiled.tick_path == COMPILED_PATH
    for controller, tolerance in ((compiled, 1e-5), (machine, 1e-9)):
        got = [controller.step(pose, k * DT) for k, pose in enumerate(poses)]
        _assert_same(expected, got, tolerance)
        for command in got:
            for name in ("wheel_speeds", "twist", "predicted_poses", "motor_currents",
                         "contact_forces"):
                assert np.all(np.isfinite(getattr(command, name)))
            assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        assert _assert_within_motors(robot, got) >= 1  # the motors' limits were reached


def test_swerve_motor_preset_is_refused_by_name() -> None:
    trajectory = FigureEight(1.0, 8.0, heading="tangent")
    with pytest.raises(UnsupportedTickError, match=r"swerve with .*a motor model"):
        Controller(motor_preset("swerve"), trajectory, horizon=HORIZON, dt=DT,
                   compiled="virtual-machine")


@needs_cmake
def test_the_exported_motor_library_gives_the_python_commands(tmp_path: Path) -> None:
    """``mpc.export_c`` of the Mecanum motor preset, built with CMake: its example program
    replaying the recorded loop's ticks gives the Python tick's statuses, twists and wheel
    speeds to 1e-9; the header carries the feedforward's place."""
    poses, expected = _motor_loop("mecanum")
    controller = Controller(motor_preset("mecanum"), LOOP, horizon=HORIZON, dt=DT,
                            compiled="virtual-machine")
    source = mpc.export_c(controller, tmp_path / "src")
    assert "#define MPC_FF 20" in (source / "mpc_tick_config.h").read_text()
    program = cmake_example(source, tmp_path / "build")
    ahead = Lookahead(LOOP, controller.model.offsets, DT)
    done = subprocess.run(
        [str(program)], input=example_input(poses, [ahead.window(k * DT)
                                                    for k in range(len(poses))]),
        check=True, capture_output=True, text=True)
    rows = [np.array(line.split(), dtype=float) for line in done.stdout.splitlines()]
    assert len(rows) == len(expected)
    statuses = (Status.SOLVED, Status.PREVIOUS_PLAN, Status.FEEDFORWARD, Status.STOPPING)
    for tick, (row, command) in enumerate(zip(rows, expected, strict=True)):
        assert statuses[int(row[0])] is command.status, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:], command.wheel_speeds, rtol=0, atol=1e-9)


def test_perf_motors_names_the_layouts_without_motors() -> None:
    """``mpc-bench perf --sections compiled --motors`` on a layout with no motor preset: a
    one-line error naming the ones there are, before anything is built."""
    with pytest.raises(ScenarioError, match=r"no motor preset of caster4; expected some of "
                                            r"omni3, omni4, mecanum, swerve, ball3"):
        compiled_section(["caster4"], ["time"], {"inside": 0.8}, "figure8", "fixed", HORIZON,
                         DT, 20, 1, reference, lambda control, ticks: None,
                         lambda *a, **k: {}, lambda ticks: 0, lambda line: None, motors=True)


def test_motor_path_mode_is_refused_by_name() -> None:
    """Path mode on a motor preset: refused, naming the combination."""
    trajectory = FigureEight(1.0, 8.0, heading="tangent")
    with pytest.raises(UnsupportedTickError, match=r"mode='path' on a robot with a motor model"):
        Controller(motor_preset("mecanum"), trajectory, horizon=HORIZON, dt=DT, mode="path",
                   compiled="virtual-machine")


def test_a_failing_reference_falls_back_as_in_the_python_tick() -> None:
    """A reference that cannot be sampled for a second (the previous plan, then stopping,
    then solved again) on the Mecanum motor preset: the virtual machine gives the Python
    tick's statuses, failure counts, commands and motor currents to 1e-9 (the library runs
    the same graphs; its daqp is the other release, above)."""
    trajectory = Broken(1.0, 8.0, heading="tangent")
    robot = motor_preset("mecanum")
    saved = row_screen.SCREEN_AFTER
    row_screen.SCREEN_AFTER = 10**9
    try:
        with same_reuse_rule():
            python = Controller(robot, trajectory, horizon=HORIZON, dt=DT)
            machine = Controller(robot, trajectory, horizon=HORIZON, dt=DT,
                                 compiled="virtual-machine")
            start = FigureEight(1.0, 8.0, heading="tangent").sample(0.0).pose
            pose = start + np.array([0.15, -0.05, 0.2])
            expected, got = [], []
            for k in range(140):
                expected.append(python.step(pose, k * DT))
                got.append(machine.step(pose, k * DT))
                pose = plant_step(pose, expected[-1].twist)
    finally:
        row_screen.SCREEN_AFTER = saved
    assert {c.status for c in expected} == {Status.SOLVED, Status.PREVIOUS_PLAN,
                                            Status.STOPPING}
    _assert_same(expected, got, 1e-9)


def test_the_moving_cost_reaches_the_hessian_and_the_drift() -> None:
    """A motor robot's rate terms weigh the body acceleration with the reference's Coriolis
    term (:meth:`~mpc.model.tracking.TrackingModel.cost`), so its cost Hessian moves with
    the reference: ``prepare`` carries the model's values, ``hessian`` gives the NumPy
    condensed Hessian (:meth:`~mpc.solvers.condensed.Condenser.hessian`) of those values,
    two references that turn differently give two Hessians, and the drift from a kept
    build counts the values' change over the Python tick's tolerance."""
    from mpc.solvers.condensed import Condenser
    from mpc.solvers.hessian_reuse import COST_TOLERANCE
    from mpc.solvers.qp_structure import assemble_qp
    from mpc.tick.graphs import build_graphs
    from mpc.tick.reuse import terms_size

    horizon = 6
    robot = motor_preset("mecanum")
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    controller = Controller(robot, trajectory, horizon=horizon, dt=DT)
    model = controller.model
    graphs = build_graphs(model, motor_wheels(robot), DT)
    structure = assemble_qp(model, stage_limits(robot, model.change_times, None))
    nnz = structure.cost_terms.sparsity_out(0).nnz()
    assert graphs.terms == terms_size(horizon) + nnz  # the cost's values are reuse terms
    ahead = Lookahead(trajectory, model.offsets, DT)
    n = horizon
    cost_at = 3 * (n + 1) + 9 * n + 2 * n + 3 * n + 3 * n + 3 * (n + 1)
    results = []
    for t in (0.0, 1.3):  # the figure-eight's turn rate differs
        poses, velocities = ahead.window(t)
        pose = poses[0] + np.array([0.02, -0.01, 0.03])
        last = np.array([0.3, 0.1, 0.5])
        out = graphs.prepare(pose, poses.T, velocities.T, last, np.zeros((3, n)), 0.0,
                             np.zeros(graphs.terms), np.zeros(0), np.zeros(0))
        carry, terms = np.array(out[3]).ravel(), np.array(out[4]).ravel()
        hessian = np.array(graphs.hessian(carry))
        condenser = Condenser(model, structure)
        start = 3 * (n + 1)
        sensitivity = carry[start:start + 9 * n].reshape(n, 3, 3).transpose(0, 2, 1)
        steps = carry[start + 9 * n:start + 11 * n].reshape(n, 2)
        values = carry[cost_at:cost_at + nnz]
        condenser.scatter(values)
        expected = condenser.hessian(condenser.state_sensitivities(sensitivity, steps))
        np.testing.assert_allclose(hessian, expected, rtol=0,
                                   atol=1e-9 * np.abs(expected).max())
        results.append((pose, poses, velocities, last, terms, values, hessian))
    (_, _, _, _, terms_a, values_a, hessian_a), (pose, poses, velocities, last, _, values_b,
                                                 hessian_b) = results
    assert np.abs(values_a - values_b).max() > 1e-6 * np.abs(values_a).max()
    assert np.abs(hessian_a - hessian_b).max() > 1e-6 * np.abs(hessian_a).max()
    # the same tick again, the first reference's build kept: the cost's change counted
    drift = float(graphs.prepare(pose, poses.T, velocities.T, last, np.zeros((3, n)), 0.0,
                                 terms_a, np.zeros(0), np.zeros(0))[5])
    tolerance = COST_TOLERANCE * np.abs(np.asarray(structure.hessian.data)).max()
    assert drift >= np.abs(values_b - values_a).max() / tolerance * (1 - 1e-12)
