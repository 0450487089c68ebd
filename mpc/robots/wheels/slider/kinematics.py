"""The steered wheel on a radial slider (the founding analysis's Eq. 8; SWOM): kinematics.

Unit ``i``: a rail from the body origin at angle ``alpha`` (body frame, REP-103), a
slider carrying a steered wheel along it at ``l`` [m] from the origin (the contact point
``C = l (cos alpha, sin alpha)``), moving at ``ldot`` [m/s]; the steer angle ``beta``
[rad] is measured from the rail, as a fixed wheel's; wheel radius ``r`` [m], drive rate
``phidot`` [rad/s]. With ``e = (-sin(a+b), cos(a+b))`` the rolling direction,
``n = (cos(a+b), sin(a+b))`` the axle and ``v(C)`` the body's velocity at ``C``, the wheel
rolls without slipping when

    rolling:   -sin(a+b) vx + cos(a+b) vy + l cos(b) omega = r phidot + ldot sin(b)
    no slip:    cos(a+b) vx + sin(a+b) vy + l sin(b) omega = -ldot cos(b)

so for a twist and a steer angle (``cos b != 0``: at ``b = +-90 deg`` the slider runs
along the rolling direction and the no-slip row loses it)

    ldot = -(n . v(C)) / cos(b),        r phidot = e . v(C) - ldot sin(b).

Both rows are linear in the twist: forward kinematics is their least-squares twist. The
slider position and the steer angle are states (the stroke ``[l_min, l_max]`` bounds the
first); this module is the kinematics of one or more units (the robot, its limits and
its joint states: the rest of :mod:`mpc.robots.wheels.slider`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.validation import MAX_COORDINATE, bounded, finite_vector, metres, positive, shown

#: Smallest ``|cos(beta)|`` at which a unit's slider rate is defined (beta 90 deg off the
#: rail: the slider runs along the rolling direction).
MIN_COS_STEER = 1e-6


@dataclass(frozen=True)
class SliderUnit:
    """One wheel on a radial slider.

    Attributes:
        rail_angle: the rail's angle ``alpha`` from the body x axis [rad].
        stroke: the slider's range ``(l_min, l_max)``: the contact point's distance from
            the body origin [m], ``0 <= l_min < l_max``.
        wheel_radius: [m].
        max_wheel_speed: drive rate limit [rad/s].
        max_steer_rate: steer rate limit [rad/s].
        max_slider_speed: slider rate limit [m/s].
    """

    rail_angle: float
    stroke: tuple[float, float]
    wheel_radius: float
    max_wheel_speed: float
    max_steer_rate: float
    max_slider_speed: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "rail_angle", bounded("rail_angle", self.rail_angle,
                                                       MAX_COORDINATE, "[rad]", RobotError))
        ends = finite_vector("stroke", self.stroke, 2, "(l_min, l_max) [m]", RobotError)
        low, high = (metres(f"stroke[{i}]", end, RobotError, zero=True)
                     for i, end in enumerate(ends.tolist()))
        if not low < high:
            raise RobotError(f"stroke must be (l_min, l_max) with l_min < l_max [m], got "
                             f"{shown(self.stroke)}")
        object.__setattr__(self, "stroke", (low, high))
        object.__setattr__(self, "wheel_radius",
                           metres("wheel_radius", self.wheel_radius, RobotError))
        for name in ("max_wheel_speed", "max_steer_rate", "max_slider_speed"):
            object.__setattr__(self, name, positive(name, getattr(self, name), RobotError))

    def joint_rates(self, twist: ArrayLike, steer_angle: float,
                    position: float) -> tuple[float, float]:
        """(drive rate ``phidot`` [rad/s], slider rate ``ldot`` [m/s]) that roll the wheel
        without slipping for body ``twist`` (vx, vy, omega), at ``steer_angle`` [rad] from
        the rail and slider ``position`` [m]."""
        vx, vy, omega = finite_vector("twist", twist, 3, "(vx, vy, omega) [m/s, m/s, rad/s]",
                                      RobotError).tolist()
        beta = bounded("steer_angle", steer_angle, MAX_COORDINATE, "[rad]", RobotError)
        length = bounded("position", position, MAX_COORDINATE, "[m]", RobotError)
        if abs(math.cos(beta)) < MIN_COS_STEER:
            raise RobotError(f"steer_angle {shown(steer_angle)} is 90 deg from the rail: the "
                             "slider runs along the rolling direction and its rate is "
                             "not defined")
        a = self.rail_angle
        cx, cy = length * math.cos(a), length * math.sin(a)
        wx, wy = vx - omega * cy, vy + omega * cx  # v(C)
        heading = a + beta
        slide = -(math.cos(heading) * wx + math.sin(heading) * wy) / math.cos(beta)
        rim = -math.sin(heading) * wx + math.cos(heading) * wy - slide * math.sin(beta)
        return rim / self.wheel_radius, slide

    def rows(self, steer_angle: float, position: float) -> FloatArray:
        """The rolling and no-slip rows (2, 3) at ``steer_angle`` [rad] and ``position`` [m]:
        ``rows @ twist = (r phidot + ldot sin b, -ldot cos b)``."""
        heading = self.rail_angle + steer_angle
        return np.array([
            [-math.sin(heading), math.cos(heading), position * math.cos(steer_angle)],
            [math.cos(heading), math.sin(heading), position * math.sin(steer_angle)]])


def slider_twist(units: tuple[SliderUnit, ...], steer_angles: ArrayLike, positions: ArrayLike,
                 drive_rates: ArrayLike, slider_rates: ArrayLike) -> FloatArray:
    """Forward kinematics: the least-squares body twist (vx, vy, omega) of the units' drive
    rates [rad/s] and slider rates [m/s] at their steer angles [rad] and positions [m]
    (exact when the rates roll every wheel without slipping; slip otherwise)."""
    count = len(units)
    if count < 2 or not all(isinstance(unit, SliderUnit) for unit in units):
        raise RobotError(f"units must be at least 2 SliderUnit objects, got {shown(units)}")
    what = f"one value per unit ({count})"
    betas = finite_vector("steer_angles", steer_angles, count, what, RobotError)
    lengths = finite_vector("positions", positions, count, what, RobotError)
    drive = finite_vector("drive_rates", drive_rates, count, what, RobotError)
    slide = finite_vector("slider_rates", slider_rates, count, what, RobotError)
    rows = np.vstack([unit.rows(b, length) for unit, b, length in
                      zip(units, betas.tolist(), lengths.tolist(), strict=True)])
    radii = np.array([unit.wheel_radius for unit in units])
    right = np.column_stack([radii * drive + slide * np.sin(betas), -slide * np.cos(betas)])
    twist, *_ = np.linalg.lstsq(rows, right.reshape(-1), rcond=None)
    return np.asarray(twist, dtype=float)
