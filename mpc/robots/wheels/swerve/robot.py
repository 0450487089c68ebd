"""Swerve drive: independently steered and driven modules.

Module ``i`` at body position ``p_i = (x_i, y_i)`` [m] moves at
``v_i = (vx - omega y_i, vy + omega x_i)`` [m/s]; its wheel turns at
``|v_i| / r`` [rad/s] along the steer angle ``atan2(v_iy, v_ix)`` [rad]
(0 = forward, counter-clockwise positive).

- Speed limit: the disk ``|v_i| <= r * max_wheel_speed``, exact in the
  nonlinear problem, a regular polygon midway between the inscribed and the
  circumscribed one in the QP
  (``cos(2 pi m / M) v_ix + sin(2 pi m / M) v_iy <= r * max * (1 + cos(pi / M)) / 2``).
- Acceleration limit: ``max_wheel_accel`` bounds the change of the module's
  *velocity vector* per second, ``|v_i,k - v_i,k-1| <= r * max_wheel_accel * dt``
  (a disk too), not only the change of its speed: turning a moving module
  costs acceleration as well.
- Flip rule: a module more than 90 degrees from its present angle steers to
  ``angle + pi`` and drives backwards instead (exactly 90 degrees does not
  flip); a module at (near) zero speed keeps its angle.

Axle-offset modules (``axle_offset > 0``, Neobotix MPO-700): :mod:`mpc.robots.wheels.swerve.axle`.
Steering ranges (``steer_range``: absolute angles, flips planned over the horizon):
:mod:`mpc.robots.wheels.swerve.ranges`.
Module states (flip rule, modules at rest, aiming): :mod:`mpc.robots.wheels.swerve.states`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.angles import wrap_angle
from mpc.arrays import FloatArray, readonly
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
    PlanarModules,
    Robot,
    SpeedRows,
    WheelCommands,
    as_twists,
    point_velocity_maps,
)
from mpc.robots.description.mobility import WheelSpec
from mpc.robots.description.registry import (
    register,
    register_sampler,
    register_wheel_set,
    steer_rate,
)
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.swerve.axle import axle_forward_kinematics, axle_speed_ratio
from mpc.robots.wheels.swerve.limits import (
    MOVING_MODULE_SPEED,
    STOPPED_MODULE_SPEED,
    linearised_stage_limits,
    nlp_stage_limits,
    qp_speed_rows,
    steering_fraction,
    update_linearised,
)
from mpc.robots.wheels.swerve.ramp_turn import ramp_turn_fraction
from mpc.robots.wheels.swerve.ranges import (
    check_steer_plan,
    check_steer_range,
    nearest_branch,
    ranged_commands,
    settled_angles,
)
from mpc.robots.wheels.swerve.states import aimed_angles, module_states
from mpc.robots.wheels.swerve.steer_rows import update_steering_rows, with_steering_rows
from mpc.validation import body_points, checked_arguments, metres, positive, shown

__all__ = ["SwerveRobot", "swerve", "wrap_angle"]


@dataclass(frozen=True, eq=False)
class SwerveRobot(Robot):
    """A swerve base; wheel speeds are module speeds ``|v_i| / r`` [rad/s] >= 0.

    Attributes:
        module_positions: (n, 2) module centres in the body frame [m], n >= 2.
        wheel_radius: [m].
        max_speed: per-module wheel speed limit [rad/s].
        max_steer_rate: steering motor rate limit [rad/s].
        max_accel: per-module wheel acceleration limit [rad/s^2] (of the velocity
            vector, see the module docstring) or None.
        steer_range: (lo, hi) absolute steer angles [rad] every module stays within
            (``hi - lo >= pi``), or None: angles modulo a turn, today's flip rule
            (:mod:`mpc.robots.wheels.swerve.ranges`).
        steer_plan: with a range, how flips are chosen: ``"horizon"`` (over the plan,
            the default) or ``"tick"`` (the per-tick rule kept inside the range).
    """

    kind = "swerve"
    steered = True

    module_positions: ArrayLike = field(default_factory=lambda: np.zeros((0, 2)))
    wheel_radius: float = field(default=0.05, kw_only=True)
    max_speed: float = field(default=1.0, kw_only=True)
    max_steer_rate: float = field(default=10.0, kw_only=True)
    max_accel: float | None = field(default=None, kw_only=True)
    axle_offset: float = field(default=0.0, kw_only=True)
    steer_range: tuple[float, float] | None = field(default=None, kw_only=True)
    steer_plan: str = field(default="horizon", kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "steer_range", check_steer_range(self.steer_range))
        object.__setattr__(self, "steer_plan", check_steer_plan(self.steer_plan))
        positions = body_points("module_positions", self.module_positions, "modules", RobotError)
        object.__setattr__(self, "module_positions", readonly(positions))
        radius = metres("wheel_radius", self.wheel_radius, RobotError)
        object.__setattr__(self, "wheel_radius", radius)
        object.__setattr__(self, "max_speed",
                           positive("max_wheel_speed", self.max_speed, RobotError))
        object.__setattr__(self, "max_steer_rate",
                           positive("max_steer_rate", self.max_steer_rate, RobotError))
        if self.max_accel is not None:
            object.__setattr__(self, "max_accel",
                               positive("max_wheel_accel", self.max_accel, RobotError))
        lever = metres("axle_offset", self.axle_offset, RobotError, zero=True)
        object.__setattr__(self, "axle_offset", lever)
        n = positions.shape[0]
        object.__setattr__(self, "wheel_blocks", readonly(self.ground_maps() / radius))
        object.__setattr__(self, "nominal_max_wheel_speed", readonly(np.full(n, self.max_speed)))
        object.__setattr__(
            self, "nominal_max_wheel_accel",
            None if self.max_accel is None else readonly(np.full(n, self.max_accel)))
        self._finish()
        if (not lever and self.rest_projector is None and self.dynamics is None
                and self.steer_range is None):  # a range's clamp settles turning modules
            accel = self.max_wheel_accel
            object.__setattr__(self, "planar_modules", PlanarModules(
                tuple((a, b, c, d, e, f)
                      for a, b, c, d, e, f in self.wheel_blocks.reshape(n, 6).tolist()),
                tuple(self.max_wheel_speed.tolist()), tuple(self.speed_slack.tolist()),
                None if accel is None else tuple(accel.tolist()), self.command_snap,
                self.max_steer_rate, radius, MOVING_MODULE_SPEED))

    def ground_maps(self) -> FloatArray:
        """Module ground velocity per twist, ``[[1, 0, -y_i], [0, 1, x_i]]``, shape (n, 2, 3)."""
        return point_velocity_maps(self.module_positions)

    @property
    def wheel_positions(self) -> FloatArray:
        return np.array(self.module_positions, dtype=float)

    @property
    def max_steer_rates(self) -> FloatArray:
        return np.full(self.n_wheels, self.max_steer_rate)

    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Module wheel speeds ``|v_i| / r`` [rad/s], non-negative, shape (n,) or (k, n); with
        an axle offset, ``(|v_i| + L |omega|) / r`` (the larger of the two flips)."""
        speeds = np.linalg.norm(self.wheel_velocities(twist), axis=-1)
        if self.axle_offset:
            spin = np.abs(as_twists(twist)[..., 2:3])
            speeds = speeds + self.axle_offset * spin / self.wheel_radius
        return speeds

    @property
    def command_snap(self) -> float:
        """A module slower than :data:`STOPPED_MODULE_SPEED` is sent at rest [rad/s]."""
        return STOPPED_MODULE_SPEED / self.wheel_radius

    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        velocity = self.flat_wheel_blocks @ twist
        speeds = np.hypot(velocity[0::2], velocity[1::2])
        if self.axle_offset:
            speeds = speeds + self.axle_offset * abs(float(twist[2])) / self.wheel_radius
        return speeds

    def speed_ratio(self, twist: ArrayLike) -> FloatArray | float:
        """Peak wheel speed / limit; with an axle offset the speed is
        ``(|v_i| + L |omega|) / r`` (see :meth:`wheel_speeds`)."""
        if not self.axle_offset:
            return super().speed_ratio(twist)
        return axle_speed_ratio(self, twist)

    def module_velocities(self, twist: ArrayLike) -> FloatArray:
        """Module ground velocities ``v_i`` [m/s], shape (..., n, 2)."""
        return self.wheel_velocities(twist) * self.wheel_radius

    def module_states(
        self, twist: ArrayLike, current_angles: ArrayLike | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Signed wheel speeds [rad/s] and steer angles [rad] for one twist.

        Args:
            twist: body twist (vx, vy, omega), shape (3,).
            current_angles: the modules' present steer angles [rad], shape (n,),
                or None (no flip; stopped modules point at 0).
        """
        xi = as_twists(twist)
        if xi.shape != (3,):
            raise RobotError(f"module_states takes one twist of shape (3,), got {xi.shape}")
        return self._states(self.wheel_blocks @ xi, self._current_angles(current_angles))

    def commands_from_velocities(self, velocities: FloatArray,
                                 steer_angles: FloatArray | None) -> WheelCommands:
        """Signed speeds [rad/s] and steer angles in (-pi, pi] [rad] for wheel velocities
        (n, 2) [rad/s] (module ground velocity / r), with the flip and keep-at-rest rules."""
        return WheelCommands(*self._states(velocities, steer_angles))

    def _states(self, velocities: FloatArray,
                steer_angles: FloatArray | None) -> tuple[FloatArray, FloatArray]:
        speeds, angles = module_states(velocities, steer_angles, self.wheel_radius)
        if self.steer_range is None:
            return speeds, angles
        # a range: the per-tick rule's branch nearest the present absolute angle, inside it
        lo, hi = self.steer_range
        present = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        for i, (speed, angle, here) in enumerate(zip(speeds.tolist(), angles.tolist(),
                                                     present.tolist(), strict=True)):
            if speed == 0.0:
                angles[i] = min(max(here, lo), hi)
            else:
                direction = angle if speed > 0.0 else angle + np.pi
                angles[i] = nearest_branch(here, direction, lo, hi)
                speeds[i] = abs(speed) * np.cos(angles[i] - direction)
        return speeds, angles

    def steer_angle_range(self) -> tuple[float, float] | None:
        return self.steer_range

    def states_from_velocities(
        self, velocities: FloatArray, current_angles: ArrayLike | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Signed speeds [rad/s] and steer angles [rad] for module ground velocities
        (n, 2) [m/s]; the rules of :meth:`module_states`."""
        speeds = np.asarray(velocities, dtype=float)
        if speeds.shape != (self.n_wheels, 2):
            raise RobotError(f"velocities must have shape ({self.n_wheels}, 2), got "
                             f"{speeds.shape}")
        return self._states(speeds / self.wheel_radius, self._current_angles(current_angles))

    def _current_angles(self, current_angles: ArrayLike | None) -> FloatArray | None:
        """The modules' present steer angles, checked: n finite angles [rad], or None."""
        if current_angles is None:
            return None
        current = np.asarray(current_angles, dtype=float)
        if current.shape != (self.n_wheels,) or not np.all(np.isfinite(current)):
            raise RobotError(f"current_angles must be {self.n_wheels} finite angles, "
                             f"got {shown(current_angles)}")
        return current

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
        stacked = np.stack([speeds * np.cos(angles), speeds * np.sin(angles)], axis=-1)
        return stacked.reshape(*speeds.shape[:-1], 2 * self.n_wheels) @ self._flat_pinv.T

    def command_velocities(self, speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        angles = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        return np.stack([speeds * np.cos(angles), speeds * np.sin(angles)], axis=1)

    def forward_kinematics(self, wheel_speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        angles = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        if self.axle_offset:
            return self.steering_forward_kinematics(wheel_speeds, angles, None)
        velocities = np.empty(2 * self.n_wheels)
        velocities[0::2] = wheel_speeds * np.cos(angles)
        velocities[1::2] = wheel_speeds * np.sin(angles)
        return self._flat_pinv @ velocities

    def steering_forward_kinematics(self, wheel_speeds: FloatArray, steer_angles: FloatArray,
                                    steer_rates: FloatArray | None) -> FloatArray:
        """Forward kinematics while the modules steer at ``steer_rates`` [rad/s] (None: 0).
        With an axle offset ``L``: least squares of ``e_i . v_i + L omega = r phidot_i -
        L betadot_i`` and ``n_i . v_i = 0`` over the modules; else :meth:`forward_kinematics`."""
        if not self.axle_offset:
            return self.forward_kinematics(wheel_speeds, steer_angles)
        return axle_forward_kinematics(self, wheel_speeds, steer_angles, steer_rates)

    def axle_correction(self, twist: FloatArray, steer_rates: FloatArray | None) -> FloatArray:
        """The drive-rate correction of an axle offset [rad/s] (n,):
        ``L (omega + betadot) / r`` (0 without an offset)."""
        rates = np.zeros(self.n_wheels) if steer_rates is None else steer_rates
        return self.axle_offset * (float(twist[2]) + rates) / self.wheel_radius

    def stage_limits(self, change_times: FloatArray,
                     polygon_sides: int | None) -> StageLimits:
        """Each module's speed disk linearised around the plan the solver starts from and
        its acceleration disk a constant 16-gon
        (:func:`~mpc.robots.wheels.swerve.limits.linearised_stage_limits`), or with
        ``polygon_sides`` the constant polygon of :meth:`qp_speed_rows`. Always the
        polygon with an axle offset, and with a motor model: there the linearised disks'
        bolder plans took a motor over its current limit on the motor plant
        (docs/design/swerve-motors-polygon.md). With a motor model, followed by each
        module's steering rate along each stage's ramp
        (:mod:`~mpc.robots.wheels.swerve.steer_rows`)."""
        if polygon_sides is None and not self.axle_offset and self.dynamics is None:
            return linearised_stage_limits(self, change_times)
        limits = super().stage_limits(change_times, polygon_sides)
        if self.dynamics is not None:  # its stages ramp: the steering rate along them
            return with_steering_rows(self, limits)
        return limits

    def update_stage_limits(self, limits: StageLimits, guess: FloatArray, last: FloatArray,
                            steer_angles: FloatArray | None) -> None:
        if "steer_first" in limits.memory:
            update_steering_rows(self, limits, guess, last)
        elif not limits.constant:
            update_linearised(self, limits, guess, last)

    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        """A regular polygon midway between the ones inscribed in and circumscribed about
        each module's disk (:func:`~mpc.robots.wheels.swerve.limits.qp_speed_rows`)."""
        return qp_speed_rows(self, polygon_sides)

    def casadi_limits(self, twist: ca.SX, bounds: FloatArray) -> tuple[ca.SX, FloatArray,
                                                                         FloatArray]:
        velocity = ca.DM(self.flat_wheel_blocks) @ twist
        squares = velocity[0::2] ** 2 + velocity[1::2] ** 2
        bounds = np.asarray(bounds, dtype=float)
        return squares, np.full(bounds.shape, -np.inf), bounds**2

    def steering_fraction(self, last: FloatArray, target: FloatArray,
                          steer_angles: FloatArray | None, dt: float) -> float:
        if steer_angles is None:
            return 1.0
        if self.steer_range is not None:
            steer_angles = settled_angles(self, last, steer_angles, dt)
        return steering_fraction(self, last, target, steer_angles, dt)

    def ramp_turn_fraction(self, last: FloatArray, target: FloatArray, dt: float) -> float:
        return ramp_turn_fraction(self, last, target, dt)

    def wheel_commands(self, twist: FloatArray, steer_angles: FloatArray | None,
                       aim: FloatArray | None = None, dt: float | None = None) -> WheelCommands:
        """Signed speeds and steer angles for ``twist`` with the flip rule; modules it leaves
        at rest turn towards their direction in ``aim`` by at most ``max_steer_rate dt``.
        With a :attr:`steer_range`: :func:`~mpc.robots.wheels.swerve.ranges.ranged_commands`
        (absolute angles; no plan to look along here, see :meth:`planned_wheel_commands`)."""
        if self.steer_range is not None:
            return self.planned_wheel_commands(twist, steer_angles, aim, dt, None, None)
        speeds, angles = self._states(self.wheel_blocks @ twist, steer_angles)
        if self.axle_offset:  # the wheel rolls with the body's rotation and its steering
            turning = None
            if steer_angles is not None and dt is not None:
                turning = wrap_angle(angles - steer_angles) / dt
            speeds = speeds + self.axle_correction(twist, turning)
        if aim is None or dt is None or steer_angles is None or self.axle_offset:
            return WheelCommands(speeds, angles)
        return WheelCommands(speeds, aimed_angles(self, speeds, angles, aim, steer_angles, dt))

    def planned_wheel_commands(self, twist: FloatArray, steer_angles: FloatArray | None,
                               aim: FloatArray | None, dt: float | None,
                               plan: FloatArray | None, durations: FloatArray | None,
                               memory: dict[str, FloatArray] | None = None) -> WheelCommands:
        """With a :attr:`steer_range`, each module's branch chosen along the plan's twists
        ``plan`` (N, 3) of stage lengths ``durations`` (N,) [s], its velocity changed by at
        most its acceleration limit from the last tick's, and a turn under way finished
        (``memory``: the caller's dict, kept from tick to tick)
        (:func:`~mpc.robots.wheels.swerve.ranges.ranged_commands`); without one,
        :meth:`wheel_commands`."""
        if self.steer_range is None:
            return self.wheel_commands(twist, steer_angles, aim, dt)
        speeds, angles, rates = ranged_commands(self, twist, steer_angles, self.steer_range,
                                                self.steer_plan, aim, dt, plan, durations,
                                                memory)
        if self.axle_offset:  # the wheel rolls with the body's rotation and its steering
            speeds = speeds + self.axle_correction(twist, rates)
        return WheelCommands(speeds, angles)

    def nlp_stage_limits(self, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                         change_times: FloatArray
                         ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
        return nlp_stage_limits(self, twists, last, steer_angles, change_times)

    def module_velocity_gram(self) -> FloatArray:
        ground = self.ground_maps()
        return np.einsum("ndi,ndj->ij", ground, ground)

    def description(self) -> dict[str, Any]:
        return {"type": "swerve", "name": self.name,
                "module_positions": np.asarray(self.module_positions).tolist(),
                "wheel_radius": self.wheel_radius, "max_wheel_speed": self.max_speed,
                "max_steer_rate": self.max_steer_rate, "max_wheel_accel": self.max_accel,
                **({"axle_offset": self.axle_offset} if self.axle_offset else {}),
                **({"steer_range": list(self.steer_range), "steer_plan": self.steer_plan}
                   if self.steer_range is not None else {})}

    def mobility_wheels(self) -> list[dict[str, Any]]:
        if self.axle_offset:
            return [{"type": "axle_offset", "x": float(x), "y": float(y),
                     "lever": float(self.axle_offset)} for x, y in self.wheel_positions]
        return [{"type": "steered", "x": float(x), "y": float(y)}
                for x, y in self.wheel_positions]

    def drive_radii(self) -> FloatArray:
        if self.axle_offset:
            raise RobotError("motor dynamics support swerve modules whose wheel is under the "
                             f"steering axis; robot {self.name!r} has axle_offset "
                             f"{shown(self.axle_offset)} m")
        return np.full(self.n_wheels, float(self.wheel_radius))

    def with_wheel_limits(self, max_speed: float, max_accel: FloatArray) -> SwerveRobot:
        return replace(self, max_speed=max_speed, max_accel=float(np.min(max_accel)),
                       dynamics=None)

    def _with_derating(self, derating: tuple[float, ...]) -> SwerveRobot:
        return replace(self, derating=derating)


@checked_arguments(RobotError)
def swerve(
    *,
    module_positions: ArrayLike,
    wheel_radius: float,
    max_wheel_speed: float,
    max_steer_rate: float,
    max_wheel_accel: float | None = None,
    axle_offset: float = 0.0,
    steer_range: ArrayLike | None = None,
    steer_plan: str = "horizon",
    name: str = "swerve",
    allow_unusual: bool = False,
) -> SwerveRobot:
    """A swerve base.

    Args:
        module_positions: (n, 2) module centres in the body frame [m], e.g. FL, FR, RL, RR.
        wheel_radius: [m].
        max_wheel_speed: per-module wheel speed limit [rad/s].
        max_steer_rate: steering rate limit [rad/s].
        max_wheel_accel: [rad/s^2] or None (bounds the module velocity vector's change).
        axle_offset: the wheel's offset along its axle from the steer axis [m] >= 0
            (MPO-700-style modules; see :mod:`mpc.robots.wheels.swerve.axle`), 0 for centred
            modules.
        steer_range: (lo, hi) absolute steer angles [rad] the modules stay within, finite,
            ``hi - lo >= pi`` (e.g. ``(-pi, pi)`` for cable-wrapped modules), or None (no
            range: angles modulo a turn). See :mod:`mpc.robots.wheels.swerve.ranges`.
        steer_plan: with a range, ``"horizon"`` (flips chosen over the plan) or ``"tick"``
            (the per-tick flip rule kept inside the range).
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError naming the likely
            unit mistake.
    """
    robot = SwerveRobot(module_positions, name=name, wheel_radius=wheel_radius,
                        max_speed=max_wheel_speed, max_steer_rate=max_steer_rate,
                        max_accel=max_wheel_accel, axle_offset=axle_offset,
                        steer_range=check_steer_range(steer_range), steer_plan=steer_plan)
    check_plausible({"module_positions": (SIZE, robot.module_positions),
                     "wheel_radius": (WHEEL_RADIUS, robot.wheel_radius),
                     "axle_offset": (OFFSET, robot.axle_offset),
                     "max_wheel_speed": (WHEEL_SPEED, robot.max_speed),
                     "max_wheel_accel": (WHEEL_ACCEL, robot.max_accel),
                     "max_steer_rate": (STEER_RATE, robot.max_steer_rate)}, allow_unusual)
    return robot


def _from_wheel_set(specs: Sequence[WheelSpec], *, wheel_radius: float, max_wheel_speed: float,
                    max_steer_rate: float | None, max_wheel_accel: float | None,
                    name: str) -> SwerveRobot:
    """Steered or axle-offset modules of a wheel set (:mod:`mpc.robots.description.wheel_set`), one
    lever for every module."""
    levers = {spec.lever or 0.0 for spec in specs}
    if len(levers) != 1:
        raise RobotError(f"wheels: every axle_offset module needs the same lever, got "
                         f"{sorted(levers)}")
    return swerve(module_positions=[[spec.x, spec.y] for spec in specs],
                  wheel_radius=wheel_radius, max_wheel_speed=max_wheel_speed,
                  max_steer_rate=steer_rate(specs[0].kind, max_steer_rate),
                  max_wheel_accel=max_wheel_accel, axle_offset=levers.pop(), name=name,
                  allow_unusual=True)


def _random_swerve(rng: np.random.Generator) -> dict[str, Any]:
    """Sweeps' swerve robot: modules at (+-a, +-b), a and b 0.15-0.40 m, wheel radius
    40-60 mm, speed limit 20-40 rad/s, steering rate 8-16 rad/s."""
    u = rng.uniform
    a, b = u(0.15, 0.40), u(0.15, 0.40)
    return {"type": "swerve", "module_positions": [[a, b], [a, -b], [-a, b], [-a, -b]],
            "wheel_radius": u(0.04, 0.06), "max_wheel_speed": u(20, 40),
            "max_steer_rate": u(8, 16)}


register("swerve", swerve)
register_wheel_set(("steered", "axle_offset"), _from_wheel_set)
register_sampler("swerve", _random_swerve)
