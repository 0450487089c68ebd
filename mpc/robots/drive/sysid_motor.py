"""SysId's wheel model: the feedforward ``V = kS sgn(w) + kV w + kA dw/dt`` WPILib's SysId
identifies, in the wheel's angular units (rad), as the rest of this library measures
wheel speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.validation import finite, non_negative, positive

#: A scalar or an array: every model method maps floats to a float, arrays to an array.
Value = TypeVar("Value", float, FloatArray)


@dataclass(frozen=True)
class SysIdMotor:
    """A wheel described by SysId's feedforward ``V = kS sgn(w) + kV w + kA dw/dt``.

    Units are the wheel's angular ones, as everywhere in this library (wheel
    speed ``w`` in rad/s); :meth:`from_linear` converts SysId constants
    identified in metres. WPILib's ``SimpleMotorFeedforwardRadians`` with the
    same constants gives the same voltages.

    Attributes:
        kS: static friction voltage [V], >= 0.
        kV: voltage per wheel speed [V s/rad], > 0.
        kA: voltage per wheel acceleration [V s^2/rad], >= 0.
    """

    kS: float  # SysId's names
    kV: float
    kA: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "kS", non_negative("kS [V]", self.kS, RobotError))
        object.__setattr__(self, "kV", positive("kV [V s/rad]", self.kV, RobotError))
        object.__setattr__(self, "kA", non_negative("kA [V s^2/rad]", self.kA, RobotError))

    @classmethod
    def from_linear(cls, kS: float, kV: float, kA: float, wheel_radius: float) -> SysIdMotor:
        """From constants identified in metres: ``kV`` [V s/m], ``kA`` [V s^2/m] and the
        wheel radius [m] (a wheel speed ``w`` [rad/s] is a rim speed ``r w`` [m/s])."""
        radius = positive("wheel_radius [m]", wheel_radius, RobotError)
        return cls(kS, finite("kV [V s/m]", kV, RobotError) * radius,
                   finite("kA [V s^2/m]", kA, RobotError) * radius)

    def voltage(self, speed: Value, acceleration: Value) -> Value:
        """Voltage [V] for wheel speed [rad/s] and acceleration [rad/s^2]."""
        return self.kS * np.sign(speed) + self.kV * speed + self.kA * acceleration

    def voltage_for_step(self, speed: Value, next_speed: Value, dt: float) -> Value:
        """Constant voltage [V] over ``dt`` [s] that takes the wheel from ``speed`` to
        ``next_speed`` [rad/s], exactly for the model (WPILib's current/next ``calculate``)."""
        step = positive("dt [s]", dt, RobotError)
        if self.kA < 1e-9:
            return self.kS * np.sign(next_speed) + self.kV * next_speed
        pole = -self.kV / self.kA
        inverse_ka = 1.0 / self.kA
        decay = math.exp(pole * step)
        gain = inverse_ka * step if pole > -1e-9 else 1.0 / pole * (decay - 1.0) * inverse_ka
        return self.kS * np.sign(speed) + 1.0 / gain * (next_speed - decay * speed)

    def max_acceleration(self, voltage: Value, speed: Value) -> Value:
        """Largest wheel acceleration [rad/s^2] with ``voltage`` [V] at ``speed`` [rad/s];
        infinite when ``kA`` is 0."""
        with np.errstate(divide="ignore"):
            return (voltage - self.kS * np.sign(speed) - self.kV * speed) / np.float64(self.kA)

    def max_speed(self, voltage: float, acceleration: float = 0.0) -> float:
        """Largest steady wheel speed [rad/s] with ``voltage`` [V] while accelerating."""
        return (voltage - self.kS - self.kA * acceleration) / self.kV
