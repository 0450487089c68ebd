"""The reference window a controller tracks over its horizon.

Each tick samples the trajectory at ``t + k dt`` (k = 0..N) and evaluates
the model's :attr:`~mpc.model.TrackingModel.reference_terms`: the
feedforward twist of stage ``k`` is the constant body twist that drives the
model exactly from reference pose ``k`` to ``k + 1`` in one tick (the SE(2)
logarithm divided by ``dt``). Unlike the trajectory's instantaneous body
twist it is consistent with the discrete dynamics, so a robot on the
reference with the feedforward stays on it, and the cost has no bias
towards cutting corners.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.model import BufferedFunction, TrackingModel
from mpc.robots.base import FloatArray
from trajectories import Trajectory


class ReferenceWindow:
    """Samples a trajectory over the horizon into preallocated arrays.

    The returned arrays are reused by the next call: copy what you keep.
    """

    def __init__(self, trajectory: Trajectory, model: TrackingModel) -> None:
        self.trajectory = trajectory
        n = model.horizon
        self.offsets = model.dt * np.arange(n + 1)
        self._poses = np.zeros((n + 1, 3))
        self._velocities = np.zeros((n + 1, 3))
        self._feedforward = np.zeros((n, 3))
        self._directions = np.zeros((n + 1, 2))
        self._evaluate = BufferedFunction(model.reference_terms,
                                          [self._poses, self._velocities],
                                          [self._feedforward, self._directions])

    def at(
        self, time: float, heading: float, rate: float = 1.0
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The window from ``time`` [s]: poses (N+1, 3), feedforward (N, 3), directions (N+1, 2).

        ``rate`` < 1 plays the reference slower (stage k at ``time + rate k dt``).
        The reference heading is shifted by a multiple of 2 pi so that its
        first value lies within pi of ``heading`` (the robot's), which makes
        the quadratic heading cost measure the wrapped error.
        """
        sample = self.trajectory.sample(time + rate * self.offsets)
        poses = self._poses
        poses[:] = sample.pose
        turns = math.floor((poses[0, 2] - heading) / (2.0 * math.pi) + 0.5)
        if turns:
            poses[:, 2] -= 2.0 * math.pi * turns
        self._velocities[:] = sample.velocity
        self._evaluate()
        return poses, self._feedforward, self._directions
