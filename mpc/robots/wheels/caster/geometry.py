"""What the caster helper modules (rows, prediction, clamp) read of a caster robot.

:class:`~mpc.robots.wheels.caster.robot.CasterRobot` satisfies it; the helpers take this protocol so
that they need not import the robot class that imports them.
"""

from __future__ import annotations

from typing import Any, Protocol

from numpy.typing import ArrayLike

from mpc.arrays import FloatArray


class CasterGeometry(Protocol):
    """A caster robot's axes, trails, wheels and limits."""

    @property
    def _cache(self) -> dict[Any, Any]: ...  # functions built once per robot, by key
    @property
    def name(self) -> str: ...
    @property
    def n_wheels(self) -> int: ...
    @property
    def caster_positions(self) -> ArrayLike: ...  # (n, 2) steer axes [m]
    @property
    def offsets(self) -> FloatArray: ...  # (n,) trails [m]
    @property
    def radii(self) -> FloatArray: ...  # (n,) wheel radii [m]
    @property
    def max_steer_rates(self) -> FloatArray: ...  # (n,) [rad/s]
    @property
    def max_wheel_speed(self) -> FloatArray: ...  # (n,) [rad/s], derated
    @property
    def nominal_max_wheel_speed(self) -> FloatArray: ...  # (n,) [rad/s]
    @property
    def max_wheel_accel(self) -> FloatArray | None: ...  # (n,) [rad/s^2]
