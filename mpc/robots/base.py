"""The robot interface: what the controller, both solvers and the plant ask of a layout.

Every layout is described the same way. Wheel ``i`` has a small matrix
``W_i`` (shape ``(d, 3)``) mapping the body twist ``xi = (vx, vy, omega)``
[m/s, m/s, rad/s] to its wheel velocity ``W_i @ xi`` [rad/s]. The limits are

    ||W_i @ xi|| <= max_wheel_speed[i]                       (speed)
    ||W_i @ (xi_k - xi_{k-1})|| <= max_wheel_accel[i] * dt   (acceleration)

A layout owns everything that depends on its wheel type, as methods:

- :meth:`Robot.wheel_magnitudes`: each wheel's speed for a twist (the clamp's measure);
- :meth:`Robot.qp_speed_rows`: the limits as two-sided linear rows for the QP;
- :meth:`Robot.casadi_limits`: the limits as CasADi expressions for the NLP;
- :meth:`Robot.wheel_commands` / :meth:`Robot.commands_from_velocities`: what to
  send the wheels (signed speeds, and steer angles for steered wheels);
- :meth:`Robot.forward_kinematics`: the twist the wheels' actual motion gives (the plant);
- :meth:`Robot.module_velocity_gram`: the cost weight that keeps steering smooth.

A new wheel type is a subclass implementing the abstract methods plus a
factory registered with :func:`mpc.robots.register`.

:class:`Robot` also has the speed-limit checks of :mod:`mpc.robots.speed_checks`
(``speed_ratio``, ``is_feasible``, ``desaturate``) and the steer-state joint defaults of
:mod:`mpc.robots.steer_states`; derating is checked in :mod:`mpc.robots.derating`.
"""

from __future__ import annotations

import abc
import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple, TypeVar

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, readonly
from mpc.errors import RobotError
from mpc.robots.checks import as_twists, check_holonomic
from mpc.robots.derating import check_derating, merged_derating, rest_projector
from mpc.robots.drive.dynamics import RobotDynamics
from mpc.robots.drive.force_map import force_map
from mpc.robots.limits import (
    DEFAULT_POLYGON_SIDES,
    SpeedRows,
    StageLimits,
    linear_stage_limits,
)
from mpc.robots.speed_checks import SpeedLimitChecks
from mpc.robots.steer_states import SteerStateJoints
from mpc.validation import MAX_WHEELS, MIN_RATE, shown

__all__ = ["Robot", "SpeedRows", "WheelCommands", "as_twists", "check_holonomic",
           "point_velocity_maps"]

RobotT = TypeVar("RobotT", bound="Robot")


class ScalarWheels(NamedTuple):
    """A robot's wheel rows and limits as Python floats, for a robot whose every wheel has
    a scalar speed ``W_i u`` (``wheel_dim`` 1: Swedish wheels, ball spin axes) and nothing
    else for the clamp to check (no failed wheel, no motor model): the clamp's pure-Python
    path (:func:`mpc.control.clamp.clamp_command`; with 3-8 wheels NumPy's cost a call is
    most of its work: docs/design/tick-costs.md)."""

    rows: tuple[tuple[float, float, float], ...]  # W_i [rad/s per twist unit]
    limits: tuple[float, ...]  # max_wheel_speed [rad/s]
    slack: tuple[float, ...]  # speed_slack [rad/s]
    accel: tuple[float, ...] | None  # max_wheel_accel [rad/s^2]


class PlanarModules(NamedTuple):
    """The same for steered modules whose speed is their velocity's length ``|W_i u|``
    (``W_i`` two rows; swerve without an axle offset, no failed module, no motor model):
    the clamp's speed and acceleration steps and its check that no module turns past its
    steering rate, in Python floats (quicker: docs/design/tick-costs.md)."""

    rows: tuple[tuple[float, float, float, float, float, float], ...]  # W_i's two rows
    limits: tuple[float, ...]  # max_wheel_speed [rad/s]
    slack: tuple[float, ...]  # speed_slack [rad/s]
    accel: tuple[float, ...] | None  # max_wheel_accel [rad/s^2]
    snap: float  # command_snap [rad/s]
    steer_rate: float  # max_steer_rate [rad/s]
    radius: float  # wheel_radius [m]
    moving: float  # the module speed [m/s] above which its turn is checked


class WheelCommands(NamedTuple):
    """What is sent to the wheels: signed speeds [rad/s] and steer angles [rad] or None."""

    speeds: FloatArray
    steer_angles: FloatArray | None



def point_velocity_maps(positions: ArrayLike) -> FloatArray:
    """Velocity of body-fixed points per body twist, ``[[1, 0, -y], [0, 1, x]]``, shape
    (n, 2, 3), from their positions (x, y) [m], shape (n, 2)."""
    points = np.asarray(positions, dtype=float)
    maps = np.zeros((points.shape[0], 2, 3))
    maps[:, 0, 0] = 1.0
    maps[:, 1, 1] = 1.0
    maps[:, 0, 2] = -points[:, 1]
    maps[:, 1, 2] = points[:, 0]
    return maps

@dataclass(frozen=True, eq=False)
class Robot(SpeedLimitChecks, SteerStateJoints, abc.ABC):
    """Common interface of every drive layout (see the module docstring).

    Subclasses set ``wheel_blocks``, ``nominal_max_wheel_speed`` and
    ``nominal_max_wheel_accel`` in ``__post_init__`` and then call
    :meth:`_finish`. ``derating`` scales each wheel's speed limit, 1.0 for a
    healthy wheel and 0.0 for a failed one held at rest; see :meth:`derated`.
    """

    #: Registry name of the wheel type (``"swedish"``, ``"swerve"``, ...).
    kind: ClassVar[str] = ""
    #: Whether the wheels are steered (commands carry steer angles).
    steered: ClassVar[bool] = False
    #: Whether the steer angles are states the motion sets (casters): the controller then
    #: takes the measured angles each tick and commands steer rates.
    steer_states: ClassVar[bool] = False

    name: str = field(default="robot", kw_only=True)
    derating: tuple[float, ...] | None = field(default=None, kw_only=True)
    #: Mass, motors, battery and traction (:mod:`mpc.robots.drive.dynamics`): the solvers add
    #: motor-aware limits (:mod:`mpc.robots.drive.motor_limits`); None keeps the kinematic ones.
    dynamics: RobotDynamics | None = field(default=None, kw_only=True)

    # Set by subclasses.
    wheel_blocks: FloatArray = field(init=False, repr=False)  # (n, d, 3) [rad/s per twist unit]
    nominal_max_wheel_speed: FloatArray = field(init=False, repr=False)  # (n,) [rad/s]
    nominal_max_wheel_accel: FloatArray | None = field(init=False, repr=False)  # (n,) [rad/s^2]
    #: Projects a twist onto those that keep every failed wheel (limit 0) at
    #: rest, ``I - pinv(W_f) W_f``; None when no wheel has failed.
    rest_projector: FloatArray | None = field(init=False, repr=False, default=None)
    _flat_pinv: FloatArray = field(init=False, repr=False)  # (3, n * d) least squares
    #: The wheels as Python floats for the clamp (:class:`ScalarWheels`), or None.
    scalar_wheels: ScalarWheels | None = field(init=False, repr=False, default=None)
    #: Steered modules as Python floats for the clamp (:class:`PlanarModules`), or None.
    planar_modules: PlanarModules | None = field(init=False, repr=False, default=None)
    #: How far over its speed limit a wheel may read and count as within it (rounding) [rad/s]
    #: (n,): :data:`SPEED_SLACK` of the limit, of the nominal one for a failed wheel.
    speed_slack: FloatArray = field(init=False, repr=False)

    def _finish(self) -> None:
        """Checks shared by every layout; subclasses call it last in ``__post_init__``."""
        if not isinstance(self.name, str):
            raise RobotError(f"name must be a string, got {self.name!r}")
        if self.n_wheels > MAX_WHEELS:
            raise RobotError(f"a robot has at most {MAX_WHEELS} wheels (a bound of this "
                             f"library), got {self.n_wheels}")
        self._check_rates()
        flat = self.wheel_blocks.reshape(-1, 3)
        check_holonomic(flat, f"robot {self.name!r}")
        object.__setattr__(self, "_flat_pinv", readonly(np.linalg.pinv(flat)))
        if self.derating is not None:
            derating = check_derating(self.derating, self.n_wheels)
            object.__setattr__(self, "derating", derating)
            projector = rest_projector(self.wheel_blocks, derating)
            if projector is not None:
                object.__setattr__(self, "rest_projector", projector)
        object.__setattr__(self, "speed_slack", _speed_slack(self.max_wheel_speed,
                                                             self.nominal_max_wheel_speed))
        self._check_dynamics()
        if self.wheel_dim == 1 and self.rest_projector is None and self.dynamics is None:
            accel = self.max_wheel_accel
            object.__setattr__(self, "scalar_wheels", ScalarWheels(
                tuple((a, b, c) for a, b, c in flat.tolist()),
                tuple(self.max_wheel_speed.tolist()), tuple(self.speed_slack.tolist()),
                None if accel is None else tuple(np.asarray(accel, dtype=float).tolist())))

    def _check_rates(self) -> None:
        """Every nominal speed, acceleration and steering-rate limit at least
        :data:`~mpc.validation.MIN_RATE`; the clamp's rounding slack from them
        (:attr:`speed_slack`)."""
        for name, unit, values in (
                ("max_wheel_speed", "rad/s", self.nominal_max_wheel_speed),
                ("max_wheel_accel", "rad/s^2", self.nominal_max_wheel_accel),
                ("max_steer_rate", "rad/s", self.max_steer_rates)):
            if values is not None and not bool((np.asarray(values) >= MIN_RATE).all()):
                raise RobotError(f"{name} must be at least {MIN_RATE:g} [{unit}] on every wheel "
                                 f"(a bound of this library), got {shown(values)}")

    def _check_dynamics(self) -> None:
        """With dynamics: the force map can be built (a supported wheel type whose wheels
        carry the weight)."""
        if self.dynamics is not None:
            force_map(self)

    # ------------------------------------------------------------ what the wheel type says
    # Code outside a wheel type asks these instead of branching on its class (the
    # mobility analysis, the force map, the benchmarks); a type that cannot answer one
    # raises RobotError naming itself.
    def description(self) -> dict[str, Any]:
        """Plain data :func:`mpc.robots.from_dict` rebuilds this robot from, exactly (its
        wheels and limits as built; dynamics and derating are not described)."""
        raise RobotError(f"wheel type {self.kind!r} cannot describe its robots as plain data")

    def mobility_wheels(self) -> list[dict[str, Any]]:
        """The wheels as tables of the mobility analysis
        (:mod:`mpc.robots.description.mobility`)."""
        raise RobotError(f"wheel type {self.kind!r} has no wheel-set description")

    def drive_radii(self) -> FloatArray:
        """The radius each wheel speed's effort acts at on the floor [m] (n,), for motor
        dynamics (:mod:`mpc.robots.drive.force_map`)."""
        raise RobotError(f"motor dynamics do not support wheel type {self.kind!r}")

    def with_wheel_limits(self, max_speed: float, max_accel: FloatArray) -> Robot:
        """The same wheels with every speed limit ``max_speed`` [rad/s] and per-wheel
        acceleration limits ``max_accel`` [rad/s^2] (n,) (a type with one limit for every
        wheel takes the smallest), without dynamics."""
        raise RobotError(f"wheel type {self.kind!r} cannot take new wheel limits")

    # ------------------------------------------------------------ description
    @property
    def n_wheels(self) -> int:
        return int(self.wheel_blocks.shape[0])

    @property
    def wheel_names(self) -> tuple[str, ...]:
        """Names of the wheels (modules) in their order, for figures and logs: four wheels,
        one in each quadrant of the body frame, are named by it (``FL``, ``FR``, ``RL``,
        ``RR``; x forward, y left: Mecanum, swerve modules, omni4 counter-clockwise); other
        layouts ``module 1..n`` (steered wheels) or ``wheel 1..n``."""
        return quadrant_names(self.wheel_positions) or tuple(
            f"{'module' if self.steered else 'wheel'} {i}" for i in range(1, self.n_wheels + 1))

    @property
    def flat_wheel_blocks(self) -> FloatArray:
        """``wheel_blocks`` stacked into (n * d, 3): wheel i's rows are i*d .. i*d + d - 1."""
        return self.wheel_blocks.reshape(-1, 3)

    @property
    def wheel_dim(self) -> int:
        """Rows of each wheel's velocity map ``W_i`` (1: a signed speed; 2: a velocity)."""
        return int(self.wheel_blocks.shape[1])

    @property
    @abc.abstractmethod
    def wheel_positions(self) -> FloatArray:
        """Wheel (or module) centres in the body frame [m], shape (n, 2)."""

    @property
    def max_wheel_speed(self) -> FloatArray:
        """Per-wheel speed limit [rad/s], after derating."""
        if self.derating is None:
            return self.nominal_max_wheel_speed
        return self.nominal_max_wheel_speed * np.asarray(self.derating)

    @property
    def max_wheel_accel(self) -> FloatArray | None:
        """Per-wheel acceleration limit [rad/s^2], or None if unlimited.

        Derating limits speed only: a failed wheel is held at rest by its
        speed limit, and an acceleration limit of 0 would make the step from
        its last (moving) command to rest infeasible.
        """
        return self.nominal_max_wheel_accel

    @property
    def max_steer_rates(self) -> FloatArray | None:
        """Per-wheel steering rate limit [rad/s] of steered wheels, else None."""
        return None

    @property
    def command_snap(self) -> float:
        """How far a sent wheel velocity may sit from ``W_i u`` [rad/s] (0: exactly there).
        The clamp keeps this much of each acceleration limit in hand at both ends of a
        change, so the commands as sent stay within it."""
        return 0.0

    # ------------------------------------------------------------ kinematics
    def wheel_velocities(self, twist: ArrayLike) -> FloatArray:
        """Wheel velocity vectors ``W_i @ twist`` [rad/s], shape (..., n, d)."""
        xi = as_twists(twist)
        return np.einsum("ndj,...j->...nd", self.wheel_blocks, xi)

    @abc.abstractmethod
    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Inverse kinematics: wheel speeds [rad/s] for body twist(s), shape (..., n)."""

    @abc.abstractmethod
    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        """``||W_i @ twist||`` [rad/s] for one (3,) twist, shape (n,); unchecked (hot path)."""

    def twist_from_velocities(self, velocities: FloatArray) -> FloatArray:
        """Least-squares body twist of wheel velocities (n, d) [rad/s]."""
        return self._flat_pinv @ velocities.reshape(-1)

    @abc.abstractmethod
    def forward_kinematics(self, wheel_speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        """The body twist the wheels' actual motion gives (least squares; slip otherwise).

        Args:
            wheel_speeds: signed wheel speeds [rad/s], shape (n,).
            steer_angles: steer angles [rad], shape (n,), for steered wheels; else None.
        """

    def steering_forward_kinematics(self, wheel_speeds: FloatArray, steer_angles: FloatArray,
                                    steer_rates: FloatArray | None) -> FloatArray:
        """:meth:`forward_kinematics` while steered wheels turn at ``steer_rates`` [rad/s]
        (modules whose wheel moves as they steer, e.g. an axle offset, override it)."""
        return self.forward_kinematics(wheel_speeds, steer_angles)

    # ------------------------------------------------------------ commands
    def wheel_commands(self, twist: FloatArray, steer_angles: FloatArray | None,
                       aim: FloatArray | None = None, dt: float | None = None) -> WheelCommands:
        """What to send for one (3,) twist, given the present steer angles (steered wheels).

        ``aim`` (a twist) and ``dt`` [s]: steered wheels the twist leaves at rest turn
        towards their direction in ``aim``, as far as their steering rate allows in ``dt``
        (they get ready for a motion the clamp held back)."""
        velocities = self.wheel_blocks @ twist  # (n, d)
        return self.commands_from_velocities(velocities, steer_angles)

    def planned_wheel_commands(self, twist: FloatArray, steer_angles: FloatArray | None,
                               aim: FloatArray | None, dt: float | None,
                               plan: FloatArray | None, durations: FloatArray | None,
                               memory: dict[str, FloatArray] | None = None) -> WheelCommands:
        """:meth:`wheel_commands` given also the plan's twists ``plan`` (N, 3) (None: no
        plan) of stage lengths ``durations`` (N,) [s], and ``memory``, a dict the caller
        keeps from tick to tick (empty after a reset) for the robot's own use;
        steered wheels with a steering range choose their branch along it. Default:
        :meth:`wheel_commands`."""
        return self.wheel_commands(twist, steer_angles, aim, dt)

    def steer_angle_range(self) -> tuple[float, float] | None:
        """Steered wheels' range of absolute steer angles (lo, hi) [rad], or None: angles
        modulo a turn (default)."""
        return None

    def steering_fraction(self, last: FloatArray, target: FloatArray,
                          steer_angles: FloatArray | None, dt: float) -> float:
        """The largest fraction of the step from ``last`` towards ``target`` (twists) that
        turns no steered wheel faster than its steering rate from ``steer_angles``.
        Default (no steered wheels): 1."""
        return 1.0

    def ramp_turn_fraction(self, last: FloatArray, target: FloatArray, dt: float) -> float:
        """The largest fraction of the step from ``last`` towards ``target`` (twists) along
        whose ramp over ``dt`` (the wheel velocities moving in a straight line, as a motor
        robot plans a stage) no steered wheel's direction turns faster than its steering
        rate. Default (no steered wheels): 1."""
        return 1.0

    @abc.abstractmethod
    def commands_from_velocities(self, velocities: FloatArray,
                                 steer_angles: FloatArray | None) -> WheelCommands:
        """What to send for wheel velocities (n, d) [rad/s] that need not come from one twist
        (e.g. after per-wheel clipping), given the present steer angles."""

    def command_velocities(self, speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        """The wheel velocity vectors (n, d) [rad/s] that sent speeds (and steer angles)
        ask for: what the limits bound. Default: the signed speeds as (n, 1)."""
        return np.asarray(speeds, dtype=float)[:, None]

    def initial_steer_angles(self) -> FloatArray | None:
        """Steer angles of a robot at rest [rad] (steered wheels point forward), else None."""
        return np.zeros(self.n_wheels) if self.steered else None

    # ------------------------------------------------------------ limits for the solvers
    @abc.abstractmethod
    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        """The wheel limits as two-sided linear rows in the twist (see :class:`SpeedRows`)."""

    @abc.abstractmethod
    def casadi_limits(self, twist: ca.SX, bounds: FloatArray) -> tuple[ca.SX, FloatArray,
                                                                         FloatArray]:
        """``(g, lower, upper)`` with ``lower <= g <= upper`` iff ``||W_i twist|| <= bounds[i]``
        for every wheel, exactly (the NLP's constraint)."""

    def stage_limits(self, change_times: FloatArray,
                     polygon_sides: int | None) -> StageLimits:
        """The QP's limit rows for a plan whose twist ``u_k`` follows ``u_{k-1}`` by
        ``change_times[k]`` [s] (N,) (see :mod:`mpc.robots.limits`); ``polygon_sides``
        for a disk taken as a polygon (None: the robot's default,
        :data:`~mpc.robots.limits.DEFAULT_POLYGON_SIDES` sides where it has one). Default:
        the constant rows of :meth:`qp_speed_rows` on every twist and every change."""
        sides = DEFAULT_POLYGON_SIDES if polygon_sides is None else polygon_sides
        return linear_stage_limits(self.qp_speed_rows(sides), self.max_wheel_speed,
                                   self.max_wheel_accel, change_times)

    def update_stage_limits(self, limits: StageLimits, guess: FloatArray, last: FloatArray,
                            steer_angles: FloatArray | None) -> None:
        """Refill rows that depend on the plan the solver starts from (``guess`` twists
        (N, 3), ``last`` command, present steer angles). Default: nothing to refill."""
        return None

    def nlp_stage_limits(self, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                         change_times: FloatArray
                         ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
        """The NLP's exact limits on every stage's twist (``twists`` 3 x N, ``last`` 3,
        ``steer_angles`` the present ones for steered wheels, ``u_k`` following ``u_{k-1}``
        by ``change_times[k]`` [s]): lists of ``(g, lower, upper)``. Default:
        :meth:`casadi_limits` on every twist and every change."""
        accel = self.max_wheel_accel
        values: list[ca.SX] = []
        lower: list[FloatArray] = []
        upper: list[FloatArray] = []
        for k in range(twists.shape[1]):
            change = twists[:, k] - (last if k == 0 else twists[:, k - 1])
            pairs = [(twists[:, k], self.max_wheel_speed)]
            if accel is not None:
                pairs.append((change, accel * float(change_times[k])))
            for twist, bound in pairs:
                value, low, high = self.casadi_limits(twist, bound)
                values.append(value)
                lower.append(low)
                upper.append(high)
        return values, lower, upper

    def module_velocity_gram(self) -> FloatArray:
        """``sum_i G_i^T G_i`` over steered modules' ground-velocity maps ``G_i`` [m^2/s^2 per
        twist unit^2], shape (3, 3): weights the change of module velocity between ticks.
        Zero for wheels that are not steered."""
        return np.zeros((3, 3))

    # ------------------------------------------------------------ derating
    def derated(self, factors: dict[int, float] | ArrayLike) -> Robot:
        """A copy with per-wheel speed limits scaled by ``factors`` in [0, 1].

        ``{2: 0.0}`` models wheel 2 failed and held at rest; ``{0: 0.5}`` a
        wheel that reaches only half its speed. Acceleration limits are kept.
        """
        return self._with_derating(merged_derating(self.derating, factors, self.n_wheels))

    @abc.abstractmethod
    def _with_derating(self, derating: tuple[float, ...]) -> Robot: ...

    # ------------------------------------------------------------ dynamics
    def with_dynamics(self: RobotT, dynamics: RobotDynamics | None) -> RobotT:
        """A copy with ``dynamics`` (a :class:`~mpc.robots.drive.dynamics.RobotDynamics`): the
        solvers, the clamp and ``Command`` then respect and report the motors; None drops
        them (kinematic limits only)."""
        if dynamics is not None and not isinstance(dynamics, RobotDynamics):
            raise RobotError(f"dynamics must be a RobotDynamics or None, got {shown(dynamics)}")
        return dataclasses.replace(self, dynamics=dynamics)


def quadrant_names(positions: ArrayLike) -> tuple[str, ...] | None:
    """``FL``, ``FR``, ``RL``, ``RR`` for four positions (n, 2) [m] one to a quadrant of the
    body frame (x forward, y left), in their order; None for any other set."""
    points = np.asarray(positions, dtype=float).reshape(-1, 2)
    if points.shape != (4, 2) or not bool((np.abs(points) > 1e-9).all()):
        return None
    names = tuple(("F" if x > 0 else "R") + ("L" if y > 0 else "R") for x, y in points.tolist())
    return names if len(set(names)) == 4 else None


#: Relative rounding slack of a wheel's speed against its limit (the clamp's).
SPEED_SLACK = 1e-12


def _speed_slack(limit: FloatArray, nominal: FloatArray) -> FloatArray:
    """:data:`SPEED_SLACK` of each limit, of the nominal limit where the wheel has failed
    (limit 0: a twist projected to keep it at rest reads rounding, not 0)."""
    return readonly(SPEED_SLACK * np.where(limit > 0.0, limit, nominal))
