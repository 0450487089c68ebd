"""A simulated robot: integrates commanded wheel speeds, with real-robot faults.

The plant is deliberately not the controller's model: it integrates the
pose with RK4 over ``substeps`` sub-intervals per tick from the twist that
forward kinematics gives for the *actual* wheel speeds, which may lag the
command (first-order motor), arrive late (whole ticks of delay), slip, or
point the wrong way while a swerve module is still steering.

Casters (robots whose steer angles are states): the plant integrates each steer
angle from the commanded steer rate (limited to ``max_steer_rate``), and the robot
moves by the least-squares forward map of the actual drive and steer rates at the
actual angles (:meth:`~mpc.robots.wheels.caster.robot.CasterRobot.joint_twist`): joint rates
that do not agree on one rigid motion mean slip. :attr:`Plant.steer_angles` is what
a caster robot's controller measures.
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
from mpc.validation import is_finite_number, is_integer, shown


@dataclass(frozen=True)
class PlantConfig:
    """What the simulated robot adds to ideal kinematics.

    Attributes:
        substeps: integration sub-intervals per control tick (>= 1).
        motor_lag: first-order time constant of every wheel's speed [s]; 0 = instant.
        delay_ticks: whole ticks between a command and its effect.
        position_noise: standard deviation of the measured x and y [m].
        heading_noise: standard deviation of the measured heading [rad].
        slip: mean fraction of each wheel's speed lost to slip, drawn per
            wheel and tick uniformly from [0, 2 * slip] (0 <= slip < 0.5).
        steer_rate_limited: steered wheels turn at the robot's ``max_steer_rate``
            (False: they snap to the commanded angle).
    """

    substeps: int = 10
    motor_lag: float = 0.0
    delay_ticks: int = 0
    position_noise: float = 0.0
    heading_noise: float = 0.0
    slip: float = 0.0
    steer_rate_limited: bool = True

    def __post_init__(self) -> None:
        if not is_integer(self.substeps) or self.substeps < 1:
            raise SimulationError(f"substeps must be an integer >= 1, got {shown(self.substeps)}")
        if not is_integer(self.delay_ticks) or self.delay_ticks < 0:
            raise SimulationError(f"delay_ticks must be an integer >= 0, "
                                  f"got {shown(self.delay_ticks)}")
        for name in ("motor_lag", "position_noise", "heading_noise", "slip"):
            value = getattr(self, name)
            if not is_finite_number(value) or value < 0:
                raise SimulationError(f"{name} must be a finite number >= 0, got {shown(value)}")
        if self.slip >= 0.5:
            raise SimulationError(f"slip must be < 0.5 (a mean fraction), got {shown(self.slip)}")


#: Named plants for the CLI and tests.
PLANT_PRESETS: dict[str, PlantConfig] = {
    "ideal": PlantConfig(),
    "realistic": PlantConfig(motor_lag=0.03, delay_ticks=1, position_noise=0.002,
                             heading_noise=0.005, slip=0.03),
}


class Plant:
    """The simulated robot.

    Args:
        robot: the true robot (its kinematics and steering rate).
        dt: control tick [s].
        pose: initial world pose (x, y, theta).
        config: the faults to simulate.
        rng: random generator for noise and slip.
    """

    def __init__(self, robot: Robot, dt: float, pose: FloatArray, config: PlantConfig,
                 rng: np.random.Generator) -> None:
        self.robot = robot
        self.dt = dt
        self.config = config
        self.pose = np.array(pose, dtype=float)
        self.rng = rng
        n = robot.n_wheels
        self.wheel_speeds = np.zeros(n)  # actual, signed [rad/s]
        self.steer_angles = robot.initial_steer_angles()  # actual [rad], steered wheels only
        rest = (np.zeros(n), None if self.steer_angles is None else np.zeros(n),
                np.zeros(n) if robot.steer_states else None)
        self._pipe: deque[tuple[FloatArray, FloatArray | None, FloatArray | None]] = deque(
            [rest] * config.delay_ticks
        )
        self.steer_rates = np.zeros(n) if robot.steer_states else None  # actual [rad/s]

    def measure(self) -> FloatArray:
        """The pose a localisation system would report (with noise)."""
        config = self.config
        if config.position_noise == 0.0 and config.heading_noise == 0.0:
            return self.pose.copy()
        noise = self.rng.normal(size=3) * np.array(
            [config.position_noise, config.position_noise, config.heading_noise]
        )
        return self.pose + noise

    def apply(self, command: Command) -> FloatArray:
        """Run one tick under ``command``; return the wheel speeds actually reached [rad/s]."""
        self._pipe.append((command.wheel_speeds, command.steer_angles, command.steer_rates))
        target_speeds, target_angles, target_rates = self._pipe.popleft()
        config = self.config
        h = self.dt / config.substeps
        keep = math.exp(-h / config.motor_lag) if config.motor_lag > 0 else 0.0
        if config.slip > 0:
            grip = 1.0 - self.rng.uniform(0.0, 2.0 * config.slip, size=self.robot.n_wheels)
        else:
            grip = np.ones(self.robot.n_wheels)
        if self.robot.steer_states and target_rates is not None:
            self._joint_tick(target_speeds, target_rates, grip, keep, h)
            return self.wheel_speeds * grip
        for _ in range(config.substeps):
            self.wheel_speeds = keep * self.wheel_speeds + (1.0 - keep) * target_speeds
            turning = None
            if self.steer_angles is not None and target_angles is not None:
                before = self.steer_angles
                self._steer(target_angles, h)
                if config.steer_rate_limited:  # a snap (not rate limited) moves no wheel
                    turning = wrap_angle(self.steer_angles - before) / h
            if turning is None or self.steer_angles is None:
                twist = self.robot.forward_kinematics(self.wheel_speeds * grip, self.steer_angles)
            else:
                twist = self.robot.steering_forward_kinematics(
                    self.wheel_speeds * grip, self.steer_angles, turning)
            self._integrate(twist, h)
        return self.wheel_speeds * grip

    def _joint_tick(self, target_speeds: FloatArray, target_rates: FloatArray | None,
                    grip: FloatArray, keep: float, h: float) -> None:
        """Casters: drive and steer rates through the motor lag (steer rates limited), the
        angles integrated, the pose moved by the rates' least-squares twist."""
        rates = np.zeros(self.robot.n_wheels) if target_rates is None else target_rates
        limit = self.robot.max_steer_rates
        if self.config.steer_rate_limited and limit is not None:
            rates = np.clip(rates, -limit, limit)
        angles = self.steer_angles if self.steer_angles is not None else np.zeros_like(rates)
        steer = self.steer_rates if self.steer_rates is not None else np.zeros_like(rates)
        for _ in range(self.config.substeps):
            self.wheel_speeds = keep * self.wheel_speeds + (1.0 - keep) * target_speeds
            steer = keep * steer + (1.0 - keep) * rates
            twist = self.robot.joint_twist(self.wheel_speeds * grip, steer, angles)
            self._integrate(twist, h)
            angles = angles + h * steer
        self.steer_angles, self.steer_rates = angles, steer

    def _steer(self, target: FloatArray, h: float) -> None:
        """Turn every steered wheel towards its commanded angle, at most ``max_steer_rate``:
        the short way round, or for wheels with a steering range the absolute way (their
        angles are absolute and stay unwrapped, so leaving the range shows)."""
        current = self.steer_angles if self.steer_angles is not None else np.zeros_like(target)
        absolute = self.robot.steer_angle_range() is not None  # a range: no wrapping round
        error = target - current if absolute else wrap_angle(target - current)
        rates = self.robot.max_steer_rates
        if self.config.steer_rate_limited and rates is not None:
            reach = rates * h
            error = np.clip(error, -reach, reach)
        self.steer_angles = current + error if absolute else wrap_angle(current + error)

    def _integrate(self, twist: FloatArray, h: float) -> None:
        """RK4 of d/dt pose = R(theta) twist over ``h`` seconds."""
        def rate(pose: FloatArray) -> FloatArray:
            c, s = math.cos(pose[2]), math.sin(pose[2])
            return np.array([c * twist[0] - s * twist[1], s * twist[0] + c * twist[1], twist[2]])

        k1 = rate(self.pose)
        k2 = rate(self.pose + 0.5 * h * k1)
        k3 = rate(self.pose + 0.5 * h * k2)
        k4 = rate(self.pose + h * k3)
        self.pose = self.pose + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
