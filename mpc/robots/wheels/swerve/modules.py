"""What the swerve helper modules (rows, states, axle offset) read of a swerve robot.

:class:`~mpc.robots.wheels.swerve.robot.SwerveRobot` satisfies it; the helpers take this protocol so
that they need not import the robot class that imports them.
"""

from __future__ import annotations

from typing import Protocol

from numpy.typing import ArrayLike

from mpc.arrays import FloatArray


class SwerveModules(Protocol):
    """A swerve robot's modules: geometry [m], wheel maps and limits."""

    @property
    def name(self) -> str: ...
    @property
    def n_wheels(self) -> int: ...
    @property
    def wheel_blocks(self) -> FloatArray: ...  # (n, 2, 3) [rad/s per twist unit]
    @property
    def flat_wheel_blocks(self) -> FloatArray: ...  # (2n, 3)
    @property
    def wheel_radius(self) -> float: ...  # [m]
    @property
    def axle_offset(self) -> float: ...  # [m]
    @property
    def max_steer_rate(self) -> float: ...  # [rad/s]
    @property
    def max_wheel_speed(self) -> FloatArray: ...  # (n,) [rad/s], derated
    @property
    def nominal_max_wheel_speed(self) -> FloatArray: ...  # (n,) [rad/s]
    @property
    def max_wheel_accel(self) -> FloatArray | None: ...  # (n,) [rad/s^2]

    def ground_maps(self) -> FloatArray: ...  # (n, 2, 3)

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray: ...  # [rad/s]
