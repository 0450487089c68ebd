"""A simulated robot driven through its DC motors: voltage in, traction out.

Each wheel's motor controller runs a velocity loop on the command: the setpoint ramps
from the last commanded wheel speed to this one over the tick (a constant acceleration,
as the motor-aware rows plan it; a first-order hold, which a controller built with
``Controller(command_ramp=True)`` plans for from half a tick ahead), and the voltage is
the feedforward for the setpoint's speed and the tick's torque plus proportional
feedback::

    V_demand = w_set / kv + R T_ff / kt + velocity_gain (w_set - w)

``T_ff`` is the command's own motor torque (:attr:`Command.motor_torques`) when it has
one (a swerve module's whose command carries its contact force vector,
:attr:`Command.contact_forces`: that vector projected onto the way the module points
now, each sub-step, plus the wheel's own inertia torque, as a team projects PathPlanner's
robot-relative forces onto the measured module angle), otherwise the torque the
commanded change of twist needs on this robot (an acceleration feedforward, as a
well-identified ``kA`` gives: controllers that do not plan forces are not handicapped by
a poorer wheel loop). The motor controller applies
``V_demand`` clipped to the bus voltage, then lowers it so that the current stays within
the current limit (a stator current limit). Counted, per tick, on any sub-step:

- a **voltage violation** when ``|V_demand|`` exceeds the bus voltage;
- a **current violation** when the current of the clipped voltage exceeds the limit;
- a **slip event** when a wheel's contact force reached ``mu N`` and the wheel slid;

and the **planned traction ratio**: the largest contact force / ``mu N`` that the
command's own step (from the command before it to it, over the tick) needs by the
rigid-body model (:mod:`mpc.robots.drive.force_map`), whoever made the command. A slip
on a tick whose planned ratio is at most 1 is the plant's, not the plan's; ``steer_saturated``
says whether a swerve module's steering ran at its rate limit on the tick (then the
module lags the velocity it should point along, and its contact slides sideways).

Physics per sub-step (implicit Euler in the twist and the wheel speeds):

- each motor: ``T = kt (V - w / kv) / R`` at the wheel (WPILib's model);
- each wheel: ``J dw/dt = T - tau`` with ``tau`` the floor's reaction (wheel torque
  units); the body: ``M (du/dt + coriolis(u)) = sum W^T tau`` (:mod:`mpc.robots.drive.force_map`);
- the floor: a stiff regularised contact, ``tau = k (w - W u)`` along each slip
  direction (a Swedish wheel's roller axis, a ball's two actuators, a swerve module's
  rolling and lateral directions), one ``k`` for every contact, such that a contact
  creeps at ``slip_speed + slip_ratio |v|`` (``|v|`` the contacts' mean ground speed) at
  the mean ``mu N``: so the force the directions no motor drives take is shared as the
  planner's minimum-norm split shares it, under the same static normal loads (the force
  model of :mod:`mpc.robots.drive.force_map`; ``docs/guide/traction.md``), as a tyre whose
  force saturates at a few degrees of slip angle or a few percent of slip; a contact
  whose force would exceed ``mu N`` slides with ``mu N`` (kinetic friction along the
  force it would have needed);
- the battery: ``V_bus = E - R_battery I_battery``, ``I_battery = sum V I / V_bus``
  (the last sub-step's draw);
- a swerve module steers at ``max_steer_rate`` along the module velocity the tick's ramp
  has reached (from the last command's to this one's: the direction turns over the tick
  as the speed changes), and its wheel loop's setpoint is that velocity's component along
  the way the wheel points.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from mpc.angles import wrap_angle
from mpc.arrays import FloatArray
from mpc.control.command import Command
from mpc.errors import SimulationError
from mpc.robots.base import Robot
from mpc.robots.drive.force_map import ForceMap, force_map
from mpc.sim.motor_substep import MIN_WHEEL_INERTIA, SubStepModel
from mpc.sim.plant import PLANT_PRESETS, Plant, PlantConfig
from mpc.validation import is_finite_number, shown

__all__ = ["EVENT_KEYS", "MIN_WHEEL_INERTIA", "MotorPlant", "MotorPlantConfig"]

#: Event series a :class:`MotorPlant` records per tick (:meth:`MotorPlant.events`).
EVENT_KEYS: tuple[str, ...] = ("voltage_violation", "current_violation", "slip",
                               "peak_voltage_ratio", "peak_current_ratio", "bus_voltage",
                               "peak_traction_ratio", "planned_traction_ratio",
                               "steer_saturated")


@dataclass(frozen=True)
class MotorPlantConfig(PlantConfig):
    """The motor plant's settings (the delay and noise of :class:`PlantConfig` apply too;
    its ``motor_lag`` and ``slip`` must stay 0: the motors and traction model both).

    Attributes:
        velocity_gain: each wheel loop's proportional gain [V per rad/s at the wheel];
            None: five times the back-EMF slope ``1 / kv``.
        battery_resistance: [ohm]; None: the robot's ``dynamics.battery_resistance``.
        slip_speed: how fast a contact creeps at full traction at rest [m/s], > 0; and
        slip_ratio: how much faster per m/s of its ground speed, >= 0 (0.02: traction
            saturates at about 1 degree of slip angle or 2 % of slip, a stiff tread; 0: a
            rigid one, which a module steering a degree behind its velocity already
            slides).
    """

    substeps: int = 20
    velocity_gain: float | None = None
    battery_resistance: float | None = None
    slip_speed: float = 0.002
    slip_ratio: float = 0.02

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.motor_lag != 0.0 or self.slip != 0.0:
            raise SimulationError("the motor plant models the motors and traction itself: "
                                  f"motor_lag and slip must be 0, got {shown(self.motor_lag)} and "
                                  f"{shown(self.slip)}")
        for name in ("velocity_gain", "battery_resistance"):
            value = getattr(self, name)
            if value is not None and (not is_finite_number(value) or value < 0):
                raise SimulationError(f"{name} must be a finite number >= 0 or None, "
                                      f"got {shown(value)}")
        if not is_finite_number(self.slip_speed) or self.slip_speed <= 0:
            raise SimulationError(f"slip_speed [m/s] must be a finite number > 0, "
                                  f"got {shown(self.slip_speed)}")
        if not is_finite_number(self.slip_ratio) or self.slip_ratio < 0:
            raise SimulationError(f"slip_ratio must be a finite number >= 0, "
                                  f"got {shown(self.slip_ratio)}")


# `simulate(..., plant="motor")` and `mpc-bench --plant motor`.
PLANT_PRESETS["motor"] = MotorPlantConfig()


class MotorPlant(Plant):
    """The robot driven through its motors (module docstring).

    Args:
        robot: the true robot; it must have dynamics (:meth:`Robot.with_dynamics`).
        dt: control tick [s].
        pose: initial world pose (x, y, theta).
        config: a :class:`MotorPlantConfig`.
        rng: random generator for the measurement noise.
    """

    def __init__(self, robot: Robot, dt: float, pose: FloatArray, config: PlantConfig,
                 rng: np.random.Generator) -> None:
        if robot.dynamics is None:
            raise SimulationError(f"the motor plant needs a robot with dynamics; robot "
                                  f"{robot.name!r} has none (robot.with_dynamics(...))")
        if not isinstance(config, MotorPlantConfig):
            raise SimulationError(f"config must be a MotorPlantConfig, got {shown(config)}")
        super().__init__(robot, dt, pose, config, rng)
        self.forces: ForceMap = force_map(robot)
        dyn = robot.dynamics
        forces = self.forces
        self.battery_resistance = (dyn.battery_resistance if config.battery_resistance is None
                                   else config.battery_resistance)
        self.velocity_gain = (5.0 / forces.kv if config.velocity_gain is None
                              else config.velocity_gain)
        self.twist = np.zeros(3)  # body twist [m/s, m/s, rad/s]
        self._battery_current = 0.0
        self._last_speeds = np.zeros(robot.n_wheels)  # last commanded wheel speeds
        self._last_twist = np.zeros(3)
        self._last_angles: FloatArray | None = None  # last commanded steer angles
        self._events: list[tuple[float, ...]] = []
        self._saturated = False  # a module's steering at its rate limit this tick
        self._commands: deque[Command | None] = deque([None] * config.delay_ticks)
        self._physics = SubStepModel.build(robot, forces, self.velocity_gain, config.slip_speed,
                                           config.slip_ratio, config.substeps, dt)
        self.current_limit = self._physics.current_limit  # the gearbox's [A]

    def set_motion(self, twist: FloatArray) -> None:
        """Put the robot in motion at body ``twist`` with its wheels rolling along (steered
        wheels pointing along their velocity) and the last command equal to it."""
        robot = self.robot
        twist = np.array(twist, dtype=float)
        speeds, angles = robot.wheel_commands(twist, robot.initial_steer_angles())
        self.twist = twist
        self.wheel_speeds = np.asarray(speeds, dtype=float).copy()
        self._last_speeds = self.wheel_speeds.copy()
        self._last_twist = twist.copy()
        if angles is not None:
            self.steer_angles = np.asarray(angles, dtype=float).copy()
            self._last_angles = self.steer_angles.copy()

    # ------------------------------------------------------------ one tick
    def apply(self, command: Command) -> FloatArray:
        """Run one tick under ``command``; return the wheel speeds reached [rad/s]."""
        planned = self._planned_traction(command)
        target_speeds, target_angles, feedforward, vectors = self._delayed_targets(command)
        config, forces = self.config, self.forces
        substeps = config.substeps
        h = self.dt / substeps
        start = self._last_speeds
        flags = [False, False, False]
        self._saturated = False
        peaks = [0.0, 0.0, 0.0]
        lowest = math.inf
        aims = target_angles if self.steer_angles is not None else None
        if aims is not None:  # the module velocity vectors the tick ramps between
            begin, finish = self._module_ramp(start, target_speeds, aims)
        for s in range(substeps):
            fraction = (s + 1.0) / substeps
            setpoint = start + (target_speeds - start) * fraction
            if aims is not None:
                setpoint = self._steer_modules(begin + (finish - begin) * fraction, aims, h)
            bus = self.robot.dynamics.battery_voltage - self.battery_resistance * (  # type: ignore[union-attr]
                self._battery_current)
            lowest = min(lowest, bus)
            torque = feedforward if vectors is None else self._projected(feedforward, vectors)
            ahead = forces.voltage(torque, setpoint) + self.velocity_gain * setpoint
            previous = self.twist
            self.twist, self.wheel_speeds, sub = self._physics.step(
                (self.twist, self.wheel_speeds), self.steer_angles, ahead, bus)
            flags[0] |= sub.voltage_violation
            flags[1] |= sub.current_violation
            flags[2] |= sub.slipped
            peaks[0] = max(peaks[0], sub.voltage_ratio)
            peaks[1] = max(peaks[1], sub.current_ratio)
            peaks[2] = max(peaks[2], sub.traction_ratio)
            self._battery_current = float(sub.voltage @ sub.current) / max(bus, 1e-9)
            self._integrate(0.5 * (previous + self.twist), h)
        self._last_speeds = np.asarray(target_speeds, dtype=float).copy()
        if target_angles is not None:
            self._last_angles = np.asarray(target_angles, dtype=float).copy()
        self._events.append((float(flags[0]), float(flags[1]), float(flags[2]),
                             peaks[0], peaks[1], lowest, peaks[2], planned,
                             float(self._saturated)))
        return self.wheel_speeds.copy()

    def _delayed_targets(self, command: Command
                         ) -> tuple[FloatArray, FloatArray | None, FloatArray,
                                    FloatArray | None]:
        """Queue ``command`` on the delay line; the wheel speeds, steer angles, wheel
        torque feedforward [N m] of the command that comes out of it, and (swerve modules
        whose command carries them) its contact force vectors [N] (n, 2)."""
        self._commands.append(command)
        delayed = self._commands.popleft()
        vectors = None
        if delayed is None:  # the delay line still holds the robot at rest
            target_speeds, target_angles = np.zeros(self.robot.n_wheels), self.steer_angles
            feedforward = self._feedforward(np.zeros(3), None, target_angles)
        else:
            target_speeds, target_angles = delayed.wheel_speeds, delayed.steer_angles
            feedforward = self._feedforward(np.asarray(delayed.twist, dtype=float),
                                            delayed.motor_torques, target_angles)
            if (delayed.contact_forces is not None and target_angles is not None
                    and delayed.motor_torques is not None and self.robot.wheel_dim == 2):
                vectors = np.asarray(delayed.contact_forces, dtype=float)
                # the command's torque less its contact force's part along the commanded
                # angle: the wheel's own inertia, which stays with the wheel
                along = vectors[:, 0] * np.cos(target_angles) + vectors[:, 1] * np.sin(
                    target_angles)
                feedforward = feedforward - along * self.forces.radii
        return target_speeds, target_angles, feedforward, vectors

    def _planned_traction(self, command: Command) -> float:
        """The largest contact force / ``mu N`` of the step from the last command that
        came out of the delay line to the one that comes out now (call before
        :meth:`_delayed_targets`); 0 without friction."""
        limits = self.forces.friction_limits
        if limits is None:
            return 0.0
        delayed = self._commands[0] if self._commands else command
        twist = np.zeros(3) if delayed is None else np.asarray(delayed.twist, dtype=float)
        accel = self.forces.acceleration(self._last_twist, twist, self.dt)
        contact = self.forces.contact_forces(accel)
        return float((np.hypot(contact[:, 0], contact[:, 1]) / limits).max())

    def _projected(self, inertia: FloatArray, vectors: FloatArray) -> FloatArray:
        """Swerve: each module's drive torque feedforward [N m] now, its contact force
        ``vectors`` (n, 2) [N] projected onto the way the module points now (as a team
        projects PathPlanner's robot-relative forces onto the measured module angle),
        plus the wheel's own ``inertia`` torque."""
        angles = self.steer_angles
        if angles is None:  # pragma: no cover - swerve modules have angles
            return inertia
        along = vectors[:, 0] * np.cos(angles) + vectors[:, 1] * np.sin(angles)
        return inertia + along * self.forces.radii

    def _module_ramp(self, start: FloatArray, target_speeds: FloatArray,
                     aims: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The swerve modules' velocity vectors (n, 2) the tick ramps between: from the last
        command's (the first tick: where the modules point) to this one's."""
        if self._last_angles is not None:
            before = self._last_angles
        else:  # the first tick: from where the modules point
            before = aims if self.steer_angles is None else self.steer_angles
        begin = start[:, None] * np.stack([np.cos(before), np.sin(before)], axis=1)
        finish = np.asarray(target_speeds)[:, None] * np.stack(
            [np.cos(aims), np.sin(aims)], axis=1)
        return begin, finish

    def _steer_modules(self, velocity: FloatArray, aims: FloatArray, h: float) -> FloatArray:
        """Steer each module for ``h`` seconds along the ``velocity`` (n, 2) the ramp has
        reached (flip rule against its present angle; at rest, towards its commanded angle
        ``aims``); the wheel loops' setpoints: its component along the way each points."""
        speed = np.hypot(velocity[:, 0], velocity[:, 1])
        angle = np.arctan2(velocity[:, 1], velocity[:, 0])
        present = aims if self.steer_angles is None else self.steer_angles
        flip = np.abs(wrap_angle(angle - present)) > math.pi / 2
        angle = np.where(speed > 1e-9, np.where(flip, angle + math.pi, angle), aims)
        rates = self.robot.max_steer_rates
        if self.config.steer_rate_limited and rates is not None:
            self._saturated |= bool(np.any(np.abs(wrap_angle(angle - present))
                                           > rates * h * (1.0 + 1e-9)))
        self._steer(angle, h)
        pointing = aims if self.steer_angles is None else self.steer_angles
        setpoint: FloatArray = (velocity[:, 0] * np.cos(pointing)
                                + velocity[:, 1] * np.sin(pointing))
        return setpoint

    def _feedforward(self, twist: FloatArray, motor_torques: FloatArray | None,
                     angles: FloatArray | None) -> FloatArray:
        """Wheel torques [N m] the loop feeds forward this tick: the command's own motor
        torques, or the torque its change of twist needs (acceleration feedforward)."""
        forces = self.forces
        if motor_torques is not None:
            torque = np.asarray(motor_torques, dtype=float) * (
                forces.dynamics.gearing * forces.count)
        else:
            if self.robot.wheel_dim == 2:
                steer = np.zeros(self.robot.n_wheels) if angles is None else angles
                directions = np.stack([np.cos(steer), np.sin(steer)], axis=1)
            else:
                directions = np.ones((self.robot.n_wheels, 1))
            torque = forces.drive_torques(self._last_twist, twist, self.dt, directions)
        self._last_twist = twist
        return torque

    # ------------------------------------------------------------ record
    def events(self) -> dict[str, FloatArray]:
        """Per tick so far: ``voltage_violation``, ``current_violation``, ``slip`` (1.0 or
        0.0), ``peak_voltage_ratio`` (largest ``|V_demand| / V_bus``),
        ``peak_current_ratio`` (largest ``|I| / limit``), ``peak_traction_ratio`` (largest
        contact force / ``mu N`` the contacts were asked for), the lowest ``bus_voltage``
        [V] over its sub-steps, ``planned_traction_ratio`` and ``steer_saturated`` (module
        docstring)."""
        table = np.array(self._events, dtype=float).reshape(-1, len(EVENT_KEYS))
        return {key: table[:, i].copy() for i, key in enumerate(EVENT_KEYS)}
