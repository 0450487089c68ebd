"""Swedish-wheel robots (omni and Mecanum), in Siegwart's general wheel model.

Wheel ``i`` sits at polar angle ``alpha`` and distance ``l`` from the body
origin; ``beta`` is the angle of its plane relative to that leg and ``gamma``
the angle between its rollers and its plane (0 omni, +-45 deg Mecanum). Its
rolling constraint in the body frame (REP-103: x forward, y left, yaw
counter-clockwise) is

    [sin(a+b+g), -cos(a+b+g), -l cos(b+g)] @ xi = r * phidot * cos(g)

so ``phidot = J @ xi`` with ``J_i = [sin(a+b+g), -cos(a+b+g), -l cos(b+g)] / (r cos g)``:
a signed wheel speed [rad/s] per body twist ``xi = (vx, vy, omega)``. Each
wheel's limit ``|J_i xi| <= max_speed`` is one exact linear row.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, readonly
from mpc.errors import RobotError
from mpc.plausibility import (
    SIZE,
    WHEEL_ACCEL,
    WHEEL_RADIUS,
    WHEEL_SPEED,
    check_plausible,
)
from mpc.robots.base import Robot, SpeedRows, WheelCommands
from mpc.robots.registry import register
from mpc.validation import (
    MAX_COORDINATE,
    MAX_WHEELS,
    bounded,
    checked_arguments,
    integer_in,
    metres,
    positive,
    shown,
)


@dataclass(frozen=True)
class SwedishWheel:
    """One Swedish wheel in Siegwart's notation.

    Attributes:
        alpha: polar angle of the wheel centre in the body frame [rad].
        beta: angle of the wheel plane relative to the leg ``l`` [rad].
        gamma: angle between roller axes and wheel plane [rad]; 0 omni, +-pi/4 Mecanum.
        l: distance of the wheel centre from the body origin [m], >= 0.
        radius: wheel radius [m].
        max_speed: wheel speed limit [rad/s].
        max_accel: wheel acceleration limit [rad/s^2], or None for unlimited.
    """

    alpha: float
    beta: float
    gamma: float
    l: float  # noqa: E741  (Siegwart's symbol)
    radius: float
    max_speed: float
    max_accel: float | None = None

    def __post_init__(self) -> None:
        for name in ("alpha", "beta", "gamma"):
            object.__setattr__(self, name, bounded(name, getattr(self, name), MAX_COORDINATE,
                                                   "[rad]", RobotError))
        object.__setattr__(self, "l", metres("l", self.l, RobotError, zero=True))
        object.__setattr__(self, "radius", metres("radius", self.radius, RobotError))
        object.__setattr__(self, "max_speed", positive("max_speed", self.max_speed, RobotError))
        if self.max_accel is not None:
            object.__setattr__(self, "max_accel",
                               positive("max_accel", self.max_accel, RobotError))
        if abs(math.cos(self.gamma)) < 1e-9:
            raise RobotError(
                f"gamma must not be +-pi/2 (rollers parallel to the axle), got {shown(self.gamma)}"
            )

    @property
    def jacobian_row(self) -> FloatArray:
        """``J_i`` [rad/s per (m/s, m/s, rad/s)], shape (3,)."""
        a, b, g = self.alpha, self.beta, self.gamma
        row = np.array([math.sin(a + b + g), -math.cos(a + b + g), -self.l * math.cos(b + g)])
        return row / (self.radius * math.cos(g))

    @property
    def position(self) -> tuple[float, float]:
        """Wheel centre (x, y) in the body frame [m]."""
        return self.l * math.cos(self.alpha), self.l * math.sin(self.alpha)


@dataclass(frozen=True, eq=False)
class SwedishRobot(Robot):
    """A robot on Swedish wheels: ``wheel_speeds = J @ twist`` (signed, rad/s).

    Args:
        wheels: at least three :class:`SwedishWheel` whose rows span every twist.
        name: a label.
    """

    kind = "swedish"

    wheels: tuple[SwedishWheel, ...] = ()

    def __post_init__(self) -> None:
        wheels = tuple(self.wheels) if isinstance(self.wheels, Sequence) else ()
        if len(wheels) > MAX_WHEELS:
            raise RobotError(f"a robot has at most {MAX_WHEELS} wheels (a bound of this "
                             f"library), got {len(wheels)}")
        if len(wheels) < 3 or not all(isinstance(w, SwedishWheel) for w in wheels):
            raise RobotError(
                f"a Swedish robot needs a sequence of at least 3 SwedishWheel objects, "
                f"got {shown(self.wheels)}"
            )
        object.__setattr__(self, "wheels", wheels)
        jacobian = np.array([w.jacobian_row for w in wheels])
        object.__setattr__(self, "wheel_blocks", readonly(jacobian[:, None, :]))
        object.__setattr__(self, "nominal_max_wheel_speed",
                           readonly([w.max_speed for w in wheels]))
        accels = [w.max_accel for w in wheels if w.max_accel is not None]
        if accels and len(accels) != len(wheels):
            raise RobotError("either every wheel has max_accel or none has")
        object.__setattr__(self, "nominal_max_wheel_accel", readonly(accels) if accels else None)
        self._finish()

    @property
    def jacobian(self) -> FloatArray:
        """Inverse-kinematics Jacobian ``J`` (n x 3) [rad/s per twist unit]."""
        return self.wheel_blocks[:, 0, :]

    @property
    def wheel_positions(self) -> FloatArray:
        return np.array([w.position for w in self.wheels])

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Signed wheel speeds ``J @ twist`` [rad/s], shape (n,) or (k, n)."""
        return self.wheel_velocities(twist)[..., 0]

    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        return np.abs(self.jacobian @ twist)

    def twist(self, wheel_speeds: ArrayLike) -> FloatArray:
        """Forward kinematics: least-squares twist ``pinv(J) @ wheel_speeds``, (3,) or (k, 3)."""
        speeds = np.asarray(wheel_speeds, dtype=float)
        if speeds.ndim not in (1, 2) or speeds.shape[-1] != self.n_wheels:
            raise RobotError(
                f"wheel_speeds must have shape ({self.n_wheels},) or (k, {self.n_wheels}), "
                f"got shape {speeds.shape}"
            )
        if not np.all(np.isfinite(speeds)):
            raise RobotError(f"wheel_speeds must be finite, got {speeds}")
        return speeds @ self._flat_pinv.T

    def forward_kinematics(self, wheel_speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        return self._flat_pinv @ wheel_speeds

    def commands_from_velocities(self, velocities: FloatArray,
                                 steer_angles: FloatArray | None) -> WheelCommands:
        return WheelCommands(velocities[:, 0].copy(), None)

    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        return SpeedRows(self.jacobian.copy(), np.arange(self.n_wheels), 1.0)

    def casadi_limits(self, twist: ca.SX, bounds: FloatArray) -> tuple[ca.SX, FloatArray,
                                                                         FloatArray]:
        return ca.DM(self.jacobian) @ twist, -np.asarray(bounds), np.asarray(bounds)

    def _with_derating(self, derating: tuple[float, ...]) -> SwedishRobot:
        return replace(self, derating=derating)


def wheel_limits(wheel_radius: object, max_wheel_speed: object,
                 max_wheel_accel: object) -> tuple[float, float, float | None]:
    """A factory's wheel radius [m], speed [rad/s] and acceleration limit [rad/s^2] (or
    None), checked under the names the caller passed them by."""
    accel = None if max_wheel_accel is None else positive("max_wheel_accel", max_wheel_accel,
                                                          RobotError)
    return (metres("wheel_radius", wheel_radius, RobotError),
            positive("max_wheel_speed", max_wheel_speed, RobotError), accel)


@checked_arguments(RobotError)
def omni(
    *,
    n_wheels: int,
    base_radius: float,
    wheel_radius: float,
    max_wheel_speed: float,
    first_wheel_angle: float = math.pi / 2,
    max_wheel_accel: float | None = None,
    name: str = "omni",
    allow_unusual: bool = False,
) -> SwedishRobot:
    """Omni wheels on a circle, driving tangentially, counter-clockwise positive.

    ``r * phidot_i = -sin(alpha_i) vx + cos(alpha_i) vy + base_radius * omega`` with
    ``alpha_i = first_wheel_angle + 2 pi i / n_wheels`` (Siegwart's beta = pi, gamma = 0):
    a positive speed on every wheel spins the robot counter-clockwise. Wheel 0 is
    the one at ``first_wheel_angle``; the order is counter-clockwise.

    Args:
        n_wheels: number of wheels, >= 3.
        base_radius: distance of each wheel centre from the body origin [m].
        wheel_radius: [m].
        max_wheel_speed: [rad/s].
        first_wheel_angle: polar angle of wheel 0's centre [rad].
        max_wheel_accel: [rad/s^2] or None.
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError naming the likely
            unit mistake.
    """
    count = integer_in("n_wheels", n_wheels, 3, MAX_WHEELS, RobotError)
    base = metres("base_radius", base_radius, RobotError)
    first = bounded("first_wheel_angle", first_wheel_angle, MAX_COORDINATE, "[rad]", RobotError)
    radius, speed, accel = wheel_limits(wheel_radius, max_wheel_speed, max_wheel_accel)
    wheels = tuple(
        SwedishWheel(alpha=first + 2.0 * math.pi * i / count, beta=math.pi, gamma=0.0, l=base,
                     radius=radius, max_speed=speed, max_accel=accel)
        for i in range(count)
    )
    robot = SwedishRobot(wheels, name=name)
    check_plausible({"base_radius": (SIZE, base), "wheel_radius": (WHEEL_RADIUS, radius),
                     "max_wheel_speed": (WHEEL_SPEED, speed),
                     "max_wheel_accel": (WHEEL_ACCEL, accel)}, allow_unusual)
    return robot


@checked_arguments(RobotError)
def mecanum(
    *,
    wheelbase: float,
    track: float,
    wheel_radius: float,
    max_wheel_speed: float,
    max_wheel_accel: float | None = None,
    name: str = "mecanum",
    allow_unusual: bool = False,
) -> SwedishRobot:
    """Four Mecanum wheels in the X ("ABAB") pattern, order FL, FR, RL, RR.

    ``r * phidot = (vx - vy - k w, vx + vy + k w, vx + vy - k w, vx - vy + k w)``
    with ``k = (wheelbase + track) / 2``, as WPILib's ``MecanumDriveKinematics``
    (ROS 2's ``mecanum_drive_controller`` orders its commands FL, FR, RR, RL).

    Args:
        wheelbase: front-rear distance between wheel centres [m].
        track: left-right distance between wheel centres [m].
        wheel_radius: [m].
        max_wheel_speed: [rad/s].
        max_wheel_accel: [rad/s^2] or None.
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError naming the likely
            unit mistake.
    """
    half_x = metres("wheelbase", wheelbase, RobotError) / 2.0
    half_y = metres("track", track, RobotError) / 2.0
    radius, speed, accel = wheel_limits(wheel_radius, max_wheel_speed, max_wheel_accel)
    quarter = math.pi / 4.0
    corners = ((half_x, half_y, -quarter), (half_x, -half_y, quarter),
               (-half_x, half_y, quarter), (-half_x, -half_y, -quarter))
    wheels = []
    for x, y, gamma in corners:
        alpha = math.atan2(y, x)
        wheels.append(SwedishWheel(alpha=alpha, beta=math.pi / 2.0 - alpha, gamma=gamma,
                                   l=math.hypot(x, y), radius=radius, max_speed=speed,
                                   max_accel=accel))
    robot = SwedishRobot(tuple(wheels), name=name)
    check_plausible({"wheelbase": (SIZE, 2.0 * half_x), "track": (SIZE, 2.0 * half_y),
                     "wheel_radius": (WHEEL_RADIUS, radius),
                     "max_wheel_speed": (WHEEL_SPEED, speed),
                     "max_wheel_accel": (WHEEL_ACCEL, accel)}, allow_unusual)
    return robot


def _swedish(*, wheels: Sequence[Mapping[str, Any]], name: str = "swedish",
             allow_unusual: bool = False) -> SwedishRobot:
    """A Swedish robot from wheel tables (the fields of :class:`SwedishWheel`); sizes and
    limits beyond any real robot's raise RobotError unless ``allow_unusual``."""
    allowed = {"alpha", "beta", "gamma", "l", "radius", "max_speed", "max_accel"}
    required = allowed - {"max_accel"}
    if not isinstance(wheels, Sequence) or isinstance(wheels, str):
        raise RobotError(f"wheels must be a list of wheel tables, got {shown(wheels)}")
    built = []
    for index, table in enumerate(wheels):
        if not isinstance(table, Mapping):
            raise RobotError(f"wheels[{index}] must be a table, got {shown(table)}")
        unknown = sorted(set(table) - allowed)
        missing = sorted(required - set(table))
        if unknown or missing:
            raise RobotError(f"wheels[{index}]: unknown key(s) {unknown}, missing key(s) "
                             f"{missing}; expected {sorted(allowed)}")
        built.append(SwedishWheel(**table))
    robot = SwedishRobot(tuple(built), name=name)
    for index, wheel in enumerate(built):
        check_plausible({f"wheels[{index}].l": (SIZE, wheel.l),
                         f"wheels[{index}].radius": (WHEEL_RADIUS, wheel.radius),
                         f"wheels[{index}].max_speed": (WHEEL_SPEED, wheel.max_speed),
                         f"wheels[{index}].max_accel": (WHEEL_ACCEL, wheel.max_accel)},
                        allow_unusual)
    return robot


register("omni", omni)
register("mecanum", mecanum)
register("swedish", _swedish)
