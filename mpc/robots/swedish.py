"""Swedish-wheel robots (omni and Mecanum), in Siegwart's general wheel model.

Wheel ``i`` (see ``../shared/docs/kinematics.md``) obeys the rolling constraint

    [sin(a+b+g), -cos(a+b+g), -l cos(b+g)] @ xi = r * phidot * cos(g)

so ``phidot = J @ xi`` with ``J_i = [sin(a+b+g), -cos(a+b+g), -l cos(b+g)] / (r cos g)``.
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
    check_holonomic,
    finite,
    positive_finite,
    readonly,
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
            object.__setattr__(self, name, finite(name, getattr(self, name)))
        length = finite("l", self.l)
        if length < 0.0:
            raise RobotError(f"l must be >= 0 (a distance), got {self.l!r}")
        object.__setattr__(self, "l", length)
        object.__setattr__(self, "radius", positive_finite("radius", self.radius))
        object.__setattr__(self, "max_speed", positive_finite("max_speed", self.max_speed))
        if self.max_accel is not None:
            object.__setattr__(self, "max_accel", positive_finite("max_accel", self.max_accel))
        if abs(math.cos(self.gamma)) < 1e-9:
            raise RobotError(
                f"gamma must not be +-pi/2 (rollers parallel to the axle), got {self.gamma!r}"
            )

    @property
    def jacobian_row(self) -> FloatArray:
        """``J_i`` [rad/s per (m/s, m/s, rad/s)], shape (3,)."""
        a, b, g = self.alpha, self.beta, self.gamma
        row = np.array([math.sin(a + b + g), -math.cos(a + b + g), -self.l * math.cos(b + g)])
        return row / (self.radius * math.cos(g))


@dataclass(frozen=True, eq=False)
class SwedishRobot(Robot):
    """A robot on Swedish wheels: ``wheel_speeds = J @ twist`` (signed, rad/s)."""

    wheels: tuple[SwedishWheel, ...] = field(default=(), kw_only=True)
    _pinv: FloatArray = field(init=False, repr=False)  # least-squares inverse of J

    def __post_init__(self) -> None:
        wheels = tuple(self.wheels)
        if len(wheels) < 3 or not all(isinstance(w, SwedishWheel) for w in wheels):
            raise RobotError(
                f"a Swedish robot needs at least 3 SwedishWheel objects, got {self.wheels!r}"
            )
        object.__setattr__(self, "wheels", wheels)
        jacobian = np.array([w.jacobian_row for w in wheels])
        check_holonomic(jacobian, f"robot {self.name!r}")
        object.__setattr__(self, "wheel_blocks", readonly(jacobian[:, None, :]))
        object.__setattr__(
            self, "nominal_max_wheel_speed", readonly([w.max_speed for w in wheels])
        )
        accels = [w.max_accel for w in wheels]
        if all(a is None for a in accels):
            object.__setattr__(self, "nominal_max_wheel_accel", None)
        elif any(a is None for a in accels):
            raise RobotError("either every wheel has max_accel or none has")
        else:
            object.__setattr__(self, "nominal_max_wheel_accel",
                               readonly([float(a) for a in accels if a is not None]))
        object.__setattr__(self, "_pinv", readonly(np.linalg.pinv(jacobian)))
        self._check_derating()

    @property
    def jacobian(self) -> FloatArray:
        """Inverse-kinematics Jacobian ``J`` (n x 3) [rad/s per twist unit]."""
        return self.wheel_blocks[:, 0, :]

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Signed wheel speeds ``J @ twist`` [rad/s], shape (n,) or (k, n)."""
        return self.wheel_velocities(twist)[..., 0]

    def twist(self, wheel_speeds: ArrayLike) -> FloatArray:
        """Forward kinematics: least-squares twist ``pinv(J) @ wheel_speeds``."""
        speeds = np.asarray(wheel_speeds, dtype=float)
        if speeds.ndim not in (1, 2) or speeds.shape[-1] != self.n_wheels:
            raise RobotError(
                f"wheel_speeds must have shape ({self.n_wheels},) or (k, {self.n_wheels}), "
                f"got shape {speeds.shape}"
            )
        if not np.all(np.isfinite(speeds)):
            raise RobotError(f"wheel_speeds must be finite, got {speeds}")
        return speeds @ self._pinv.T

    def _with_derating(self, derating: tuple[float, ...]) -> SwedishRobot:
        return replace(self, derating=derating)


def omni(
    *,
    n_wheels: int,
    base_radius: float,
    wheel_radius: float,
    max_wheel_speed: float,
    first_wheel_angle: float = math.pi / 2,
    max_wheel_accel: float | None = None,
    name: str = "omni",
) -> SwedishRobot:
    """Omni wheels on a circle, driving tangentially, counter-clockwise positive.

    ``r * phidot_i = -sin(alpha_i) vx + cos(alpha_i) vy + base_radius * omega`` with
    ``alpha_i = first_wheel_angle + 2 pi i / n_wheels`` (Siegwart's beta = pi, gamma = 0).

    Args:
        n_wheels: number of wheels, >= 3.
        base_radius: distance of each wheel centre from the body origin [m].
        wheel_radius: [m].
        max_wheel_speed: [rad/s].
        first_wheel_angle: polar angle of wheel 0's centre [rad].
        max_wheel_accel: [rad/s^2] or None.
    """
    if isinstance(n_wheels, bool) or not isinstance(n_wheels, (int, np.integer)) or n_wheels < 3:
        raise RobotError(f"n_wheels must be an integer >= 3, got {n_wheels!r}")
    base = positive_finite("base_radius", base_radius)
    first = finite("first_wheel_angle", first_wheel_angle)
    wheels = tuple(
        SwedishWheel(
            alpha=first + 2.0 * math.pi * i / n_wheels,
            beta=math.pi,
            gamma=0.0,
            l=base,
            radius=wheel_radius,
            max_speed=max_wheel_speed,
            max_accel=max_wheel_accel,
        )
        for i in range(int(n_wheels))
    )
    return SwedishRobot(name=name, wheels=wheels)


def mecanum(
    *,
    wheelbase: float,
    track: float,
    wheel_radius: float,
    max_wheel_speed: float,
    max_wheel_accel: float | None = None,
    name: str = "mecanum",
) -> SwedishRobot:
    """Four Mecanum wheels in the X ("ABAB") pattern, order FL, FR, RL, RR.

    ``r * phidot = (vx - vy - k w, vx + vy + k w, vx + vy - k w, vx - vy + k w)``
    with ``k = (wheelbase + track) / 2``, as WPILib's ``MecanumDriveKinematics``.

    Args:
        wheelbase: front-rear distance between wheel centres [m].
        track: left-right distance between wheel centres [m].
        wheel_radius: [m].
        max_wheel_speed: [rad/s].
        max_wheel_accel: [rad/s^2] or None.
    """
    half_x = positive_finite("wheelbase", wheelbase) / 2.0
    half_y = positive_finite("track", track) / 2.0
    quarter = math.pi / 4.0
    corners = ((half_x, half_y, -quarter), (half_x, -half_y, quarter),
               (-half_x, half_y, quarter), (-half_x, -half_y, -quarter))
    wheels = []
    for x, y, gamma in corners:
        alpha = math.atan2(y, x)
        wheels.append(
            SwedishWheel(
                alpha=alpha,
                beta=math.pi / 2.0 - alpha,
                gamma=gamma,
                l=math.hypot(x, y),
                radius=wheel_radius,
                max_speed=max_wheel_speed,
                max_accel=max_wheel_accel,
            )
        )
    return SwedishRobot(name=name, wheels=tuple(wheels))
