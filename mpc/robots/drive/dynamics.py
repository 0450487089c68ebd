"""A robot's rigid-body and motor description: what motor-aware limits and the motor plant need.

:class:`RobotDynamics` holds numbers only (SI units); attach it to any robot with
:meth:`~mpc.robots.Robot.with_dynamics` (or a ``[dynamics]`` table in a robot file) and
the solvers add the motor rows of :mod:`mpc.robots.drive.motor_limits`; without it a robot
keeps its kinematic limits alone. Every drive wheel (a Swedish wheel, a swerve module's
drive, each actuator of a driven ball) has the same gearbox: ``motor`` (a
:class:`~mpc.robots.drive.motor.DCMotor` of ``count`` motors on one shaft) behind ``gearing``.

A robot file::

    [dynamics]
    mass = 50.0                 # [kg]
    yaw_inertia = 3.0           # [kg m^2] about the body origin (the centre of mass)
    motor = "kraken_x60"        # a MOTOR_PRESETS name, or a table of DCMotor's fields
    motor_count = 1             # motors per wheel (with a preset name)
    gearing = 6.75              # motor turns per wheel turn
    battery_voltage = 12.0      # [V] open-circuit
    battery_resistance = 0.02   # [ohm] internal + wiring (sag), optional
    current_limit = 60.0        # [A] per motor (each motor controller's limit), optional
    friction = 1.1              # wheel-floor friction coefficient, optional
    wheel_inertia = 0.003       # [kg m^2] wheel + rotors reflected, about its axle, optional
    headroom = 0.05             # fraction of current and friction left for wheel feedback, optional
    voltage_headroom = 0.03     # fraction of the battery voltage left likewise, optional
    # steer_motor = "kraken_x60" and steer_gearing = 21.43 (swerve, optional)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from mpc.errors import RobotError
from mpc.plausibility import MASS, check_plausible
from mpc.robots.drive.motor import MOTOR_PRESETS, DCMotor
from mpc.validation import integer_at_least, non_negative, positive, shown

#: [m/s^2] gravity for the wheels' normal loads.
GRAVITY = 9.81

#: Default share of each motor's current limit and each contact's friction that a plan
#: leaves to the wheels' own velocity loops, whose feedback adds torque to the plan's: less
#: let the motor plant's loops past the current limit and traction
#: (docs/design/motor-headroom.md).
HEADROOM = 0.05

#: Default share of the battery voltage a plan leaves likewise. Where the voltage binds (at
#: the motors' free speed) the loops need less of it: 3 % kept the motor plant free of
#: voltage violations and tracked closer than 5 % (docs/design/motor-headroom.md).
VOLTAGE_HEADROOM = 0.03


@dataclass(frozen=True)
class RobotDynamics:
    """Mass, inertia, drive motors, battery and traction of a robot (SI units).

    Attributes:
        mass: [kg], > 0.
        yaw_inertia: [kg m^2] about the vertical axis through the body origin, taken as
            the centre of mass (so the wheels' static loads balance about it), > 0.
        motor: one drive wheel's gearbox at the motor shaft (``count`` motors).
        gearing: motor turns per wheel turn, > 0.
        battery_voltage: open-circuit battery voltage [V], > 0.
        battery_resistance: battery internal plus wiring resistance [ohm], >= 0: the bus
            sags by ``battery_resistance * battery current``.
        current_limit: each motor's current limit [A] (a motor controller's stator limit),
            or None for none (the stall current bounds it).
        friction: wheel-floor friction coefficient, or None for unlimited traction.
        wheel_inertia: each wheel's inertia about its axle with the motors' rotors
            reflected through the gearing [kg m^2], >= 0.
        headroom: fraction in [0, 0.5) of the current limit and friction the plan leaves
            unused, for the wheels' own velocity feedback (:data:`HEADROOM`).
        voltage_headroom: the same for the battery voltage (:data:`VOLTAGE_HEADROOM`).
        steer_motor: a swerve module's steering gearbox at the motor shaft, or None.
        steer_gearing: its motor turns per module turn (with ``steer_motor``).
    """

    mass: float
    yaw_inertia: float
    motor: DCMotor
    gearing: float
    battery_voltage: float = 12.0
    battery_resistance: float = 0.0
    current_limit: float | None = None
    friction: float | None = None
    wheel_inertia: float = 0.0
    headroom: float = HEADROOM
    voltage_headroom: float = VOLTAGE_HEADROOM
    steer_motor: DCMotor | None = None
    steer_gearing: float | None = None

    def __post_init__(self) -> None:
        check = {"mass": "kg", "yaw_inertia": "kg m^2", "gearing": "motor turns per wheel turn",
                 "battery_voltage": "V"}
        for name, unit in check.items():
            object.__setattr__(self, name, positive(f"{name} [{unit}]", getattr(self, name),
                                                    RobotError))
        for name, unit in (("battery_resistance", "ohm"), ("wheel_inertia", "kg m^2")):
            object.__setattr__(self, name, non_negative(f"{name} [{unit}]",
                                                        getattr(self, name), RobotError))
        if not isinstance(self.motor, DCMotor):
            raise RobotError(f"motor must be a DCMotor, got {shown(self.motor)}")
        for name in ("current_limit", "friction"):
            if getattr(self, name) is not None:
                unit = " [A]" if name == "current_limit" else ""
                object.__setattr__(self, name, positive(f"{name}{unit}", getattr(self, name),
                                                        RobotError))
        for name in ("headroom", "voltage_headroom"):
            value = non_negative(name, getattr(self, name), RobotError)
            if value >= 0.5:
                raise RobotError(f"{name} must be a fraction in [0, 0.5), got "
                                 f"{shown(getattr(self, name))}")
            object.__setattr__(self, name, value)
        if (self.steer_motor is None) != (self.steer_gearing is None):
            raise RobotError("steer_motor and steer_gearing go together: give both or neither")
        if self.steer_motor is not None:
            if not isinstance(self.steer_motor, DCMotor):
                raise RobotError(f"steer_motor must be a DCMotor, got {shown(self.steer_motor)}")
            object.__setattr__(self, "steer_gearing",
                               positive("steer_gearing", self.steer_gearing, RobotError))

    # ------------------------------------------------------------ at the wheel
    @property
    def wheel_motor(self) -> DCMotor:
        """The gearbox seen from the wheel: torque times ``gearing``, speed divided by it."""
        return self.motor.with_reduction(self.gearing)

    @property
    def free_speed(self) -> float:
        """Wheel speed with no load at the battery voltage [rad/s]:
        ``kv (V_battery - R I_free)`` at the wheel (WPILib's physics)."""
        wheel = self.wheel_motor
        return wheel.speed(wheel.torque(wheel.total_free_current), self.battery_voltage)

    @property
    def max_wheel_torque(self) -> float:
        """Largest torque one wheel's gearbox gives [N m] at the wheel: at the current
        limit (every motor of the gearbox at it), or at stall without one."""
        wheel = self.wheel_motor
        if self.current_limit is None:
            return wheel.torque(self.battery_voltage / wheel.R)
        return wheel.torque(self.current_limit * wheel.count)

    @property
    def max_acceleration(self) -> float | None:
        """The largest planar acceleration friction lets the plan give the body [m/s^2]:
        ``(1 - headroom) friction g`` (the contacts' forces sum to at most ``mu m g``), or
        None with unlimited traction."""
        if self.friction is None:
            return None
        return (1.0 - self.headroom) * self.friction * GRAVITY

    @property
    def max_steer_rate(self) -> float | None:
        """A swerve module's steering free speed at the battery voltage [rad/s], if a
        steering motor is given (its no-load speed; acceleration is not modelled)."""
        if self.steer_motor is None or self.steer_gearing is None:
            return None
        steer = self.steer_motor.with_reduction(self.steer_gearing)
        return steer.speed(steer.torque(steer.total_free_current), self.battery_voltage)


def motor_from(value: object, count: object = 1, what: str = "motor") -> DCMotor:
    """A :class:`DCMotor` from a DCMotor, a preset name (with ``count``) or a table of
    DCMotor's fields (``nominal_voltage``, ``stall_torque``, ``stall_current``,
    ``free_current``, ``free_speed`` [rad/s], optional ``count``)."""
    if isinstance(value, DCMotor):
        return value
    motors = integer_at_least(f"{what}_count", count, 1, RobotError)
    if isinstance(value, str):
        if value not in MOTOR_PRESETS:
            raise RobotError(f"{what} must be one of {list(MOTOR_PRESETS)} or a table of "
                             f"DCMotor fields, got {shown(value)}")
        return DCMotor.preset(value, motors)
    if isinstance(value, Mapping):
        fields = {"nominal_voltage", "stall_torque", "stall_current", "free_current",
                  "free_speed", "count"}
        unknown = sorted(set(value) - fields)
        missing = sorted(fields - {"count"} - set(value))
        if unknown or missing:
            raise RobotError(f"{what}: unknown key(s) {unknown}, missing key(s) {missing}; "
                             f"expected {sorted(fields)}")
        table = dict(value)
        table.setdefault("count", motors)
        return DCMotor(**table)
    raise RobotError(f"{what} must be a DCMotor, a preset name {list(MOTOR_PRESETS)} or a "
                     f"table of DCMotor fields, got {shown(value)}")


def dynamics(*, mass: float, yaw_inertia: float, motor: DCMotor | str | Mapping[str, Any],
             gearing: float, motor_count: int = 1, battery_voltage: float = 12.0,
             battery_resistance: float = 0.0, current_limit: float | None = None,
             friction: float | None = None, wheel_inertia: float = 0.0,
             headroom: float = HEADROOM, voltage_headroom: float = VOLTAGE_HEADROOM,
             steer_motor: DCMotor | str | Mapping[str, Any] | None = None,
             steer_motor_count: int = 1, steer_gearing: float | None = None,
             allow_unusual: bool = False) -> RobotDynamics:
    """A :class:`RobotDynamics` with motors given by preset name (``"kraken_x60"`` and
    ``motor_count``), a table of :class:`DCMotor` fields, or a DCMotor; the keys of a
    robot file's ``[dynamics]`` table (module docstring). A mass beyond any real robot's
    (:data:`mpc.plausibility.MASS`) raises RobotError naming the likely unit mistake,
    unless ``allow_unusual``."""
    steer = None if steer_motor is None else motor_from(steer_motor, steer_motor_count,
                                                        "steer_motor")
    result = RobotDynamics(mass=mass, yaw_inertia=yaw_inertia,
                         motor=motor_from(motor, motor_count), gearing=gearing,
                         battery_voltage=battery_voltage, battery_resistance=battery_resistance,
                         current_limit=current_limit, friction=friction,
                         wheel_inertia=wheel_inertia, headroom=headroom,
                         voltage_headroom=voltage_headroom, steer_motor=steer,
                         steer_gearing=steer_gearing)
    check_plausible({"mass": (MASS, result.mass)}, allow_unusual)
    return result


#: Keys of a ``[dynamics]`` table (the keyword arguments of :func:`dynamics`).
DYNAMICS_KEYS: frozenset[str] = frozenset({
    "mass", "yaw_inertia", "motor", "gearing", "motor_count", "battery_voltage",
    "battery_resistance", "current_limit", "friction", "wheel_inertia", "headroom",
    "voltage_headroom", "steer_motor", "steer_motor_count", "steer_gearing"})


def dynamics_from_dict(table: object, source: str = "dynamics",
                       allow_unusual: bool = False) -> RobotDynamics:
    """A :class:`RobotDynamics` from a parsed ``[dynamics]`` table (module docstring);
    ``allow_unusual`` is the robot file's key of that name (:func:`dynamics`)."""
    if not isinstance(table, Mapping):
        raise RobotError(f"{source}: dynamics must be a table of keys, got {shown(table)}")
    unknown = sorted(set(table) - DYNAMICS_KEYS)
    missing = sorted({"mass", "yaw_inertia", "motor", "gearing"} - set(table))
    if unknown or missing:
        raise RobotError(f"{source}: dynamics: unknown key(s) {unknown}, missing key(s) "
                         f"{missing}; expected some of {sorted(DYNAMICS_KEYS)}")
    try:
        return dynamics(**table, allow_unusual=allow_unusual)
    except RobotError as error:
        raise RobotError(f"{source}: dynamics: {error}") from None


class ChoreoMotorConfig(Protocol):
    """What :func:`choreo_dynamics` reads of a Choreo config (``trajectories.ChoreoConfig``):
    ``mass`` [kg], ``inertia`` [kg m^2], ``gearing``, ``vmax`` [rad/s at the motor],
    ``tmax`` [N m at the motor], ``cof``."""

    @property
    def mass(self) -> float: ...
    @property
    def inertia(self) -> float: ...
    @property
    def gearing(self) -> float: ...
    @property
    def vmax(self) -> float: ...
    @property
    def tmax(self) -> float: ...
    @property
    def cof(self) -> float: ...


def choreo_dynamics(config: ChoreoMotorConfig, *, motor: str | DCMotor = "kraken_x60",
                    battery_voltage: float = 12.0, battery_resistance: float = 0.0,
                    wheel_inertia: float = 0.0, headroom: float = HEADROOM,
                    voltage_headroom: float = VOLTAGE_HEADROOM) -> RobotDynamics:
    """The motor model of a Choreo config: ``mass``, ``inertia``, ``gearing``, ``cof`` as
    they are; the motor is ``motor`` (Choreo's default drive motor, a Kraken X60, unless
    given) with its free speed set to ``vmax`` (what Choreo plans with) and its current
    limited to ``tmax / kt`` (``tmax`` is Choreo's torque limit at the motor), so that
    its free speed and torque limit are exactly Choreo's and the voltage line between
    them is the motor's own."""
    base = motor_from(motor)
    vmax = positive("vmax [rad/s]", config.vmax, RobotError)
    tmax = positive("tmax [N m]", config.tmax, RobotError)
    scaled = DCMotor(base.nominal_voltage, base.stall_torque, base.stall_current,
                     base.free_current, vmax, base.count)
    limit = tmax / scaled.kt
    if limit > scaled.stall_current:
        raise RobotError(f"tmax {shown(tmax)} N m is beyond the {shown(base)}'s stall torque")
    return RobotDynamics(mass=config.mass, yaw_inertia=config.inertia, motor=scaled,
                         gearing=config.gearing, battery_voltage=battery_voltage,
                         battery_resistance=battery_resistance, current_limit=limit,
                         friction=config.cof, wheel_inertia=wheel_inertia, headroom=headroom,
                         voltage_headroom=voltage_headroom)


def free_speed_at(dynamics_: RobotDynamics, voltage: float) -> float:
    """Wheel free speed [rad/s] at ``voltage`` [V] (e.g. a sagged bus)."""
    wheel = dynamics_.wheel_motor
    return float(wheel.speed(wheel.torque(wheel.total_free_current), voltage))


def bus_voltage(open_circuit: float, resistance: float, power: float) -> float:
    """Bus voltage [V] of a battery (``open_circuit`` [V], ``resistance`` [ohm]) delivering
    ``power`` [W]: the larger root of ``V^2 - E V + R P = 0``, at most ``E`` (regeneration
    is not planned on); ``E / 2`` (the most power it can give) beyond that."""
    if resistance <= 0.0 or power <= 0.0:
        return open_circuit
    disc = open_circuit * open_circuit - 4.0 * resistance * power
    return 0.5 * (open_circuit + math.sqrt(max(disc, 0.0)))
