"""The planner and the motor plant share one force model: a swerve base driven round a
circle with commands that carry the plan's own feedforward (contact force vectors and
motor torques) is pushed by the plant's contacts with the forces the plan asked for, and
where those are within ``mu N`` it does not slide."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpc import Command, Status
from mpc.robots import motor_preset
from mpc.robots.drive.force_map import force_map
from mpc.robots.drive.motor_step import first_step_feedforward
from mpc.sim.motor_plant import MotorPlant, MotorPlantConfig

DT = 0.05


def _command(robot, last, twist, angles_now) -> Command:
    speeds, angles = robot.wheel_commands(twist, angles_now)
    feed = first_step_feedforward(robot, last, twist, DT, angles)
    assert feed is not None
    return Command(wheel_speeds=speeds, twist=twist, steer_angles=angles,
                   predicted_poses=np.zeros((2, 3)), status=Status.SOLVED, solver_status="",
                   solve_time=0.0, tick_time=0.0, iterations=0, consecutive_failures=0,
                   clamped=False, reference_time=0.0, wheel_forces=feed[0],
                   motor_torques=feed[1], motor_currents=feed[2], contact_forces=feed[3])


@pytest.mark.parametrize(("share", "speed", "spin"), [(0.9, 1.0, 0.0), (0.9, 2.5, 0.0),
                                                       (0.85, 1.5, 0.8)])
@pytest.mark.parametrize("config", [MotorPlantConfig(),
                                    MotorPlantConfig(steer_rate_limited=False,
                                                     velocity_gain=0.0)])
def test_plan_within_traction_does_not_slide(share: float, speed: float, spin: float,
                                             config: MotorPlantConfig) -> None:
    """A circle at ``share`` of ``mu g`` (the body also spinning at ``spin`` rad/s, so
    the modules move at different speeds): every tick's planned contact forces are within
    ``mu N``, and the plant's stay within it too (within 3 % of the plan's) and never slide.
    (With each contact's own stiffness and the feedforward held along the commanded angle
    over the tick, the plant asked up to 1.056 mu N of a plan at 0.891.)"""
    robot = motor_preset("swerve")
    forces = force_map(robot)
    dyn = robot.dynamics
    assert dyn is not None and dyn.friction is not None
    accel = share * dyn.friction * 9.81
    turn = accel / speed  # [rad/s] the velocity's turn rate in the world
    plant = MotorPlant(robot, DT, np.zeros(3), config, np.random.default_rng(0))
    first = np.array([speed, 0.0, spin])
    plant.set_motion(first)
    last = first
    planned = []
    for k in range(1, 41):
        # body-frame velocity turning at (turn - spin) relative to the body
        angle = (turn - spin) * k * DT
        twist = np.array([speed * math.cos(angle), speed * math.sin(angle), spin])
        command = _command(robot, last, twist, plant.steer_angles)
        contact = forces.contact_forces(forces.acceleration(last, twist, DT))
        planned.append(float((np.hypot(*contact.T) / forces.friction_limits).max()))
        plant.apply(command)
        last = twist
    events = plant.events()
    assert max(planned) < 1.0
    assert events["slip"].sum() == 0
    # from the second tick on (the first starts from set_motion's rolling state)
    assert events["peak_traction_ratio"][1:].max() <= max(planned) * 1.03
