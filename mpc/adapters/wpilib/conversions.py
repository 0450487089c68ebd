"""WPILib types to and from ours: ``Pose2d``, robot-relative ``ChassisSpeeds``, and a
command as ``SwerveModuleState`` s or ``MecanumDriveWheelSpeeds`` (rim speeds [m/s])."""

from __future__ import annotations

import math
from typing import TypeGuard

import numpy as np
from numpy.typing import ArrayLike
from wpimath.geometry import Pose2d, Rotation2d
from wpimath.kinematics import ChassisSpeeds, MecanumDriveWheelSpeeds, SwerveModuleState

from mpc.arrays import FloatArray
from mpc.control import Command
from mpc.errors import ControllerError, RobotError
from mpc.robots import Robot, SwedishRobot, SwerveRobot
from mpc.validation import shown


def pose_from_pose2d(pose: Pose2d) -> FloatArray:
    """``(x, y, theta)`` [m, m, rad] of a ``Pose2d``; theta as its ``Rotation2d`` holds it
    (odometry's are in (-pi, pi]; the controller matches any turn count to the reference)."""
    if not isinstance(pose, Pose2d):
        raise ControllerError(f"pose must be a wpimath.geometry.Pose2d, got {shown(pose)}")
    return np.array([pose.X(), pose.Y(), pose.rotation().radians()])


def pose2d_from_pose(pose: ArrayLike) -> Pose2d:
    """A ``Pose2d`` from ``(x, y, theta)`` [m, m, rad]."""
    x, y, theta = _three("pose", pose, "(x, y, theta)")
    return Pose2d(x, y, Rotation2d(theta))


def twist_from_chassis_speeds(speeds: ChassisSpeeds) -> FloatArray:
    """Robot-relative ``ChassisSpeeds`` as our body twist ``(vx, vy, omega)`` [m/s, m/s, rad/s]."""
    if not isinstance(speeds, ChassisSpeeds):
        raise ControllerError(f"speeds must be a wpimath ChassisSpeeds, got {shown(speeds)}")
    return np.array([speeds.vx, speeds.vy, speeds.omega])


def chassis_speeds_from_twist(twist: ArrayLike) -> ChassisSpeeds:
    """Robot-relative ``ChassisSpeeds`` from a body twist ``(vx, vy, omega)``."""
    return ChassisSpeeds(*_three("twist", twist, "(vx, vy, omega)"))


def swerve_module_states(robot: Robot, command: Command) -> list[SwerveModuleState]:
    """A swerve command as ``SwerveModuleState`` s: signed rim speed [m/s] (wheel speed times
    the wheel radius) and steer angle, in the robot's module order, after our flip rule."""
    if not isinstance(robot, SwerveRobot) or command.steer_angles is None:
        raise RobotError(f"module states need a swerve robot and its command, got {shown(robot)}")
    rim = np.asarray(command.wheel_speeds) * robot.wheel_radius
    return [SwerveModuleState(float(speed), Rotation2d(float(angle)))
            for speed, angle in zip(rim, command.steer_angles, strict=True)]


def mecanum_wheel_speeds(robot: Robot, command: Command) -> MecanumDriveWheelSpeeds:
    """A Mecanum command as ``MecanumDriveWheelSpeeds`` [m/s] (wheel speed times radius);
    our order FL, FR, RL, RR is WPILib's frontLeft, frontRight, rearLeft, rearRight."""
    if not _is_mecanum(robot):
        raise RobotError(f"wheel speeds need a four-wheel Mecanum robot, got {shown(robot)}")
    radii = np.array([wheel.radius for wheel in robot.wheels])
    return MecanumDriveWheelSpeeds(*(float(v) for v in np.asarray(command.wheel_speeds) * radii))


def _three(name: str, value: ArrayLike, what: str) -> tuple[float, float, float]:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ControllerError(f"{name} must be 3 numbers {what}, got {shown(value)}") from None
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise ControllerError(f"{name} must be 3 finite numbers {what}, got {shown(value)}")
    return float(array[0]), float(array[1]), float(array[2])


def _is_mecanum(robot: Robot) -> TypeGuard[SwedishRobot]:
    """Four Swedish wheels with rollers at -45, +45, +45, -45 deg: FL, FR, RL, RR as ours."""
    pattern = (-math.pi / 4, math.pi / 4, math.pi / 4, -math.pi / 4)
    return (isinstance(robot, SwedishRobot) and robot.n_wheels == 4
            and all(math.isclose(w.gamma, g) for w, g in zip(robot.wheels, pattern, strict=True)))
