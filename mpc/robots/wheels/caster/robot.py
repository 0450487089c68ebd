"""Powered offset casters: each wheel driven and steered, its contact trailing the steer axis.

Conventions (REP-103): body frame x forward, y left, z up; body twist
``xi = (vx, vy, omega)`` [m/s, m/s, rad/s]; angles counter-clockwise positive [rad].

Caster ``i`` has its steer axis at body point ``P = (px, py)`` [m]. Its steer angle
``beta`` [rad] is the wheel's rolling heading in the body frame (0 = rolling towards
+x), ``e = (cos beta, sin beta)``, ``n = (-sin beta, cos beta)`` (``e`` turned +90 deg).
The contact point trails the axis by the offset ``d > 0`` [m], ``C = P - d e``; the
wheel radius is ``r`` [m]. A positive drive rate ``phidot`` [rad/s] rolls the wheel
along ``+e``; a positive steer rate ``betadot`` [rad/s] turns it counter-clockwise
relative to the body. With ``v(P) = (vx - omega py, vy + omega px)`` the velocity of
the body point P, rolling without lateral slip gives (both rows linear in the twist
for a given ``beta``)::

    r * phidot  =  e . v(P)
    d * betadot =  n . v(P) - d * omega

The ``- d * omega`` term is the robot's own rotation: a caster whose axis does not
move keeps its heading in the world, so it turns by ``-omega`` in the body frame.
Forward kinematics: the body point under each contact moves at
``v(C) = r phidot e + d betadot n``; the twist is the least-squares solution of
``[[1, 0, -Cy], [0, 1, Cx]] xi = v(C)`` over all casters (the residual means slip).

**The steer angles are states of the robot, not commands**: every twist fixes
``betadot``, so the angles follow from the motion and a controller must measure them
(``Controller.step(pose, t, steer_angles=...)``). The steer-rate limit
``|betadot| <= max_steer_rate`` caps the sideways speed of every axis at
``d * max_steer_rate`` (plus ``d |omega|``): the casters must turn *before* the robot
changes direction. Trailing (contact behind the axis's motion) is stable; leading is
unstable (a small misalignment grows at the rate ``|v(P)| / d``), and a leading caster
that swings round peaks at ``betadot = |v(P)| / d`` at 90 degrees. No singularity for
``d > 0``.

Limits: drive rate ``|phidot_i| <= max_wheel_speed`` and steer rate
``|betadot_i| <= max_steer_rate`` at the *present* angles; with ``max_wheel_accel``,
the change of drive rate the change of twist asks for at the present angle,
``|D_i(beta) (xi_k - xi_{k-1})| <= max_wheel_accel dt`` (the angle's own contribution
to the drive rate's change is not counted). How the solvers use them:
:mod:`mpc.robots.wheels.caster.limits`.

In the :class:`~mpc.robots.base.Robot` interface a caster is a "wheel" whose velocity
map ``W_i`` is its axis velocity over ``r`` (``wheel_dim`` 2): ``wheel_speeds(twist)``
is the drive rate of a caster trailing its axis's motion, ``|v(P)| / r`` (steady
state; the reference feasibility check and the fallback use it). The exact joint
rates at given angles are :meth:`CasterRobot.joint_rates`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, listed, readonly
from mpc.errors import RobotError
from mpc.plausibility import (
    OFFSET,
    SIZE,
    STEER_RATE,
    WHEEL_ACCEL,
    WHEEL_RADIUS,
    WHEEL_SPEED,
    check_plausible,
)
from mpc.robots.base import (
    Robot,
    SpeedRows,
    WheelCommands,
    as_twists,
    point_velocity_maps,
)
from mpc.robots.description.mobility import WheelSpec
from mpc.robots.description.registry import register, register_wheel_set, steer_rate
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.caster import limits as caster_limits
from mpc.robots.wheels.caster.checks import (
    check_distinct_contacts,
    check_positions,
    joint_vector,
    per_caster,
)
from mpc.robots.wheels.caster.kinematics import joint_twist
from mpc.robots.wheels.contact_disk import disk_casadi_limits, disk_speed_rows
from mpc.validation import checked_arguments


@dataclass(frozen=True, eq=False)
class CasterRobot(Robot):
    """A powered-caster vehicle; ``wheel_speeds`` are trailing drive rates (module docstring).

    Attributes:
        caster_positions: (n, 2) steer axes in the body frame [m], n >= 2.
        offset: the contact's trail behind each axis [m], stored as (n,).
        wheel_radius: [m], stored as (n,).
        max_speed: drive-rate limit [rad/s], stored as (n,).
        max_steer_rate: steer-rate limit [rad/s], stored as (n,).
        max_accel: drive acceleration limit [rad/s^2] as (n,), or None.
    """

    kind = "caster"
    steered = True
    steer_states = True

    caster_positions: ArrayLike = field(default_factory=lambda: np.zeros((0, 2)))
    offset: ArrayLike = field(default=0.05, kw_only=True)
    wheel_radius: ArrayLike = field(default=0.05, kw_only=True)
    max_speed: ArrayLike = field(default=20.0, kw_only=True)
    max_steer_rate: ArrayLike = field(default=10.0, kw_only=True)
    max_accel: ArrayLike | None = field(default=None, kw_only=True)
    _cache: dict[Any, Any] = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        positions = check_positions(self.caster_positions)
        n = positions.shape[0]
        object.__setattr__(self, "caster_positions", readonly(positions))
        offset = per_caster("offset", self.offset, n, "[m]")
        object.__setattr__(self, "offset", offset)
        radius = per_caster("wheel_radius", self.wheel_radius, n, "[m]")
        object.__setattr__(self, "wheel_radius", radius)
        speed = per_caster("max_wheel_speed", self.max_speed, n, "[rad/s]")
        object.__setattr__(self, "max_speed", speed)
        object.__setattr__(self, "max_steer_rate",
                           per_caster("max_steer_rate", self.max_steer_rate, n, "[rad/s]"))
        accel = None
        if self.max_accel is not None:
            accel = per_caster("max_wheel_accel", self.max_accel, n, "[rad/s^2]")
        object.__setattr__(self, "max_accel", accel)
        check_distinct_contacts(positions, offset)
        object.__setattr__(self, "wheel_blocks",
                           readonly(self.axis_maps() / radius[:, None, None]))
        object.__setattr__(self, "nominal_max_wheel_speed", speed)
        object.__setattr__(self, "nominal_max_wheel_accel", accel)
        self._finish()

    # ------------------------------------------------------------ description
    def axis_maps(self) -> FloatArray:
        """Axis velocity per twist, ``[[1, 0, -py], [0, 1, px]]``, shape (n, 2, 3)."""
        return point_velocity_maps(self.caster_positions)

    @property
    def wheel_positions(self) -> FloatArray:
        """Steer axes [m], shape (n, 2)."""
        return np.array(self.caster_positions, dtype=float)

    @property
    def offsets(self) -> FloatArray:
        return np.asarray(self.offset, dtype=float)

    @property
    def radii(self) -> FloatArray:
        return np.asarray(self.wheel_radius, dtype=float)

    @property
    def max_steer_rates(self) -> FloatArray:
        return np.asarray(self.max_steer_rate, dtype=float)

    # ------------------------------------------------------------ kinematics
    def joint_rows(self, steer_angles: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Drive rows ``D`` and steer rows ``S`` (each (..., n, 3)) at the angles (..., n):
        ``phidot = D xi``, ``betadot = S xi`` (module docstring). Unchecked."""
        return caster_limits.joint_rows(self, np.asarray(steer_angles, dtype=float))

    def joint_rates(self, twist: ArrayLike, steer_angles: ArrayLike) -> tuple[FloatArray,
                                                                             FloatArray]:
        """Drive rates and steer rates [rad/s], each (n,), for one twist at the steer angles.

        Args:
            twist: body twist (vx, vy, omega) [m/s, m/s, rad/s], shape (3,).
            steer_angles: the casters' present steer angles [rad], shape (n,).
        """
        xi = as_twists(twist)
        if xi.shape != (3,):
            raise RobotError(f"joint_rates takes one twist of shape (3,), got {xi.shape}")
        drive, steer = self.joint_rows(self.check_angles(steer_angles))
        return drive @ xi, steer @ xi

    def twist(self, drive_rates: ArrayLike, steer_rates: ArrayLike,
              steer_angles: ArrayLike) -> FloatArray:
        """Forward kinematics: the least-squares twist of joint rates at the steer angles.

        Args:
            drive_rates: [rad/s], shape (n,).
            steer_rates: [rad/s], shape (n,).
            steer_angles: [rad], shape (n,).
        """
        drive = self._vector("drive_rates", drive_rates, "[rad/s]")
        steer = self._vector("steer_rates", steer_rates, "[rad/s]")
        return self.joint_twist(drive, steer, self.check_angles(steer_angles))

    def joint_twist(self, drive_rates: FloatArray, steer_rates: FloatArray,
                    steer_angles: FloatArray) -> FloatArray:
        """:meth:`twist` without the checks (the plant's hot path)."""
        return joint_twist(np.asarray(self.caster_positions), self.offsets, self.radii,
                           drive_rates, steer_rates, steer_angles)

    def trailing_angles(self, twist: ArrayLike, current: ArrayLike | None = None) -> FloatArray:
        """Steer angles [rad] along each axis's velocity for ``twist`` (the casters trailing
        that motion); an axis at rest keeps ``current`` (default 0)."""
        xi = as_twists(twist)
        velocity = self.axis_maps() @ xi
        keep = np.zeros(self.n_wheels) if current is None else self.check_angles(current)
        moving = np.hypot(velocity[:, 0], velocity[:, 1]) > 1e-9
        return np.where(moving, np.arctan2(velocity[:, 1], velocity[:, 0]), keep)

    def check_angles(self, steer_angles: ArrayLike, name: str = "steer_angles") -> FloatArray:
        """The steer angles as a finite (n,) float array, or RobotError."""
        return self._vector(name, steer_angles, "[rad]")

    def _vector(self, name: str, value: ArrayLike, unit: str) -> FloatArray:
        return joint_vector(name, value, self.n_wheels, unit)

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Drive rates of casters trailing their axes' motion, ``|v(P)| / r`` [rad/s] >= 0,
        shape (n,) or (k, n)."""
        return np.linalg.norm(self.wheel_velocities(twist), axis=-1)

    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        velocity = self.flat_wheel_blocks @ twist
        return np.hypot(velocity[0::2], velocity[1::2])

    def forward_kinematics(self, wheel_speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        """The steady-state (trailing) view: each axis moving at ``r phidot`` along its steer
        angle, least squares over the axes (the inverse of :meth:`wheel_commands`). The
        joint-state map is :meth:`twist`."""
        angles = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        velocities = np.empty(2 * self.n_wheels)
        velocities[0::2] = wheel_speeds * np.cos(angles)
        velocities[1::2] = wheel_speeds * np.sin(angles)
        return self._flat_pinv @ velocities

    def commands_from_velocities(self, velocities: FloatArray,
                                 steer_angles: FloatArray | None) -> WheelCommands:
        """The steady-state (trailing) view: drive rates ``|v(P)| / r`` and steer angles
        along each axis's velocity (axis velocities / r, (n, 2)); an axis at rest keeps its
        angle. The joint rates at measured angles are :meth:`joint_rates`."""
        current = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        speeds = np.hypot(velocities[:, 0], velocities[:, 1])
        moving = speeds * self.radii > 1e-9
        angles = np.where(moving, np.arctan2(velocities[:, 1], velocities[:, 0]), current)
        return WheelCommands(np.where(moving, speeds, 0.0), angles)

    # ------------------------------------------------------------ limits for the solvers
    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        """Angle-free stand-in (the solvers use :meth:`stage_limits`): the axis speed disk
        ``|v(P)| <= r max_wheel_speed`` as an inscribed polygon."""
        return disk_speed_rows(self.wheel_blocks, polygon_sides)

    def casadi_limits(self, twist: ca.SX, bounds: FloatArray) -> tuple[ca.SX, FloatArray,
                                                                         FloatArray]:
        """Angle-free stand-in: the axis speed disk (squared)."""
        return disk_casadi_limits(self.flat_wheel_blocks, twist, bounds)

    def stage_limits(self, change_times: FloatArray,
                     polygon_sides: int | None) -> StageLimits:
        return caster_limits.stage_limits(self, change_times)

    def update_stage_limits(self, limits: StageLimits, guess: FloatArray, last: FloatArray,
                            steer_angles: FloatArray | None) -> None:
        caster_limits.update_stage_limits(self, limits, guess, steer_angles)

    def nlp_stage_limits(self, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                         change_times: FloatArray
                         ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
        return caster_limits.nlp_stage_limits(self, twists, last, steer_angles, change_times)

    def clamp_joints(self, target: FloatArray, last: FloatArray, dt: float,
                     steer_angles: FloatArray) -> FloatArray | None:
        return caster_limits.clamp_at(self, target, last, dt, steer_angles)

    def predict_steer_angles(self, steer_angles: FloatArray, twists: FloatArray,
                             durations: FloatArray) -> FloatArray:
        """The steer angles (k+1, n) [rad] the twists (k, 3), each held for its duration
        (k,) [s], turn the casters through from ``steer_angles`` (n,) (RK4 of ``betadot``)."""
        return caster_limits.predict(self, steer_angles, twists, durations)

    def description(self) -> dict[str, Any]:
        return {"type": "caster", "name": self.name, **listed(
            positions=self.caster_positions, offset=self.offset,
            wheel_radius=self.wheel_radius, max_wheel_speed=self.max_speed,
            max_steer_rate=self.max_steer_rate, max_wheel_accel=self.max_accel)}

    def mobility_wheels(self) -> list[dict[str, Any]]:
        return [{"type": "caster", "x": float(x), "y": float(y), "offset": float(d)}
                for (x, y), d in zip(self.wheel_positions, self.offsets, strict=True)]

    def _with_derating(self, derating: tuple[float, ...]) -> CasterRobot:
        return replace(self, derating=derating)


@checked_arguments(RobotError)
def caster(
    *,
    positions: ArrayLike,
    offset: ArrayLike,
    wheel_radius: ArrayLike,
    max_wheel_speed: ArrayLike,
    max_steer_rate: ArrayLike,
    max_wheel_accel: ArrayLike | None = None,
    name: str = "caster",
    allow_unusual: bool = False,
) -> CasterRobot:
    """A powered-caster vehicle (see the module docstring for the conventions).

    Args:
        positions: (n, 2) steer axes in the body frame [m], n >= 2; contacts must never
            meet (axes farther apart than the sum of their offsets).
        offset: trail of the contact behind the axis [m] > 0, a number or one per caster.
        wheel_radius: [m], a number or one per caster.
        max_wheel_speed: drive-rate limit [rad/s], a number or one per caster.
        max_steer_rate: steer-rate limit [rad/s], a number or one per caster.
        max_wheel_accel: drive acceleration limit [rad/s^2] (a number or one per caster)
            or None for unlimited.
        name: a label.
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError naming the likely
            unit mistake.
    """
    robot = CasterRobot(positions, name=name, offset=offset, wheel_radius=wheel_radius,
                        max_speed=max_wheel_speed, max_steer_rate=max_steer_rate,
                        max_accel=max_wheel_accel)
    check_plausible({"positions": (SIZE, robot.caster_positions),
                     "wheel_radius": (WHEEL_RADIUS, robot.radii),
                     "offset": (OFFSET, robot.offsets),
                     "max_wheel_speed": (WHEEL_SPEED, robot.max_speed),
                     "max_wheel_accel": (WHEEL_ACCEL, robot.max_accel),
                     "max_steer_rate": (STEER_RATE, robot.max_steer_rates)}, allow_unusual)
    return robot


def _from_wheel_set(specs: Sequence[WheelSpec], *, wheel_radius: float, max_wheel_speed: float,
                    max_steer_rate: float | None, max_wheel_accel: float | None,
                    name: str) -> CasterRobot:
    """Casters of a wheel set (:mod:`mpc.robots.description.wheel_set`)."""
    return caster(positions=[[spec.x, spec.y] for spec in specs],
                  offset=[spec.offset or 0.0 for spec in specs], wheel_radius=wheel_radius,
                  max_wheel_speed=max_wheel_speed,
                  max_steer_rate=steer_rate("caster", max_steer_rate),
                  max_wheel_accel=max_wheel_accel, name=name, allow_unusual=True)


register("caster", caster)
register_wheel_set(("caster",), _from_wheel_set)
