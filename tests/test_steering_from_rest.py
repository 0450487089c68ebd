"""Swerve modules that must turn before they can drive wait at rest: a start from rest with
modules out of line is a stop while they turn, never a creep at the stopped speed (such a
creep held the modules' angles and kept the robot from starting)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpc import Controller
from mpc.control.clamp import clamp_command
from mpc.robots import SwerveRobot, swerve
from mpc.robots.wheels.swerve.limits import turn_fraction, turns
from mpc.sim import simulate
from trajectories import SampledTrajectory

DT = 0.02


def robot() -> SwerveRobot:
    """The modules of examples/data/s-curve.traj (not a rectangle), no acceleration limit."""
    return swerve(module_positions=[[0.3, 0.25], [0.3, -0.25], [-0.28, 0.27], [-0.28, -0.27]],
                  wheel_radius=0.05, max_wheel_speed=90.0, max_steer_rate=12.0)


def test_from_rest_a_module_out_of_line_stops_the_step_and_the_others_wait() -> None:
    """From rest, modules 1-3 already point along the target and module 0 is 1 rad off
    (reach 0.24 rad): module 0 cannot move, and a rigid twist that leaves it at rest and
    moves along the step is none but 0. The command is exactly at rest, and module 0
    turns by its reach towards the target."""
    swerve_robot = robot()
    target = np.array([0.05, 0.0, 0.5])  # module speeds differ (rotation about a point)
    velocities = swerve_robot.wheel_blocks @ target
    wanted = np.arctan2(velocities[:, 1], velocities[:, 0])
    steer = wanted.copy()
    steer[0] -= 1.0
    reach = swerve_robot.max_steer_rate * DT
    assert turns(swerve_robot, velocities, steer)[0] > reach
    assert turn_fraction(swerve_robot, np.zeros(3), target, steer, DT) == 0.0
    twist, clamped = clamp_command(swerve_robot, target, np.zeros(3), DT, steer)
    assert clamped and np.array_equal(twist, np.zeros(3))
    speeds, angles = swerve_robot.wheel_commands(twist, steer, target, DT)
    assert angles is not None
    assert np.array_equal(speeds, np.zeros(4))
    assert angles[0] == pytest.approx(steer[0] + reach, abs=1e-12)
    assert np.allclose(angles[1:], wanted[1:], atol=1e-12)


@pytest.mark.parametrize("heading", [0.002, -0.01])
def test_a_start_from_rest_with_a_small_heading_error_moves_off(heading: float) -> None:
    """A rest-to-rest reference starting smoothly (quintic, zero acceleration at the ends)
    from a heading a few mrad off: the modules need different turns, and the robot used to
    sit on a ~1e-6 m/s creep for the whole run. It starts within a few ticks, tracks, and
    never turns a module faster than its steering rate."""
    swerve_robot = robot()
    reference = SampledTrajectory([0.0, 2.0], [[0.0, 0.0, 0.0], [1.0, 0.6, 0.4]],
                                  np.zeros((2, 3)), np.zeros((2, 3)))
    controller = Controller(swerve_robot, reference, horizon=25, dt=DT)
    result = simulate(controller, 0.5, initial_pose=[0.0, 0.0, heading])
    moving = np.abs(result.twist_command).sum(axis=1) > 1e-3
    assert moving.any() and int(np.argmax(moving)) <= 15
    error = np.linalg.norm(result.pose[-1, :2] - result.reference[-1, :2])
    assert error < 5e-3
    assert result.steer_command is not None
    turned = np.abs(np.mod(np.diff(result.steer_command, axis=0) + math.pi / 2, math.pi)
                    - math.pi / 2)
    assert turned.max() <= swerve_robot.max_steer_rate * DT * (1.0 + 1e-9)
    assert np.all(np.abs(result.wheel_command) <= result.wheel_limit * (1.0 + 1e-9))


def test_a_slow_module_that_must_turn_far_stops_and_turns_instead_of_creeping() -> None:
    """Modules along x at 1 mm/s, the target 1 mm/s along y (a quarter turn, reach 0.24
    rad). The step from the last command reaches the edge of the steering cone at
    g = tan(reach) / (1 + tan(reach)) = 0.197, where it is sqrt(2) (1 - g) |v| = 1.14 |v|
    from the target: a stop, |v| from it, is nearer and within every limit (no
    acceleration limit). The command is the stop and every module turns by its reach."""
    swerve_robot = robot()
    last, target = np.array([1e-3, 0.0, 0.0]), np.array([0.0, 1e-3, 0.0])
    steer = np.zeros(4)
    reach = swerve_robot.max_steer_rate * DT
    fraction = turn_fraction(swerve_robot, last, target, steer, DT)
    assert fraction == pytest.approx(math.tan(reach) / (1.0 + math.tan(reach)), rel=1e-6)
    twist, clamped = clamp_command(swerve_robot, target, last, DT, steer)
    assert clamped and np.array_equal(twist, np.zeros(3))
    speeds, angles = swerve_robot.wheel_commands(twist, steer, target, DT)
    assert np.array_equal(speeds, np.zeros(4)) and angles is not None
    np.testing.assert_allclose(angles, np.full(4, reach), atol=1e-12)


def test_the_stop_is_offered_only_within_the_acceleration_limits() -> None:
    """The same quarter turn at 1 m/s with a 60 rad/s^2 limit (1.2 rad/s of wheel speed a
    tick, 20 rad/s to stop): no stop, the step to the edge of the steering cone."""
    swerve_robot = swerve(module_positions=[[0.3, 0.25], [0.3, -0.25], [-0.28, 0.27],
                                            [-0.28, -0.27]],
                          wheel_radius=0.05, max_wheel_speed=90.0, max_steer_rate=12.0,
                          max_wheel_accel=60.0)
    last, target = np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.02, 0.0])
    steer = np.zeros(4)
    reach = swerve_robot.max_steer_rate * DT
    twist, _ = clamp_command(swerve_robot, target, last, DT, steer)
    assert twist[0] > 0.9
    assert math.atan2(twist[1], twist[0]) <= reach


def test_modules_settle_at_the_end_of_a_path_without_spinning() -> None:
    """A quintic rest-to-rest reference: at its end the robot overshoots by under a
    millimetre and the correction points back. The modules used to creep along the
    clamp's step at ~0.1 mm/s for over 20 ticks, turning at up to their full rate
    (12 rad of steering in the half second after the end), the error held; now they stop,
    turn and drive back."""
    swerve_robot = robot()
    reference = SampledTrajectory([0.0, 1.0], [[0.0, 0.0, 0.0], [0.5, -0.3, -0.2]],
                                  np.zeros((2, 3)), np.zeros((2, 3)))
    controller = Controller(swerve_robot, reference, horizon=25, dt=DT)
    result = simulate(controller, 1.5)
    end = 50  # the tick at t = 1.0 s
    assert result.steer_command is not None
    turned = np.abs(np.mod(np.diff(result.steer_command, axis=0) + math.pi / 2, math.pi)
                    - math.pi / 2)
    assert turned.max() <= swerve_robot.max_steer_rate * DT * (1.0 + 1e-9)
    assert turned[end:].sum() < 4.0
    error = np.linalg.norm(result.pose[-1, :2] - result.reference[-1, :2])
    assert error < 1e-4


def test_a_last_command_that_turns_a_module_too_far_is_not_sent_again() -> None:
    """A creep of 20 um/s along x with module 3 half a radian off it (as a creep the wheel
    commands snapped partly to rest can leave it): no step from it keeps module 3 within
    its reach, and sending it again would turn module 3 by 0.5 rad in a tick. The stop is
    within every limit: the command, and module 3 turns by its reach."""
    swerve_robot = robot()
    last, target = np.array([2e-5, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    steer = np.array([0.0, 0.0, 0.0, 0.5])
    reach = swerve_robot.max_steer_rate * DT
    assert turn_fraction(swerve_robot, last, target, steer, DT) == 0.0
    twist, _ = clamp_command(swerve_robot, target, last, DT, steer)
    assert np.array_equal(twist, np.zeros(3))
    speeds, angles = swerve_robot.wheel_commands(twist, steer, target, DT)
    assert np.array_equal(speeds, np.zeros(4)) and angles is not None
    np.testing.assert_allclose(angles, [0.0, 0.0, 0.0, 0.5 - reach], atol=1e-12)
