"""A swerve baseline in the style of Team 254's SwerveSetpointGenerator (2022, ported to
PathPlanner): feedforward + P pose feedback, then a setpoint that respects module limits
(the generator and its steps: :mod:`mpc.sim.setpoint_generator`, re-exported here).
"""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import ArrayLike

from mpc.angles import wrap_angle
from mpc.control.command import Command, Status
from mpc.errors import ControllerError
from mpc.robots.base import Robot
from mpc.sim.setpoint_generator import SwerveSetpoint, generate_setpoint, steered_robot
from mpc.validation import finite_vector, is_finite_number, shown
from trajectories import Trajectory

__all__ = ["FeedforwardPSetpointController", "SwerveSetpoint", "generate_setpoint"]


class FeedforwardPSetpointController:
    """Reference feedforward plus P pose feedback through the swerve setpoint generator.

    ``twist = R(theta)^T (v_ref + K_p (p_ref - p)), omega = omega_ref + K_theta e_theta``
    (as :class:`~mpc.sim.baselines.FeedforwardPController`, feedforward at mid-tick),
    then :func:`generate_setpoint` from the last command. Only for steered (swerve)
    robots.

    Args:
        robot: a swerve robot and its limits.
        trajectory: the reference.
        dt: control tick [s].
        gains: (K_xy, K_theta) [1/s]; default (4, 4) as the other baselines.
    """

    def __init__(self, robot: Robot, trajectory: Trajectory, dt: float = 0.05,
                 gains: tuple[float, float] = (4.0, 4.0)) -> None:
        self.robot, _ = steered_robot(robot)
        if not isinstance(trajectory, Trajectory):
            raise ControllerError(
                f"trajectory must be a trajectories.Trajectory, got {type(trajectory).__name__}")
        if not is_finite_number(dt) or dt <= 0:
            raise ControllerError(f"dt must be a finite number of seconds > 0, got {shown(dt)}")
        gain = finite_vector("gains", gains, 2, "(K_xy, K_theta) [1/s]", ControllerError)
        if np.any(gain < 0):
            raise ControllerError(f"gains must be two finite numbers >= 0, got {shown(gains)}")
        self.trajectory = trajectory
        self.dt = float(dt)
        self.gains = gain
        self.reset()

    def reset(self) -> None:
        """The robot is at rest, modules pointing forward."""
        self._setpoint = SwerveSetpoint.from_twist(self.robot, np.zeros(3),
                                                   self.robot.initial_steer_angles())

    def step(self, pose: ArrayLike, t: float) -> Command:
        """The command for measured ``pose`` (x, y, theta) at time ``t`` [s]."""
        start = time.perf_counter()
        x = finite_vector("pose", pose, 3, "(x, y, theta)", ControllerError)
        if not is_finite_number(t):
            raise ControllerError(f"t must be a finite time in seconds, got {shown(t)}")
        reference = self.trajectory.sample(t)
        ahead = self.trajectory.sample(t + 0.5 * self.dt)  # held over [t, t + dt]
        error = reference.pose - x
        error[2] = float(wrap_angle(error[2]))
        world = ahead.velocity[:2] + self.gains[0] * error[:2]
        c, s = math.cos(x[2]), math.sin(x[2])
        target = np.array([c * world[0] + s * world[1], -s * world[0] + c * world[1],
                           ahead.velocity[2] + self.gains[1] * error[2]])
        self._setpoint = generate_setpoint(self.robot, self._setpoint, target, self.dt)
        return Command(
            wheel_speeds=self._setpoint.wheel_speeds.copy(), twist=self._setpoint.twist.copy(),
            steer_angles=self._setpoint.steer_angles.copy(),
            predicted_poses=reference.pose[None, :], status=Status.SOLVED,
            solver_status="none", solve_time=0.0, tick_time=time.perf_counter() - start,
            iterations=0, consecutive_failures=0,
            clamped=not np.allclose(self._setpoint.twist, target), reference_time=float(t),
        )
