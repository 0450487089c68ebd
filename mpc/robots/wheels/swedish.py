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
from mpc.robots.description.mobility import WheelSpec
from mpc.robots.description.registry import register, register_sampler, register_wheel_set
from mpc.robots.wheels.constant_jacobian import ConstantJacobianRobot
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
class SwedishRobot(ConstantJacobianRobot):
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
    def wheel_positions(self) -> FloatArray:
        return np.array([w.position for w in self.wheels])

    def twist(self, wheel_speeds: ArrayLike) -> FloatArray:
        """Forward kinematics: least-squares twist ``pinv(J) @ wheel_speeds``, (3,) or (k, 3)."""
        return self.least_squares_twist("wheel_speeds", wheel_speeds)

    def description(self) -> dict[str, Any]:
        wheels = [{"alpha": w.alpha, "beta": w.beta, "gamma": w.gamma, "l": w.l,
                   "radius": w.radius, "max_speed": w.max_speed,
                   **({} if w.max_accel is None else {"max_accel": w.max_accel})}
                  for w in self.wheels]
        return {"type": "swedish", "name": self.name, "wheels": wheels}

    def mobility_wheels(self) -> list[dict[str, Any]]:
        return [{"type": "swedish", "x": w.position[0], "y": w.position[1],
                 "heading": w.alpha + w.beta - math.pi / 2.0, "gamma": w.gamma}
                for w in self.wheels]

    def drive_radii(self) -> FloatArray:
        return np.array([wheel.radius for wheel in self.wheels])

    def with_wheel_limits(self, max_speed: float, max_accel: FloatArray) -> SwedishRobot:
        wheels = tuple(replace(w, max_speed=max_speed, max_accel=float(a))
                       for w, a in zip(self.wheels, max_accel, strict=True))
        return replace(self, wheels=wheels, dynamics=None)


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
def _from_wheel_set(specs: Sequence[WheelSpec], *, wheel_radius: float, max_wheel_speed: float,
                    max_steer_rate: float | None, max_wheel_accel: float | None,
                    name: str) -> SwedishRobot:
    """Swedish wheels of a wheel set (:mod:`mpc.robots.description.wheel_set`): wheel
    ``(x, y)`` rolling along ``heading`` has ``alpha = atan2(y, x)``, ``l = |(x, y)|`` and
    ``beta = heading + pi / 2 - alpha``."""
    radius, speed, accel = wheel_limits(wheel_radius, max_wheel_speed, max_wheel_accel)
    wheels = []
    for spec in specs:
        alpha = math.atan2(spec.y, spec.x)
        heading = 0.0 if spec.heading is None else spec.heading
        wheels.append(SwedishWheel(alpha=alpha, beta=heading + math.pi / 2 - alpha,
                                   gamma=0.0 if spec.gamma is None else spec.gamma,
                                   l=math.hypot(spec.x, spec.y), radius=radius,
                                   max_speed=speed, max_accel=accel))
    return SwedishRobot(tuple(wheels), name=name)


def _random_omni(rng: np.random.Generator) -> dict[str, Any]:
    """Sweeps' omni robot: 3 or 4 wheels on a circle of radius 0.10-0.30 m, first wheel at
    0-360/n deg, wheel radius 25-60 mm, speed limit 15-35 rad/s."""
    u = rng.uniform
    n = int(rng.integers(3, 5))
    return {"type": "omni", "n_wheels": n, "base_radius": u(0.10, 0.30),
            "first_wheel_angle": u(0.0, 2.0 * math.pi / n), "wheel_radius": u(0.025, 0.06),
            "max_wheel_speed": u(15, 35)}


def _random_mecanum(rng: np.random.Generator) -> dict[str, Any]:
    """Sweeps' Mecanum robot: wheelbase and track 0.20-0.50 m, wheel radius 30-80 mm, speed
    limit 15-30 rad/s."""
    u = rng.uniform
    return {"type": "mecanum", "wheelbase": u(0.20, 0.50), "track": u(0.20, 0.50),
            "wheel_radius": u(0.03, 0.08), "max_wheel_speed": u(15, 30)}


register("swedish", _swedish)
register_wheel_set(("swedish",), _from_wheel_set)
register_sampler("omni", _random_omni)
register_sampler("mecanum", _random_mecanum)
