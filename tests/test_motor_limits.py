"""Motor-aware limits: the QP rows against the NLP's expressions and hand-derived values, the
clamp, the feedforward in ``Command``, and robots without dynamics left as they were."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from mpc import Controller, Status
from mpc.control.clamp import clamp_command
from mpc.robots import motor_preset, preset, swerve
from mpc.robots.drive.dynamics import RobotDynamics, dynamics
from mpc.robots.drive.force_map import coriolis, force_map
from mpc.robots.drive.motor_limits import MotorStageLimits, stage_limits, update_stage_limits
from mpc.robots.drive.motor_nlp import nlp_stage_limits
from mpc.robots.drive.motor_step import CLAMP_HEADROOM, first_step_feedforward, motor_step_fraction
from mpc.sim import simulate
from trajectories import Circle, FigureEight

RNG_SEED = 11


def no_sag(name: str) -> RobotDynamics:
    robot = motor_preset(name)
    assert robot.dynamics is not None
    fields = {**vars(robot.dynamics), "battery_resistance": 0.0}
    return RobotDynamics(**fields)


def test_robots_without_dynamics_keep_their_rows_and_commands() -> None:
    robot = preset("mecanum")
    times = np.full(5, 0.05)
    own, through = robot.stage_limits(times, 16), stage_limits(robot, times, 16)
    assert not isinstance(through, MotorStageLimits) and through.constant
    for field in ("now", "before", "lower", "upper"):
        np.testing.assert_array_equal(getattr(own, field), getattr(through, field))
    command = Controller(robot, Circle(1.0, 10.0)).step(np.array([1.0, 0.0, 0.0]), 0.0)
    assert command.wheel_forces is None and command.motor_currents is None
    assert first_step_feedforward(robot, np.zeros(3), np.ones(3), 0.05, None) is None
    assert motor_step_fraction(robot, np.zeros(3), np.ones(3) * 9, 0.05, None) == 1.0


def voltages(robot_name: str, before: np.ndarray, now: np.ndarray, dt: float) -> np.ndarray:
    """Each wheel's gearbox voltage at the end of the change, from the force map by hand:
    V = w / kv + R T / kt, T = drive map (u_k - u_{k-1}) / dt + efforts of coriolis(u_k)."""
    robot = motor_preset(robot_name)
    forces = force_map(robot)
    torque = (forces.drive_map[:, 0] @ (now - before) / dt
              + forces.effort_map[:, 0] @ coriolis(now))
    return robot.wheel_blocks[:, 0] @ now / forces.kv + forces.resistance * torque / forces.kt


@pytest.mark.parametrize("name", ["mecanum", "omni3", "ball3"])
def test_qp_rows_match_the_nlp_and_the_hand_formula(name: str) -> None:
    """At the plan the rows are linearised around, the QP's motor rows equal the NLP's exact
    expressions, and the voltage rows equal V / E from the formula above."""
    robot = motor_preset(name).with_dynamics(no_sag(name))
    dyn = robot.dynamics
    assert dyn is not None
    times = np.array([0.05, 0.1, 0.1])
    rng = np.random.default_rng(RNG_SEED)
    twists = rng.normal(size=(3, 3)) * [0.8, 0.8, 1.5]
    last = rng.normal(size=3) * 0.5
    limits = stage_limits(robot, times, 16)
    assert isinstance(limits, MotorStageLimits) and limits.motor is not None
    update_stage_limits(robot, limits, twists, last, None)
    m, rows = limits.kinematic.rows, limits.motor  # type: ignore[union-attr]
    previous = np.vstack([last, twists[:-1]])
    value = (np.einsum("kmj,kj->km", limits.now[:, m:], twists)
             + np.einsum("kmj,kj->km", limits.before[:, m:], previous))
    true = value - (limits.upper[:, m:] - limits.motor_bound)  # the bounds' shift back
    # the NLP, evaluated at the same twists
    u, u_last = ca.SX.sym("u", 3, 3), ca.SX.sym("last", 3)
    own = len(robot.nlp_stage_limits(u, u_last, None, times)[0])
    values, _, _ = nlp_stage_limits(robot, u, u_last, None, times)
    expressions = ca.Function("g", [u, u_last], [ca.vertcat(*values[own:])])
    exact = np.asarray(expressions(twists.T, last)).ravel().reshape(3, -1)
    n = robot.n_wheels
    for k in range(3):
        voltage_end = true[k][(rows.kind == 0) & rows.end]
        np.testing.assert_allclose(voltage_end, exact[k][:n], atol=1e-9)
        np.testing.assert_allclose(voltage_end * dyn.battery_voltage,
                                   voltages(name, previous[k], twists[k], times[k]), atol=1e-9)
        voltage_start = true[k][(rows.kind == 0) & ~rows.end]
        np.testing.assert_allclose(voltage_start, exact[k][n:2 * n], atol=1e-9)
        torque_end = true[k][(rows.kind == 1) & rows.end]
        np.testing.assert_allclose(torque_end, exact[k][2 * n:3 * n], atol=1e-9)


def test_first_step_feedforward_by_hand() -> None:
    """A swerve base accelerating straight ahead at a [m/s^2]: every module pushes m a / 4,
    its motor gives (m a r / 4 + J a / r) / (gearing count) and draws that over kt."""
    robot = motor_preset("swerve")
    dyn = robot.dynamics
    assert dyn is not None
    a, dt = 3.0, 0.05
    last, twist = np.array([1.0, 0.0, 0.0]), np.array([1.0 + a * dt, 0.0, 0.0])
    feed = first_step_feedforward(robot, last, twist, dt, np.zeros(4))
    assert feed is not None
    forces, torques, currents, vectors = feed
    np.testing.assert_allclose(forces, dyn.mass * a / 4, rtol=1e-12)
    np.testing.assert_allclose(vectors, [[dyn.mass * a / 4, 0.0]] * 4, atol=1e-9)
    wheel_torque = dyn.mass * a * 0.05 / 4 + dyn.wheel_inertia * a / 0.05
    np.testing.assert_allclose(torques, wheel_torque / dyn.gearing, rtol=1e-12)
    np.testing.assert_allclose(currents, torques / (7.09 / 366.0), rtol=1e-12)
    # a module flipped by the flip rule (steer angle pi, driving backwards): signs turn
    feed = first_step_feedforward(robot, last, twist, dt, np.full(4, math.pi))
    assert feed is not None and np.all(feed[0] < 0) and np.all(feed[2] < 0)


def test_braking_is_allowed_more_than_accelerating_at_speed() -> None:
    """Back-EMF: near free speed the voltage left for torque is small when speeding up and
    large when braking, so the same change is cut when accelerating only."""
    robot = motor_preset("mecanum").with_dynamics(no_sag("mecanum"))
    dyn = robot.dynamics
    assert dyn is not None
    top = 0.97 * dyn.free_speed * 0.05  # [m/s] straight ahead, 97 % of free speed
    cruise = np.array([top, 0.0, 0.0])
    accel = 4.0  # [m/s^2], within traction (4.7) and the current limit
    change = np.array([accel * 0.05, 0.0, 0.0])
    speed_up = motor_step_fraction(robot, cruise, cruise + change, 0.05, None)
    slow_down = motor_step_fraction(robot, cruise, cruise - change, 0.05, None)
    assert slow_down == pytest.approx(1.0)
    assert speed_up < 0.9
    # by hand: V = w / kv + R T / kt with every wheel pushing m a r / 4 (+ J alpha)
    forces = force_map(robot)
    wheel = top / 0.05
    keep = (1.0 - CLAMP_HEADROOM * dyn.voltage_headroom) * dyn.battery_voltage
    torque_per_accel = dyn.mass * 0.05 / 4 + dyn.wheel_inertia / 0.05  # [N m per m/s^2]
    room = (keep - wheel / forces.kv) * forces.kt / forces.resistance / torque_per_accel
    # the largest acceleration the voltage at the step's end leaves (the wheel ends faster)
    end_room = (keep - (wheel + speed_up * accel) / forces.kv) * forces.kt / (
        forces.resistance * torque_per_accel)
    assert speed_up * accel == pytest.approx(end_room, rel=1e-6)
    assert end_room < room


@pytest.mark.parametrize("name", ["mecanum", "swerve", "ball3", "omni3"])
def test_clamp_keeps_random_commands_within_the_motor_limits(name: str) -> None:
    """Whatever the target, the clamped command's step from the last command needs no more
    voltage, current or traction than the clamp's share of the headroom leaves, at both
    ends of the step (independent evaluation through the force map; to 1e-4 relative: the
    clamp takes the Coriolis term's chord along the step, a second-order remainder)."""
    robot = motor_preset(name)
    dyn = robot.dynamics
    assert dyn is not None
    forces = force_map(robot)
    rng = np.random.default_rng(RNG_SEED)
    keep = 1.0 - CLAMP_HEADROOM * dyn.headroom  # current and traction
    volts_kept = 1.0 - CLAMP_HEADROOM * dyn.voltage_headroom  # a smaller share
    assert keep < volts_kept
    dt = 0.05
    steer = robot.initial_steer_angles()
    for _ in range(40):
        last = rng.normal(size=3) * [1.0, 1.0, 1.5]
        last = robot.desaturate(last) * 0.7
        if not motor_step_fraction(robot, last, last, dt, steer) >= 1.0 - 1e-9:
            continue  # the present state itself beyond a limit: nothing to check
        target = last + rng.normal(size=3) * [1.5, 1.5, 4.0]
        twist, _ = clamp_command(robot, target, last, dt, steer)
        directions = forces.drive_directions(twist, steer)
        for turn in (coriolis(last), coriolis(twist)):
            torque = np.einsum("nd,ndj,j->n", directions, forces.drive_map,
                               (twist - last) / dt) + np.einsum(
                "nd,ndj,j->n", directions, forces.effort_map, turn)
            assert np.all(np.abs(torque) <= keep * forces.torque_limit * (1 + 1e-4))
            friction = forces.friction_limits
            assert friction is not None
            contact = np.linalg.norm(forces.contact_forces((twist - last) / dt + turn), axis=1)
            assert np.all(contact <= keep * friction * (1 + 1e-4))
        speed = np.einsum("nd,ndj,j->n", directions, robot.wheel_blocks, twist)
        end_torque = np.einsum("nd,ndj,j->n", directions, forces.drive_map, (twist - last)
                               / dt) + np.einsum("nd,ndj,j->n", directions, forces.effort_map,
                                                 coriolis(twist))
        volts = speed / forces.kv + forces.resistance * end_torque / forces.kt
        assert np.all(np.abs(volts) <= volts_kept * dyn.battery_voltage * (1 + 1e-4))


def test_motor_aware_plans_agree_between_the_qp_and_the_nlp() -> None:
    """Both fast paths and the exact NLP plan the same first commands (to the QP's
    linearisation), at 100 % of the traction on a Mecanum figure-eight."""
    robot = motor_preset("mecanum")
    reference = FigureEight(1.0, 4.8, heading=0.0)
    commands = {}
    for solver in ("daqp", "osqp", "ipopt"):
        controller = Controller(robot, reference, horizon=10, solver=solver)
        result = simulate(controller, 1.0, plant="motor")
        assert set(result.status) == {Status.SOLVED.value}
        commands[solver] = result.twist_command
        metrics = result.metrics()
        assert metrics["voltage_violations"] == metrics["current_violations"] == 0
    scale = np.abs(commands["ipopt"]).max()
    for solver in ("daqp", "osqp"):
        np.testing.assert_allclose(commands[solver], commands["ipopt"], atol=0.02 * scale)


def test_controller_reports_the_feedforward_of_its_command() -> None:
    robot = motor_preset("ball3")
    controller = Controller(robot, Circle(1.0, 4.0, heading=0.0))
    pose = np.array([1.0, 0.0, 0.0])
    first = controller.step(pose, 0.0)
    second = controller.step(pose, 0.05)
    feed = first_step_feedforward(robot, first.twist, second.twist, 0.05, None)
    assert feed is not None and robot.dynamics is not None
    assert second.wheel_forces is not None and second.motor_torques is not None
    assert second.motor_currents is not None
    for mine, theirs in zip((second.wheel_forces, second.motor_torques,
                             second.motor_currents, second.contact_forces), feed, strict=True):
        np.testing.assert_allclose(mine, theirs)
    forces = force_map(robot)
    np.testing.assert_allclose(second.motor_currents,
                               second.motor_torques / (forces.kt / robot.dynamics.gearing))


def test_sag_lowers_the_planned_voltage_bound() -> None:
    """With battery resistance, a plan drawing power gets a lower voltage bound there."""
    robot = swerve(module_positions=[[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3], [-0.3, -0.3]],
                   wheel_radius=0.05, max_wheel_speed=93.0, max_steer_rate=12.0)
    robot = robot.with_dynamics(dynamics(mass=50.0, yaw_inertia=4.0, motor="kraken_x60",
                                         gearing=6.75, current_limit=60.0, friction=1.1,
                                         battery_resistance=0.02))
    limits = stage_limits(robot, np.full(2, 0.05), 16)
    assert isinstance(limits, MotorStageLimits) and limits.motor is not None
    guess = np.array([[2.0, 0.0, 0.0], [2.2, 0.0, 0.0]])  # 4 m/s^2 at 2 m/s: ~1 kW drawn
    update_stage_limits(robot, limits, guess, np.array([1.8, 0.0, 0.0]), np.zeros(4))
    voltage = limits.motor.voltage
    assert np.all(limits.motor_bound[:, voltage] < limits.motor.bound[voltage] * 0.99)
    resting = stage_limits(robot, np.full(2, 0.05), 16)
    assert isinstance(resting, MotorStageLimits)
    update_stage_limits(robot, resting, np.zeros((2, 3)), np.zeros(3), np.zeros(4))
    assert resting.motor is not None
    np.testing.assert_allclose(resting.motor_bound,
                               np.broadcast_to(resting.motor.bound, resting.motor_bound.shape))


def test_sag_rows_against_finite_differences() -> None:
    """The voltage rows carry the bus's sag linearised around the guess: their change of
    value with the plan is the sagged bound's, by central differences of B(P(u))."""
    from mpc.robots.drive.bus_sag import sag as _sag

    robot = motor_preset("mecanum")
    times = np.array([0.05, 0.1])
    rng = np.random.default_rng(RNG_SEED)
    guess = rng.normal(size=(2, 3)) * [1.0, 1.0, 1.0] + [1.5, 0.0, 0.0]
    last = guess[0] - [0.2, 0.05, 0.1]
    limits = stage_limits(robot, times, 16)
    assert isinstance(limits, MotorStageLimits) and limits.motor is not None
    previous = np.vstack([last, guess[:-1]])

    forces = limits.forces
    assert forces is not None

    def scale(twists: np.ndarray, before: np.ndarray) -> np.ndarray:
        return _sag(forces, twists, before, times, coriolis(twists), coriolis(before),
                    limits.directions).scale

    sag = _sag(forces, guess, previous, times, coriolis(guess), coriolis(previous),
               limits.directions)
    h = 1e-5
    for j in range(3):
        step = np.zeros((2, 3))
        step[:, j] = h
        numeric = (scale(guess + step, previous) - scale(guess - step, previous)) / (2 * h)
        np.testing.assert_allclose(numeric, sag.slope * sag.grad_now[:, j], rtol=1e-4,
                                   atol=1e-9)
        numeric = (scale(guess, previous + step) - scale(guess, previous - step)) / (2 * h)
        np.testing.assert_allclose(numeric, sag.slope * sag.grad_before[:, j], rtol=1e-4,
                                   atol=1e-9)


def test_a_first_tick_from_rest_under_a_reference_at_speed_is_solved() -> None:
    """The first guess is the reference's twists; the omni-3 motor preset at rest under a
    circle at 100 % of its motor model linearised its rows there into an empty set (daqp:
    infeasible, a feedforward tick). It is solved again from the last command held: a plan,
    within every limit, from the first tick on."""
    from benchmarks.motors import motor_reference

    robot = motor_preset("omni3")
    reference = motor_reference("circle", robot, 1.0, 1.0, "fixed")
    controller = Controller(robot, reference, horizon=20, dt=0.05)
    command = controller.step(reference.sample(0.0).pose, 0.0)
    assert command.status is Status.SOLVED, command.solver_status
    assert (np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9)).all()
    # within a time budget there is no second solve; the first is feasible since its first
    # stage's rows hold the last command (it was the fallback before)
    budgeted = Controller(robot, reference, horizon=20, dt=0.05, time_limit=0.5)
    assert budgeted.step(reference.sample(0.0).pose, 0.0).status is Status.SOLVED


@pytest.mark.parametrize("heading", [0.0, 0.4, 2.0])
def test_traction_polygon_is_exact_along_the_planned_force(heading: float) -> None:
    """A 2-D contact's traction polygon, turned to the force the guess asks of it, lets the
    plan push along that force exactly to the disk (headroom kept): the largest change
    along the guess's direction that the stage's traction rows allow is, by hand,
    ``(1 - headroom) mu N_c / |C_c e|`` over the contacts (no rotation: no Coriolis term)."""
    robot = motor_preset("swerve")
    dyn = robot.dynamics
    assert dyn is not None
    forces = force_map(robot)
    dt = 0.05
    limits = stage_limits(robot, np.full(2, dt), None)
    assert isinstance(limits, MotorStageLimits) and limits.motor is not None
    e = np.array([math.cos(heading), math.sin(heading), 0.0])
    last = 1.0 * e
    guess = np.array([last + 2.0 * dt * e, last + 4.0 * dt * e])  # 2 m/s^2 along e
    update_stage_limits(robot, limits, guess, last, robot.initial_steer_angles())
    traction = limits.kinematic.rows + np.flatnonzero(limits.motor.kind == 2)  # type: ignore[union-attr]

    def within(accel: float) -> bool:
        u0 = last + accel * dt * e
        value = limits.now[0, traction] @ u0 + limits.before[0, traction] @ last
        return bool(np.all(value <= limits.upper[0, traction])
                    and np.all(value >= limits.lower[0, traction]))

    friction = forces.friction_limits
    assert friction is not None
    by_hand = min((1.0 - dyn.headroom) * friction[c] / np.linalg.norm(forces.contact_maps[c] @ e)
                  for c in range(forces.n_contacts))
    assert within(by_hand * (1 - 1e-9))
    assert not within(by_hand * (1 + 1e-6))


def test_a_tick_after_a_failure_is_solved_from_the_robots_own_motion() -> None:
    """After a failed tick the guess is the reference's twists. A swerve robot behind a
    3 m circle at 100 % of its motor model: a guess that jumps from the robot's speed to
    the reference's draws more power than the battery has, the bus read off it is half the
    battery's and the voltage rows exclude the robot's own speed (infeasible, tick after
    tick: 169 fallback ticks of 202 measured). Solved again from the last command held,
    the run keeps planning (1 fallback tick) within every motor limit."""
    from benchmarks.motors import motor_reference

    robot = motor_preset("swerve")
    reference = motor_reference("circle", robot, 1.0, 3.0, "fixed")
    result = simulate(Controller(robot, reference, horizon=20, dt=0.05, command_ramp=True),
                      4.0, plant="motor")
    metrics = result.metrics()
    assert metrics["failures"] <= 3
    assert metrics["voltage_violations"] == 0
