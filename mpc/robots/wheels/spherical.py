"""Driven ball (spherical) wheels: each ball spun by two actuators about the body's x and y axes.

Conventions (REP-103): body frame x forward, y left, z up; body twist
``xi = (vx, vy, omega)`` [m/s, m/s, rad/s]; spin rates [rad/s] positive by the
right-hand rule about the body's +x and +y axes.

A ball of radius ``r`` whose centre sits above body point ``p = (px, py)``
moves with the body at ``v(p) = (vx - omega*py, vy + omega*px)``. Spinning at
``w = (w_x, w_y, w_z)`` (body axes), its contact point, ``r`` below the centre,
moves at ``v(p) + w x (0, 0, -r) = (vx - omega*py - r*w_y, vy + omega*px + r*w_x)``.
No slip makes that zero:

    w_x = -(vy + omega*px) / r
    w_y =  (vx - omega*py) / r

The spin about z is free (it moves no contact point) and needs no actuator;
the body's rotation does (through ``v(p)``). Each ball gives two constant rows, one per
actuator, and each actuator has its own limit ``|w| <= max_wheel_speed``: the
feasible set of one ball is a box in ``(w_x, w_y)``, not a disk. In the
:class:`~mpc.robots.base.Robot` interface every actuator is one "wheel"
(``wheel_dim`` 1), ordered ball by ball, about +x then about +y:
``n_wheels = 2 * balls``. Forward kinematics is the least-squares twist of the
spin rates (spin rates outside the range of the rows mean slip).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, listed, readonly
from mpc.errors import RobotError
from mpc.plausibility import SIZE, WHEEL_ACCEL, WHEEL_RADIUS, WHEEL_SPEED, check_plausible
from mpc.robots.description.mobility import WheelSpec
from mpc.robots.description.registry import register, register_sampler, register_wheel_set
from mpc.robots.wheels.constant_jacobian import ConstantJacobianRobot
from mpc.validation import body_points, checked_arguments, metres, real_array


def _expand(name: str, value: object, balls: int, *, pairs: bool) -> FloatArray:
    """Finite numbers > 0 given as one number, one per ball (n,) or, if ``pairs``, one per
    actuator (n, 2); returned one per actuator, shape (2n,)."""
    forms = f"a number, {balls} numbers (one per ball)" + (
        f" or {balls} pairs (about x, about y)" if pairs else "")
    array = real_array(name, value, forms, RobotError)
    if array.shape == ():
        array = np.full(2 * balls, float(array))
    elif array.shape == (balls,):
        array = np.repeat(array, 2)
    elif pairs and array.shape == (balls, 2):
        array = array.reshape(-1)
    else:
        raise RobotError(f"{name} must be {forms}, got shape {array.shape}")
    if not np.all(np.isfinite(array)) or np.any(array <= 0.0):
        raise RobotError(f"{name} must be finite numbers > 0, got {np.asarray(value).tolist()}")
    return readonly(array)


@dataclass(frozen=True, eq=False)
class SphericalRobot(ConstantJacobianRobot):
    """A robot on driven balls; ``wheel_speeds`` are the 2n actuator spin rates [rad/s].

    Attributes:
        ball_positions: (n, 2) ball centres over the body frame [m], n >= 2, not all
            at one point.
        wheel_radius: ball radius [m], scalar or one per ball; stored as (n,).
        max_speed: spin-rate limit of each actuator [rad/s]: scalar, one per ball, or one
            per actuator as (n, 2) pairs (about x, about y); stored as (n, 2).
        max_accel: spin acceleration limit [rad/s^2] in the same forms, or None.
    """

    kind = "spherical"

    ball_positions: ArrayLike = field(default_factory=lambda: np.zeros((0, 2)))
    wheel_radius: ArrayLike = field(default=0.05, kw_only=True)
    max_speed: ArrayLike = field(default=20.0, kw_only=True)
    max_accel: ArrayLike | None = field(default=None, kw_only=True)

    def __post_init__(self) -> None:
        positions = body_points("positions", self.ball_positions, "balls", RobotError)
        balls = positions.shape[0]
        object.__setattr__(self, "ball_positions", readonly(positions))
        radius = _expand("wheel_radius", self.wheel_radius, balls, pairs=False)[0::2]
        for index, size in enumerate(radius.tolist()):
            metres(f"wheel_radius[{index}]", size, RobotError)
        object.__setattr__(self, "wheel_radius", readonly(radius))
        speed = _expand("max_wheel_speed", self.max_speed, balls, pairs=True)
        object.__setattr__(self, "max_speed", readonly(speed.reshape(balls, 2)))
        accel = None
        if self.max_accel is not None:
            accel = _expand("max_wheel_accel", self.max_accel, balls, pairs=True)
            object.__setattr__(self, "max_accel", readonly(accel.reshape(balls, 2)))
        object.__setattr__(self, "wheel_blocks", readonly(self.spin_rows()[:, None, :]))
        object.__setattr__(self, "nominal_max_wheel_speed", speed)
        object.__setattr__(self, "nominal_max_wheel_accel", accel)
        self._finish()

    def spin_rows(self) -> FloatArray:
        """Spin rate per twist unit, ``[0, -1, -px] / r`` then ``[1, 0, -py] / r`` per ball,
        shape (2n, 3) [rad/s per (m/s, m/s, rad/s)]."""
        positions = np.asarray(self.ball_positions, dtype=float)
        radius = np.asarray(self.wheel_radius, dtype=float)
        rows = np.zeros((positions.shape[0], 2, 3))
        rows[:, 0, 1] = -1.0
        rows[:, 0, 2] = -positions[:, 0]
        rows[:, 1, 0] = 1.0
        rows[:, 1, 2] = -positions[:, 1]
        return (rows / radius[:, None, None]).reshape(-1, 3)

    @property
    def n_balls(self) -> int:
        return int(np.asarray(self.ball_positions).shape[0])

    @property
    def wheel_positions(self) -> FloatArray:
        """Each actuator's ball centre [m], shape (2n, 2) (a ball's two actuators share it)."""
        return np.repeat(np.asarray(self.ball_positions, dtype=float), 2, axis=0)

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Spin rates [rad/s] ordered ball by ball (about +x, about +y), shape (2n,) or
        (k, 2n)."""
        return self.wheel_velocities(twist)[..., 0]

    def twist(self, spin_rates: ArrayLike) -> FloatArray:
        """Forward kinematics: the least-squares twist of spin rates (2n,) or (k, 2n)."""
        return self.least_squares_twist("spin_rates", spin_rates)

    def description(self) -> dict[str, Any]:
        return {"type": "spherical", "name": self.name, **listed(
            positions=self.ball_positions, wheel_radius=self.wheel_radius,
            max_wheel_speed=self.max_speed, max_wheel_accel=self.max_accel)}

    def mobility_wheels(self) -> list[dict[str, Any]]:
        return [{"type": "spherical", "x": float(x), "y": float(y)}
                for x, y in np.asarray(self.ball_positions)]

    def drive_radii(self) -> FloatArray:
        """Each ball's radius, once for each of its two actuators [m] (2n,)."""
        return np.repeat(np.asarray(self.wheel_radius, dtype=np.float64), 2)

    def with_wheel_limits(self, max_speed: float, max_accel: FloatArray) -> SphericalRobot:
        return replace(self, max_speed=max_speed, max_accel=np.reshape(max_accel, (-1, 2)),
                       dynamics=None)


@checked_arguments(RobotError)
def spherical(
    *,
    positions: ArrayLike,
    wheel_radius: ArrayLike,
    max_wheel_speed: ArrayLike,
    max_wheel_accel: ArrayLike | None = None,
    name: str = "spherical",
    allow_unusual: bool = False,
) -> SphericalRobot:
    """A robot on driven balls, each spun about the body's +x and +y axes.

    Args:
        positions: (n, 2) ball centres in the body frame [m], n >= 2.
        wheel_radius: ball radius [m], a number or one per ball.
        max_wheel_speed: actuator spin-rate limit [rad/s]: a number, one per ball, or
            (n, 2) pairs (about x, about y).
        max_wheel_accel: actuator spin acceleration limit [rad/s^2] in the same forms, or
            None for unlimited.
        name: a label.
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError naming the likely
            unit mistake.
    """
    robot = SphericalRobot(positions, name=name, wheel_radius=wheel_radius,
                           max_speed=max_wheel_speed, max_accel=max_wheel_accel)
    check_plausible({"positions": (SIZE, robot.ball_positions),
                     "wheel_radius": (WHEEL_RADIUS, robot.wheel_radius),
                     "max_wheel_speed": (WHEEL_SPEED, robot.max_speed),
                     "max_wheel_accel": (WHEEL_ACCEL, robot.max_accel)}, allow_unusual)
    return robot


def _from_wheel_set(specs: Sequence[WheelSpec], *, wheel_radius: float, max_wheel_speed: float,
                    max_steer_rate: float | None, max_wheel_accel: float | None,
                    name: str) -> SphericalRobot:
    """Balls of a wheel set (:mod:`mpc.robots.description.wheel_set`)."""
    return spherical(positions=[[spec.x, spec.y] for spec in specs], wheel_radius=wheel_radius,
                     max_wheel_speed=max_wheel_speed, max_wheel_accel=max_wheel_accel,
                     name=name, allow_unusual=True)


def _random_balls(rng: np.random.Generator) -> dict[str, Any]:
    """Sweeps' ball robot: 3 balls on a circle of radius 0.12-0.30 m, ball radius 30-60 mm,
    speed limit 15-30 rad/s."""
    u = rng.uniform
    radius, first = u(0.12, 0.30), u(0.0, 2.0 * math.pi)
    angles = first + 2.0 * math.pi * np.arange(3) / 3
    return {"type": "spherical", "wheel_radius": u(0.03, 0.06), "max_wheel_speed": u(15, 30),
            "positions": (radius * np.column_stack([np.cos(angles), np.sin(angles)])).tolist()}


register("spherical", spherical)
register_wheel_set(("spherical",), _from_wheel_set)
register_sampler("ball", _random_balls)
