"""Swerve drive: independently steered and driven modules.

Module ``i`` at body position ``p_i = (x_i, y_i)`` moves at
``v_i = (vx - omega y_i, vy + omega x_i)``; its wheel turns at
``|v_i| / r`` along the steer angle ``atan2(v_iy, v_ix)``. The speed limit is a
disk ``|v_i| <= r * max_wheel_speed``: exact in the nonlinear problem, an
inscribed polygon in the QP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from mpc.errors import RobotError
from mpc.robots.base import (
    FloatArray,
    Robot,
    as_twists,
    check_holonomic,
    positive_finite,
    readonly,
)

#: Below this module speed [m/s] a module keeps its previous steer angle.
STOPPED_MODULE_SPEED = 1e-6


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """Wrap angle(s) into (-pi, pi] [rad]."""
    wrapped = np.mod(np.asarray(angle, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    return np.where(wrapped == -math.pi, math.pi, wrapped)


@dataclass(frozen=True, eq=False)
class SwerveRobot(Robot):
    """A swerve base; wheel speeds are module speeds ``|v_i| / r`` [rad/s] >= 0.

    Attributes:
        module_positions: (n, 2) module centres in the body frame [m].
        wheel_radius: [m].
        max_speed: per-module wheel speed limit [rad/s].
        max_steer_rate: steering motor rate limit [rad/s].
        max_accel: per-module wheel acceleration limit [rad/s^2] or None.
    """

    module_positions: FloatArray = field(default_factory=lambda: np.zeros((0, 2)), kw_only=True)
    wheel_radius: float = field(default=0.05, kw_only=True)
    max_speed: float = field(default=1.0, kw_only=True)
    max_steer_rate: float = field(default=10.0, kw_only=True)
    max_accel: float | None = field(default=None, kw_only=True)
    _pinv: FloatArray = field(init=False, repr=False)  # (3, 2n) least squares

    def __post_init__(self) -> None:
        positions = np.asarray(self.module_positions, dtype=float)
        if positions.ndim != 2 or positions.shape[1] != 2 or positions.shape[0] < 2:
            raise RobotError(
                "module_positions must have shape (n, 2) with n >= 2 modules, "
                f"got shape {positions.shape}"
            )
        if not np.all(np.isfinite(positions)):
            raise RobotError(f"module_positions must be finite, got {positions.tolist()}")
        object.__setattr__(self, "module_positions", readonly(positions))
        radius = positive_finite("wheel_radius", self.wheel_radius)
        object.__setattr__(self, "wheel_radius", radius)
        object.__setattr__(self, "max_speed", positive_finite("max_wheel_speed", self.max_speed))
        object.__setattr__(
            self, "max_steer_rate", positive_finite("max_steer_rate", self.max_steer_rate)
        )
        if self.max_accel is not None:
            object.__setattr__(
                self, "max_accel", positive_finite("max_wheel_accel", self.max_accel)
            )
        n = positions.shape[0]
        # Ground velocity of module i: [[1, 0, -y_i], [0, 1, x_i]] @ twist [m/s].
        ground = np.zeros((n, 2, 3))
        ground[:, 0, 0] = 1.0
        ground[:, 1, 1] = 1.0
        ground[:, 0, 2] = -positions[:, 1]
        ground[:, 1, 2] = positions[:, 0]
        check_holonomic(ground.reshape(2 * n, 3), f"swerve robot {self.name!r}")
        object.__setattr__(self, "wheel_blocks", readonly(ground / radius))
        object.__setattr__(self, "nominal_max_wheel_speed", readonly(np.full(n, self.max_speed)))
        object.__setattr__(
            self,
            "nominal_max_wheel_accel",
            None if self.max_accel is None else readonly(np.full(n, self.max_accel)),
        )
        object.__setattr__(self, "_pinv", readonly(np.linalg.pinv(ground.reshape(2 * n, 3))))
        self._check_derating()

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Module wheel speeds ``|v_i| / r`` [rad/s], non-negative, shape (n,) or (k, n)."""
        return np.linalg.norm(self.wheel_velocities(twist), axis=-1)

    def module_velocities(self, twist: ArrayLike) -> FloatArray:
        """Module ground velocities ``v_i`` [m/s], shape (..., n, 2)."""
        return self.wheel_velocities(twist) * self.wheel_radius

    def module_states(
        self, twist: ArrayLike, current_angles: ArrayLike | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Signed wheel speeds [rad/s] and steer angles [rad] for one twist.

        Rules (kinematics.md): a module more than 90 degrees from its current
        angle flips (steers to ``angle + pi`` and drives backwards; exactly
        90 degrees does not flip); a module at (near) zero speed keeps its
        current angle. Angles are wrapped into (-pi, pi].

        Args:
            twist: body twist (vx, vy, omega), shape (3,).
            current_angles: the modules' present steer angles [rad], shape (n,),
                or None (no flip; stopped modules point at 0).
        """
        xi = as_twists(twist)
        if xi.shape != (3,):
            raise RobotError(f"module_states takes one twist of shape (3,), got {xi.shape}")
        return self.states_from_velocities(self.module_velocities(xi), current_angles)

    def states_from_velocities(
        self, velocities: FloatArray, current_angles: ArrayLike | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Signed wheel speeds [rad/s] and steer angles [rad] for module velocities (n, 2) [m/s].

        The same rules as :meth:`module_states`, for module velocities that
        need not come from one rigid-body twist (e.g. after per-wheel clipping).
        """
        speed = np.hypot(velocities[:, 0], velocities[:, 1])
        angle = np.arctan2(velocities[:, 1], velocities[:, 0])
        if current_angles is None:
            current = np.zeros(self.n_wheels)
        else:
            current = np.asarray(current_angles, dtype=float)
            if current.shape != (self.n_wheels,) or not np.all(np.isfinite(current)):
                raise RobotError(
                    f"current_angles must be {self.n_wheels} finite angles, got {current_angles!r}"
                )
            flip = np.abs(wrap_angle(angle - current)) > math.pi / 2
            angle = np.where(flip, angle + math.pi, angle)
            speed = np.where(flip, -speed, speed)
        stopped = np.abs(speed) < STOPPED_MODULE_SPEED
        angle = np.where(stopped, current, angle)
        speed = np.where(stopped, 0.0, speed)
        return speed / self.wheel_radius, wrap_angle(angle)

    def twist(self, wheel_speeds: ArrayLike, steer_angles: ArrayLike) -> FloatArray:
        """Forward kinematics: least-squares twist from signed speeds and angles.

        Args:
            wheel_speeds: signed module wheel speeds [rad/s], shape (n,) or (k, n).
            steer_angles: steer angles [rad], same shape.
        """
        speeds = np.asarray(wheel_speeds, dtype=float)
        angles = np.asarray(steer_angles, dtype=float)
        if speeds.shape != angles.shape or speeds.shape[-1:] != (self.n_wheels,):
            raise RobotError(
                f"wheel_speeds and steer_angles must both have shape (..., {self.n_wheels}), "
                f"got {speeds.shape} and {angles.shape}"
            )
        if not (np.all(np.isfinite(speeds)) and np.all(np.isfinite(angles))):
            raise RobotError("wheel_speeds and steer_angles must be finite")
        ground = speeds * self.wheel_radius
        stacked = np.stack([ground * np.cos(angles), ground * np.sin(angles)], axis=-1)
        return stacked.reshape(*speeds.shape[:-1], 2 * self.n_wheels) @ self._pinv.T

    def _with_derating(self, derating: tuple[float, ...]) -> SwerveRobot:
        return replace(self, derating=derating)


def swerve(
    *,
    module_positions: ArrayLike,
    wheel_radius: float,
    max_wheel_speed: float,
    max_steer_rate: float,
    max_wheel_accel: float | None = None,
    name: str = "swerve",
) -> SwerveRobot:
    """A swerve base.

    Args:
        module_positions: (n, 2) module centres in the body frame [m], e.g. FL, FR, RL, RR.
        wheel_radius: [m].
        max_wheel_speed: per-module wheel speed limit [rad/s].
        max_steer_rate: steering rate limit [rad/s].
        max_wheel_accel: [rad/s^2] or None.
    """
    return SwerveRobot(
        name=name,
        module_positions=np.asarray(module_positions, dtype=float),
        wheel_radius=wheel_radius,
        max_speed=max_wheel_speed,
        max_steer_rate=max_steer_rate,
        max_accel=max_wheel_accel,
    )
