"""The clamp offers a motor robot's swerve modules a stop to turn at rest, where the
motors can brake to it within a tick (:func:`mpc.control.clamp._turn_step`).

Without it a module that had to turn far crept along a step cut to a sliver, tick after
tick: the motor-aware MPC on the swerve preset's 1 m figure-eight at 1.3x the geared free
speed fell behind and held near the middle (docs/guide/traction.md)."""

from __future__ import annotations

import numpy as np

from mpc.control.clamp import clamp_command
from mpc.robots import motor_preset
from mpc.robots.drive.motor_step import motor_step_fraction

DT = 0.05  # [s]


def test_a_slow_module_stops_to_turn() -> None:
    robot = motor_preset("swerve")
    last = np.array([0.1, 0.0, 0.0])  # 0.1 m/s along x, modules pointing along x
    aim = np.array([-0.3, 0.3, 0.0])  # back and left: 3/8 of a turn (or 1/8 reversed)
    steer = np.zeros(robot.n_wheels)
    assert robot.steering_fraction(last, aim, steer, DT) < 1.0
    # braking 0.1 m/s in a tick is 2 m/s^2: within the motors and traction
    assert motor_step_fraction(robot, last, np.zeros(3), DT, steer) >= 1.0 - 1e-9
    command, clamped = clamp_command(robot, aim, last, DT, steer)
    assert clamped
    np.testing.assert_array_equal(command, np.zeros(3))


def test_a_fast_module_is_not_stopped_beyond_its_motors() -> None:
    robot = motor_preset("swerve")
    last = np.array([3.0, 0.0, 0.0])  # 3 m/s: a stop in a tick would be 60 m/s^2
    aim = np.array([-3.0, 3.0, 0.0])
    steer = np.zeros(robot.n_wheels)
    assert motor_step_fraction(robot, last, np.zeros(3), DT, steer) < 1.0
    command, clamped = clamp_command(robot, aim, last, DT, steer)
    assert clamped and np.linalg.norm(command) > 1.0
    assert motor_step_fraction(robot, last, command, DT, steer) >= 1.0 - 1e-9
    assert robot.steering_fraction(last, command, steer, DT) >= 1.0 - 1e-9
