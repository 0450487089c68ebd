"""Our robots from WPILib kinematics: swerve modules and Mecanum wheels at the positions
of a ``SwerveDrive{2,3,4,6}Kinematics`` or ``MecanumDriveKinematics`` (or their
``Translation2d`` s)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from wpimath.geometry import Translation2d

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.plausibility import SIZE, WHEEL_ACCEL, WHEEL_RADIUS, WHEEL_SPEED, check_plausible
from mpc.robots import SwedishRobot, SwedishWheel, SwerveRobot, swerve


def _positions(source: Any, count: int | None, what: str) -> FloatArray:
    """Module or wheel centres (n, 2) [m] of a WPILib kinematics object or of a sequence of
    ``Translation2d`` or (x, y) pairs."""
    if hasattr(source, "getModules"):  # SwerveDrive{2,3,4,6}Kinematics
        items: Sequence[Any] = source.getModules()
    elif hasattr(source, "getFrontLeft"):  # MecanumDriveKinematics
        items = (source.getFrontLeft(), source.getFrontRight(), source.getRearLeft(),
                 source.getRearRight())
    else:
        items = source
    try:
        rows = [(p.X(), p.Y()) if isinstance(p, Translation2d) else p for p in items]
        positions = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        raise RobotError(f"{what} must be a WPILib kinematics object or a sequence of "
                         f"Translation2d or (x, y) pairs [m], got {source!r}") from None
    if positions.ndim != 2 or positions.shape[1] != 2 or (count and len(positions) != count):
        raise RobotError(f"{what}: expected {count or 'n'} positions (x, y) [m], got shape "
                         f"{positions.shape}")
    return positions


def robot_from_swerve_kinematics(kinematics_or_translations: Any, *, wheel_radius: float,
                                 max_wheel_speed: float, max_steer_rate: float,
                                 max_wheel_accel: float | None = None,
                                 name: str = "swerve", allow_unusual: bool = False
                                 ) -> SwerveRobot:
    """Our :func:`~mpc.robots.swerve` robot with the modules of a WPILib
    ``SwerveDrive{2,3,4,6}Kinematics`` (or their ``Translation2d`` s), in the same order.

    Args:
        wheel_radius: [m]. max_wheel_speed: [rad/s] (rim speed limit [m/s] / radius).
        max_steer_rate: [rad/s]. max_wheel_accel: [rad/s^2] or None.
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError.
    """
    positions = _positions(kinematics_or_translations, None, "swerve kinematics")
    return swerve(module_positions=positions, wheel_radius=wheel_radius,
                  max_wheel_speed=max_wheel_speed, max_steer_rate=max_steer_rate,
                  max_wheel_accel=max_wheel_accel, name=name, allow_unusual=allow_unusual)


def robot_from_mecanum_kinematics(kinematics_or_translations: Any, *, wheel_radius: float,
                                  max_wheel_speed: float, max_wheel_accel: float | None = None,
                                  name: str = "mecanum", allow_unusual: bool = False
                                  ) -> SwedishRobot:
    """A Mecanum robot (wheels FL, FR, RL, RR) with the wheel positions of a WPILib
    ``MecanumDriveKinematics`` (or four ``Translation2d`` s in that order).

    Each wheel is Siegwart's Swedish wheel at its position with rollers at -45 deg (FL, RR)
    or +45 deg (FR, RL), which is WPILib's inverse kinematics for any positions
    (``r phidot_FL = vx - vy - (x + y) omega``, ``r phidot_FR = vx + vy + (x - y) omega``,
    ...). For the rectangle ``(+-a, +-b)`` the wheels are exactly those of
    ``mecanum(wheelbase=2a, track=2b, ...)``. Units and ``allow_unusual`` as
    :func:`robot_from_swerve_kinematics`.
    """
    positions = _positions(kinematics_or_translations, 4, "Mecanum kinematics")
    quarter = math.pi / 4.0
    wheels = []
    for (x, y), gamma in zip(positions, (-quarter, quarter, quarter, -quarter), strict=True):
        alpha = math.atan2(y, x)
        wheels.append(SwedishWheel(alpha=alpha, beta=math.pi / 2.0 - alpha, gamma=gamma,
                                   l=math.hypot(x, y), radius=wheel_radius,
                                   max_speed=max_wheel_speed, max_accel=max_wheel_accel))
    robot = SwedishRobot(tuple(wheels), name=name)
    first = wheels[0]
    check_plausible({"wheel positions": (SIZE, positions),
                     "wheel_radius": (WHEEL_RADIUS, first.radius),
                     "max_wheel_speed": (WHEEL_SPEED, first.max_speed),
                     "max_wheel_accel": (WHEEL_ACCEL, first.max_accel)}, allow_unusual)
    return robot
