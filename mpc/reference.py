"""The reference window a controller tracks over its horizon.

The feedforward twist of stage ``k`` is the constant body twist that drives
the model exactly from reference pose ``k`` to reference pose ``k + 1`` in
one tick (the SE(2) logarithm divided by ``dt``). Unlike the trajectory's
instantaneous body twist, it is consistent with the discrete dynamics, so a
robot on the reference with the feedforward stays on it and the cost has no
bias towards cutting corners.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.robots.base import FloatArray
from trajectories import Trajectory

#: Below this ``|delta theta|`` [rad] the SE(2) logarithm uses its Taylor series.
_SMALL_ANGLE = 1e-4

#: Reference speed [m/s] below which the direction of travel fades to zero.
DIRECTION_SPEED = 0.01


def feedforward_twists(poses: FloatArray, dt: float) -> FloatArray:
    """Body twists (N, 3) that drive pose k exactly to pose k+1 in ``dt`` seconds.

    Args:
        poses: (N+1, 3) world poses with continuous heading [m, m, rad].
        dt: tick length [s].
    """
    delta = poses[1:] - poses[:-1]
    heading = poses[:-1, 2]
    c, s = np.cos(heading), np.sin(heading)
    forward = c * delta[:, 0] + s * delta[:, 1]  # displacement in the body frame of pose k
    left = -s * delta[:, 0] + c * delta[:, 1]
    angle = delta[:, 2]
    half = 0.5 * angle
    small = np.abs(angle) < _SMALL_ANGLE
    # (a/2) cot(a/2), with its series 1 - a^2/12 near zero.
    safe = np.where(small, 1.0, half)
    diag = np.where(small, 1.0 - angle**2 / 12.0, safe / np.tan(safe))
    twists = np.empty((len(delta), 3))
    twists[:, 0] = (diag * forward + half * left) / dt
    twists[:, 1] = (-half * forward + diag * left) / dt
    twists[:, 2] = angle / dt
    return twists


class ReferenceWindow:
    """Samples a trajectory over the horizon; preallocated for the control loop."""

    def __init__(self, trajectory: Trajectory, horizon: int, dt: float) -> None:
        self.trajectory = trajectory
        self.offsets = dt * np.arange(horizon + 1)
        self.dt = dt

    def at(self, time: float, heading: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The window from ``time`` [s]: poses (N+1, 3), feedforward (N, 3), directions (N+1, 2).

        The reference heading is shifted by a multiple of 2 pi so that its
        first value lies within pi of ``heading`` (the robot's), which makes
        the quadratic heading cost measure the wrapped error. A direction is
        the reference's world velocity over ``sqrt(|v|^2 + DIRECTION_SPEED^2)``:
        the unit direction of travel, fading to zero when the reference stops.
        """
        sample = self.trajectory.sample(time + self.offsets)
        poses = sample.pose
        turns = math.floor((poses[0, 2] - heading) / (2.0 * math.pi) + 0.5)
        if turns:
            poses = poses.copy()
            poses[:, 2] -= 2.0 * math.pi * turns
        velocity = sample.velocity[:, :2]
        scale = np.sqrt((velocity * velocity).sum(axis=1) + DIRECTION_SPEED**2)
        return poses, feedforward_twists(poses, self.dt), velocity / scale[:, None]
