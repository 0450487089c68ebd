"""Swerve module states: signed wheel speeds and steer angles from module velocities.

- Flip rule: a module more than 90 degrees from its present angle steers to
  ``angle + pi`` and drives backwards instead (exactly 90 degrees does not flip).
- At rest: a module at (near) zero speed (:data:`STOPPED_MODULE_SPEED`) keeps its angle;
  one that a command leaves at rest may turn towards its direction in an aimed twist
  (:func:`aimed_angles`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.robots.swerve_limits import STOPPED_MODULE_SPEED, turns

if TYPE_CHECKING:
    from mpc.robots.swerve import SwerveRobot


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """Wrap angle(s) into (-pi, pi] [rad]."""
    wrapped = np.mod(np.asarray(angle, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    return np.where(wrapped == -math.pi, math.pi, wrapped)


def module_states(velocities: FloatArray, steer_angles: FloatArray | None,
                  wheel_radius: float) -> tuple[FloatArray, FloatArray]:
    """Signed speeds [rad/s] and steer angles in (-pi, pi] [rad] for wheel velocities (n, 2)
    [rad/s] (module ground velocity / ``wheel_radius``), with the flip rule against the
    present ``steer_angles`` (None: no flip, stopped modules point at 0)."""
    speed = np.hypot(velocities[:, 0], velocities[:, 1])
    angle = np.arctan2(velocities[:, 1], velocities[:, 0])
    if steer_angles is None:
        current = np.zeros(velocities.shape[0])
    else:
        current = steer_angles
        flip = np.abs(wrap_angle(angle - current)) > math.pi / 2
        angle = np.where(flip, angle + math.pi, angle)
        speed = np.where(flip, -speed, speed)
    stopped = np.abs(speed) * wheel_radius < STOPPED_MODULE_SPEED
    angle = np.where(stopped, current, angle)
    speed = np.where(stopped, 0.0, speed)
    return speed, wrap_angle(angle)


def aimed_angles(robot: SwerveRobot, speeds: FloatArray, angles: FloatArray,
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
