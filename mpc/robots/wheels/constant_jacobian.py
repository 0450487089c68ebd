"""Robots whose every wheel speed is one fixed row of the twist: ``phidot = J @ twist``.

Swedish wheels (omni, Mecanum) and driven balls' actuators are such wheels: each wheel's
velocity map ``W_i`` is one constant row ``J_i`` [rad/s per (m/s, m/s, rad/s)], its speed
limit ``|J_i twist| <= max_speed_i`` one exact linear row, and forward kinematics the
least-squares ``pinv(J) @ phidot``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.robots.base import Robot, SpeedRows, WheelCommands
from mpc.validation import real_array, shown


@dataclass(frozen=True, eq=False)
class ConstantJacobianRobot(Robot):
    """A :class:`Robot` whose ``wheel_blocks`` are one constant row per wheel (n, 1, 3)."""

    @property
    def jacobian(self) -> FloatArray:
        """Inverse-kinematics Jacobian ``J`` (n x 3) [rad/s per twist unit]."""
        return self.wheel_blocks[:, 0, :]

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Signed wheel speeds ``J @ twist`` [rad/s], shape (n,) or (k, n)."""
        return self.wheel_velocities(twist)[..., 0]

    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        return np.abs(self.jacobian @ twist)

    def least_squares_twist(self, name: str, wheel_speeds: ArrayLike) -> FloatArray:
        """Forward kinematics ``pinv(J) @ wheel_speeds`` of speeds (n,) or (k, n) [rad/s],
        checked under ``name``: the twist (3,) or (k, 3)."""
        speeds = real_array(name, wheel_speeds, "numbers", RobotError)
        if speeds.ndim not in (1, 2) or speeds.shape[-1] != self.n_wheels:
            raise RobotError(f"{name} must have shape ({self.n_wheels},) or "
                             f"(k, {self.n_wheels}), got shape {speeds.shape}")
        if not np.all(np.isfinite(speeds)):
            raise RobotError(f"{name} must be finite, got {shown(wheel_speeds)}")
        return speeds @ self._flat_pinv.T

    def forward_kinematics(self, wheel_speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        return self._flat_pinv @ wheel_speeds

    def commands_from_velocities(self, velocities: FloatArray,
                                 steer_angles: FloatArray | None) -> WheelCommands:
        return WheelCommands(velocities[:, 0].copy(), None)

    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        """Exact: one two-sided row per wheel."""
        return SpeedRows(self.jacobian.copy(), np.arange(self.n_wheels), 1.0)

    def casadi_limits(self, twist: ca.SX, bounds: FloatArray) -> tuple[ca.SX, FloatArray,
                                                                         FloatArray]:
        bounds = np.asarray(bounds, dtype=float)
        return ca.DM(self.jacobian) @ twist, -bounds, bounds

    def _with_derating(self, derating: tuple[float, ...]) -> ConstantJacobianRobot:
        return replace(self, derating=derating)
