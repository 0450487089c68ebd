"""Swerve module states: signed wheel speeds and steer angles from module velocities.

- Flip rule: a module more than 90 degrees from its present angle steers to
  ``angle + pi`` and drives backwards instead (exactly 90 degrees does not flip).
- At rest: a module at (near) zero speed (:data:`STOPPED_MODULE_SPEED`) keeps its angle;
  one that a command leaves at rest may turn towards its direction in an aimed twist
  (:func:`aimed_angles`).
"""

from __future__ import annotations

import math

import numpy as np

from mpc.angles import wrap_angle
from mpc.arrays import FloatArray
from mpc.robots.wheels.swerve.limits import STOPPED_MODULE_SPEED, turns
from mpc.robots.wheels.swerve.modules import SwerveModules


def module_states(velocities: FloatArray, steer_angles: FloatArray | None,
                  wheel_radius: float) -> tuple[FloatArray, FloatArray]:
    """Signed speeds [rad/s] and steer angles in (-pi, pi] [rad] for wheel velocities (n, 2)
    [rad/s] (module ground velocity / ``wheel_radius``), with the flip rule against the
    present ``steer_angles`` (None: no flip, stopped modules point at 0)."""
    x, y = velocities[:, 0], velocities[:, 1]
    speeds, angles = np.hypot(x, y).tolist(), np.arctan2(y, x).tolist()
    # the rest a module at a time (quicker than a dozen NumPy calls on arrays of four:
    # docs/design/tick-costs.md)
    current = [0.0] * len(speeds) if steer_angles is None else steer_angles.tolist()
    for i, (speed, angle, present) in enumerate(zip(speeds, angles, current, strict=True)):
        if steer_angles is not None and abs(_wrapped(angle - present)) > 0.5 * math.pi:
            angle, speed = angle + math.pi, -speed
        if abs(speed) * wheel_radius < STOPPED_MODULE_SPEED:
            angle, speed = present, 0.0
        speeds[i], angles[i] = speed, _wrapped(angle)
    return np.array(speeds), np.array(angles)


def _wrapped(angle: float) -> float:
    """:func:`wrap_angle` of one angle (the same operations on a Python float)."""
    wrapped = (angle + math.pi) % (2.0 * math.pi) - math.pi
    return math.pi if wrapped == -math.pi else wrapped


def aimed_angles(robot: SwerveModules, speeds: FloatArray, angles: FloatArray,
                 aim: FloatArray, steer_angles: FloatArray, dt: float) -> FloatArray:
    """The commanded ``angles`` with each module the command leaves at rest turned towards
    its direction in the twist ``aim``, by at most ``max_steer_rate dt`` from its present
    angle (``steer_angles``)."""
    if (speeds != 0.0).all():  # every module drives: nothing waits (most ticks)
        return angles
    goal = robot.wheel_blocks @ aim
    wanted = np.arctan2(goal[:, 1], goal[:, 0])
    # turn the short way, flipping beyond 90 deg (exactly 90 deg: no flip), at most
    # one tick's worth
    turn = wrap_angle(wanted - steer_angles)
    turn = np.where(np.abs(turn) > math.pi / 2, turn - np.sign(turn) * math.pi, turn)
    reach = robot.max_steer_rate * dt
    waiting = (speeds == 0.0) & (turns(robot, goal, steer_angles) > 0.0)
    stepped = wrap_angle(steer_angles + np.clip(turn, -reach, reach))
    aimed: FloatArray = np.where(waiting, stepped, angles)
    return aimed
