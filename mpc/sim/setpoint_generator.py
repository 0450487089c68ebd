"""A swerve setpoint generator in the style of Team 254's SwerveSetpointGenerator (2022,
ported to PathPlanner): the step from the last setpoint towards a desired twist that
respects the module limits (the baseline :mod:`mpc.sim.setpoint` drives through it).

Written from the published description. Each tick, from the previous setpoint
(twist ``xi_0``, steer angles ``beta_0``) towards the desired twist:

1. **Desaturate** (WPILib): scale the desired twist so the fastest module is at its
   speed limit, ``goal``.
2. **Stop first**: if both twists are non-zero and every module would have to turn
   its velocity by more than 90 degrees (``goal`` reverses the robot), aim for
   ``goal = 0`` this tick.
3. **Largest fraction** ``s`` in [0, 1] of the step ``xi_0 + s (goal - xi_0)`` such
   that for every module (velocities ``v_i(s)`` [rad/s, wheel units])

   - steering: the direction of ``v_i(s)`` stays within ``dt * max_steer_rate`` of
     ``v_i(0)``'s, the first crossing along the step. 254 finds it by a few
     root-finding iterations on the heading; the velocities within that angle form a
     wedge, so here the crossing is exact (the segment leaves the wedge once).
     A module at rest (commanded speed 0) whose goal direction is more than one
     steering step away (flip rule applied) holds ``s = 0``: the robot keeps its
     previous twist while that module turns in place;
   - wheel speed: ``| |v_i(s)| - |v_i(0)| | <= dt * max_wheel_accel`` (254's drive
     limit; exact roots of a quadratic here).
4. **Module acceleration, as this project bounds it**: ``max_wheel_accel`` limits the
   change of the module's velocity *vector*, ``|v_i(s) - v_i(0)| <= dt *
   max_wheel_accel`` (see :mod:`mpc.robots.wheels.swerve.robot`), which is stricter than 254's
   speed-change limit (a module turning at constant speed changes velocity but not
   speed), so the step is finished with :func:`~mpc.control.clamp.clamp_command`,
   which shortens it along the same segment.
5. **Commands**: signed speeds and steer angles by the project's flip rule against
   ``beta_0`` (more than 90 degrees: turn to ``angle + pi`` and drive backwards; a
   module at rest keeps its angle). A module commanded at rest whose goal moves
   pre-steers towards the goal direction by at most one steering step.

Every command is within each module's speed, acceleration (vector) and steering
rate limit: steering is checked on the final command, and should a corner case
break it (a module below the at-rest speed at the start of the step), the step is
shortened by bisection until it holds (the previous twist always does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mpc.angles import wrap_angle
from mpc.arrays import BoolArray, FloatArray
from mpc.control.clamp import clamp_command
from mpc.errors import ControllerError
from mpc.robots.base import Robot
from mpc.validation import finite_vector, is_finite_number, shown

#: Relative slack on the steering limit (rounding), as for the other limits.
_STEER_SLACK = 1e-9
#: Bisection steps of the steering repair (each halves the doubt about the fraction).
_REPAIR_STEPS = 30


def _half_wrap(angle: FloatArray) -> FloatArray:
    """The turn [rad] a module needs under the flip rule, in [-pi/2, pi/2]: more than 90
    degrees either way turns to the opposite direction; exactly 90 degrees does not."""
    turn = wrap_angle(angle)
    return np.where(np.abs(turn) > math.pi / 2, turn - np.copysign(math.pi, turn), turn)


def steered_robot(robot: object) -> tuple[Robot, FloatArray]:
    """The robot and its steering rate limits [rad/s], or ControllerError unless swerve."""
    if not isinstance(robot, Robot):
        raise ControllerError(f"robot must be an mpc.robots.Robot, got {type(robot).__name__}")
    rates = robot.max_steer_rates
    if not robot.steered or rates is None or robot.wheel_dim != 2:
        raise ControllerError(
            f"the setpoint generator needs steered modules (swerve); robot {robot.name!r} "
            f"has wheel type {robot.kind!r}")
    return robot, rates


def _flip_rule(robot: Robot, velocities: FloatArray,
               current: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Signed speeds [rad/s] and steer angles [rad] by the robot's flip and rest rules."""
    speeds, angles = robot.commands_from_velocities(velocities, current)
    if angles is None:
        raise ControllerError(f"robot {robot.name!r} gave no steer angles for its modules")
    return speeds, angles


@dataclass(frozen=True, eq=False)
class SwerveSetpoint:
    """One swerve command: body twist (vx, vy, omega) [m/s, m/s, rad/s], signed module wheel
    speeds [rad/s] and steer angles in (-pi, pi] [rad], each shape (n,)."""

    twist: FloatArray
    wheel_speeds: FloatArray
    steer_angles: FloatArray

    @classmethod
    def from_twist(cls, robot: Robot, twist: ArrayLike,
                   steer_angles: ArrayLike | None = None) -> SwerveSetpoint:
        """The setpoint commanding ``twist`` from ``steer_angles`` (default: straight ahead),
        by the project's flip and keep-at-rest rules."""
        robot, _ = steered_robot(robot)
        xi = finite_vector("twist", twist, 3, "(vx, vy, omega)", ControllerError)
        if steer_angles is None:
            current = np.zeros(robot.n_wheels)
        else:
            current = finite_vector("steer_angles", steer_angles, robot.n_wheels,
                                    "steer angles [rad]", ControllerError)
        return cls(xi, *_flip_rule(robot, robot.wheel_blocks @ xi, current))


def _steering_fraction(start: FloatArray, step: FloatArray, moving: BoolArray,
                       turn: FloatArray) -> float:
    """Largest s keeping each moving module's velocity direction within ``turn`` [rad] of
    its start: where ``start + s step`` (n, 2) first leaves the wedge around it."""
    fraction = 1.0
    for i in np.flatnonzero(moving & (turn < math.pi / 2)):
        heading = math.atan2(start[i, 1], start[i, 0])
        for side in (1.0, -1.0):
            edge = heading + side * turn[i]
            normal = side * np.array([-math.sin(edge), math.cos(edge)])  # outward
            rate = float(normal @ step[i])
            if rate > 0.0:
                fraction = min(fraction, -float(normal @ start[i]) / rate)
    return max(fraction, 0.0)


def _speed_fraction(start: FloatArray, step: FloatArray, limit: FloatArray) -> float:
    """Largest s with ``| |start + s step| - |start| | <= limit`` up to the first crossing
    (254's drive-speed limit), per module (n, 2), exactly."""
    fraction = 1.0
    a = np.einsum("nd,nd->n", step, step)
    b = np.einsum("nd,nd->n", start, step)
    speed = np.hypot(start[:, 0], start[:, 1])
    for i in np.flatnonzero(a > 0.0):
        outer = speed[i] + limit[i]  # speeding up: the positive root
        c = speed[i] ** 2 - outer**2
        fraction = min(fraction, (-b[i] + math.sqrt(b[i] ** 2 - a[i] * c)) / a[i])
        inner = speed[i] - limit[i]  # slowing down: the first root, if it is reached
        c = speed[i] ** 2 - inner**2
        if inner > 0.0 and b[i] < 0.0 and b[i] ** 2 >= a[i] * c:
            fraction = min(fraction, (-b[i] - math.sqrt(b[i] ** 2 - a[i] * c)) / a[i])
    return max(fraction, 0.0)


def _goal_turn(robot: Robot, goal_velocity: FloatArray, current: FloatArray) -> FloatArray:
    """Per module, the turn [rad] to its goal direction by the flip rule; 0 where the goal
    is at rest (below the robot's at-rest speed, as its commands count it)."""
    speeds, _ = _flip_rule(robot, goal_velocity, current)
    need = _half_wrap(np.arctan2(goal_velocity[:, 1], goal_velocity[:, 0]) - current)
    return np.where(speeds != 0.0, need, 0.0)


def _commands(robot: Robot, twist: FloatArray, previous: SwerveSetpoint, need: FloatArray,
              turn: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Speeds and angles for ``twist`` by the flip rule; modules at rest pre-steer by at most
    ``turn`` towards their goal (``need``, from :func:`_goal_turn`)."""
    speeds, angles = _flip_rule(robot, robot.wheel_blocks @ twist, previous.steer_angles)
    turned = wrap_angle(previous.steer_angles + np.clip(need, -turn, turn))
    return speeds, np.where(speeds == 0.0, turned, angles)


def _steering_within(angles: FloatArray, previous: SwerveSetpoint, turn: FloatArray) -> bool:
    change = np.abs(wrap_angle(angles - previous.steer_angles))
    return bool(np.all(change <= turn * (1.0 + _STEER_SLACK)))


def generate_setpoint(robot: Robot, previous: SwerveSetpoint, desired: ArrayLike,
                      dt: float) -> SwerveSetpoint:
    """The next setpoint from ``previous`` towards the ``desired`` twist over ``dt`` [s]
    (see the module docstring); within every module limit."""
    robot, rates = steered_robot(robot)
    _check_previous(robot, previous)
    target = finite_vector("desired", desired, 3, "(vx, vy, omega)", ControllerError)
    if not is_finite_number(dt) or dt <= 0:
        raise ControllerError(f"dt must be a finite number of seconds > 0, got {shown(dt)}")
    turn = rates * dt
    start = robot.wheel_blocks @ previous.twist
    moving = previous.wheel_speeds != 0.0
    goal = robot.desaturate(target)
    goal_velocity = robot.wheel_blocks @ goal
    need = _goal_turn(robot, goal_velocity, previous.steer_angles)
    if _reverses(start, goal_velocity, moving, need):
        goal, goal_velocity, need = np.zeros(3), np.zeros_like(goal_velocity), 0.0 * need
    step = goal_velocity - start
    fraction = _steering_fraction(start, step, moving, turn)
    if np.any(~moving & (np.abs(need) > turn)):
        fraction = 0.0  # a module at rest must turn first
    accel = robot.max_wheel_accel
    if accel is not None:
        fraction = min(fraction, _speed_fraction(start, step, accel * dt))
    twist = previous.twist + fraction * (goal - previous.twist)
    twist, _ = clamp_command(robot, twist, previous.twist, dt)
    speeds, angles = _commands(robot, twist, previous, need, turn)
    if not _steering_within(angles, previous, turn):
        twist, speeds, angles = _repair(robot, twist, previous, need, turn)
    return SwerveSetpoint(twist, speeds, angles)


def _check_previous(robot: Robot, previous: object) -> None:
    """``previous`` must be a setpoint of this robot whose angles and speeds agree with its
    twist (as :meth:`SwerveSetpoint.from_twist` and :func:`generate_setpoint` make them)."""
    if not isinstance(previous, SwerveSetpoint):
        raise ControllerError(f"previous must be a SwerveSetpoint, got {type(previous).__name__}")
    n = robot.n_wheels
    if (np.shape(previous.twist) != (3,) or np.shape(previous.wheel_speeds) != (n,)
            or np.shape(previous.steer_angles) != (n,)):
        raise ControllerError(f"previous setpoint must hold a (3,) twist and ({n},) speeds "
                              f"and steer angles for robot {robot.name!r}")
    velocity = robot.wheel_blocks @ previous.twist
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    moving = previous.wheel_speeds != 0.0
    off = _half_wrap(np.arctan2(velocity[:, 1], velocity[:, 0]) - previous.steer_angles)
    if np.any(moving & ((np.abs(off) > 1e-6) | (np.abs(np.abs(previous.wheel_speeds) - speed)
                                               > 1e-9 * (1.0 + speed)))):
        raise ControllerError("previous setpoint's speeds and steer angles do not match its "
                              "twist; build it with SwerveSetpoint.from_twist")


def _reverses(start: FloatArray, goal_velocity: FloatArray, moving: BoolArray,
              need: FloatArray) -> bool:
    """Whether every module moves at both ends and would turn its velocity > 90 degrees."""
    if not np.all(moving) or not np.all(need != 0.0):
        return False
    return bool(np.all(np.einsum("nd,nd->n", start, goal_velocity) < 0.0))


def _repair(robot: Robot, twist: FloatArray, previous: SwerveSetpoint, need: FloatArray,
            turn: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Shorten the step from the previous twist until the steering limit holds (bisection;
    the previous twist holds it, and every shorter step keeps the other limits)."""
    low, high = 0.0, 1.0
    for _ in range(_REPAIR_STEPS):
        middle = 0.5 * (low + high)
        trial = previous.twist + middle * (twist - previous.twist)
        if _steering_within(_commands(robot, trial, previous, need, turn)[1], previous,
                            turn):
            low = middle
        else:
            high = middle
    twist = previous.twist + low * (twist - previous.twist)
    speeds, angles = _commands(robot, twist, previous, need, turn)
    return twist, speeds, angles
