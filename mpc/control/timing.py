"""Reference timing: which stretch of the reference each tick's plan tracks.

:class:`ReferenceWindow` samples the trajectory at ``time + rate * k dt``
(k = 0..N) straight into the tick's parameter views and evaluates the
model's reference terms there: the feedforward twist of stage ``k`` is the
constant body twist that drives the model exactly from reference pose ``k``
to ``k + 1`` in one tick (the SE(2) logarithm divided by ``dt``), so a robot
on the reference with the feedforward stays on it.

Two timing laws use it (both with one ``reset``):

- :class:`TimeIndexed`: stage 0 is the reference at ``t`` (plus the known
  delay): strict time tracking.
- :class:`TimeScaled`: where the reference window asks more than
  :data:`REFERENCE_MARGIN` of a wheel's limit, the reference is played
  slower (an internal time lags ``t``) so that the robot slows down on the
  path instead of cutting corners; it catches up when the reference allows.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray
from mpc.model.buffered import BufferedFunction
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from trajectories import Trajectory

#: With time scaling, the fraction of a wheel's limit the reference's own
#: feedforward may use; the rest is left for feedback.
REFERENCE_MARGIN = 0.9


class ReferenceWindow:
    """Samples a trajectory over the horizon into a :class:`~mpc.model.layout.TickInput`."""

    def __init__(self, trajectory: Trajectory, model: TrackingModel, tick: TickInput) -> None:
        self.trajectory = trajectory
        self.tick = tick
        self.offsets = model.dt * np.arange(model.horizon + 1)
        self._velocities = np.zeros((model.horizon + 1, 3))
        self._evaluate = BufferedFunction(model.reference_terms,
                                          [tick.poses_ref, self._velocities],
                                          [tick.twists_ref, tick.directions])

    def fill(self, time: float, heading: float, rate: float = 1.0) -> None:
        """Write the window from ``time`` [s] into the tick's reference views.

        ``rate`` < 1 plays the reference slower (stage k at ``time + rate k dt``).
        The reference heading is shifted by a multiple of 2 pi so that its
        first value lies within pi of ``heading`` (the robot's), which makes
        the quadratic heading cost measure the wrapped error.
        """
        sample = self.trajectory.sample(time + rate * self.offsets)
        poses = self.tick.poses_ref
        poses[:] = sample.pose
        turns = math.floor((poses[0, 2] - heading) / (2.0 * math.pi) + 0.5)
        if turns:
            poses[:, 2] -= 2.0 * math.pi * turns
        self._velocities[:] = sample.velocity
        self._evaluate()


class TimeIndexed:
    """Stage 0 is the reference at the planning time: strict time tracking."""

    def __init__(self, window: ReferenceWindow) -> None:
        self.window = window

    def reset(self) -> None:
        """Nothing to forget."""

    def fill(self, t: float, t_plan: float, heading: float) -> float:
        """Fill the tick's reference for planning time ``t_plan``; return the reference time."""
        self.window.fill(t_plan, heading)
        return t_plan


class TimeScaled:
    """The reference played slower where it asks more than the wheels can give.

    Args:
        window: the reference window.
        model: for the robot's wheel maps and limits, the horizon and ``dt``.
    """

    def __init__(self, window: ReferenceWindow, model: TrackingModel) -> None:
        self.window = window
        self.horizon, self.dt = model.horizon, model.dt
        robot = model.robot
        working = robot.max_wheel_speed > 0.0  # a failed wheel does not slow the reference
        self._blocks = robot.wheel_blocks[working].reshape(-1, 3)
        self._limits = robot.max_wheel_speed[working]
        self._wheel_dim = robot.wheel_dim
        self.reset()

    def reset(self) -> None:
        self.lag = 0.0  # [s] how far the reference time lags the planning time
        self._previous_t: float | None = None

    def fill(self, t: float, t_plan: float, heading: float) -> float:
        """Fill the tick's reference at the lagging time, played at a feasible rate."""
        elapsed = None if self._previous_t is None else t - self._previous_t
        self._previous_t = t
        if elapsed is None or not 0.0 < elapsed <= 2.0 * self.dt:
            self.lag = 0.0  # first tick, or the caller jumped in time: resynchronise
            elapsed = self.dt
        time_ref = t_plan - self.lag
        window = self.window
        window.fill(time_ref, heading)
        rate = min(self._room(window.tick.twists_ref),
                   1.0 + self.lag / (self.horizon * self.dt))  # catch up over a horizon
        if rate != 1.0:
            rate = max(rate, 0.0)
            window.fill(time_ref, heading, rate)
        self.lag = max(0.0, self.lag + (1.0 - rate) * elapsed)
        return time_ref

    def _room(self, feedforward: FloatArray) -> float:
        """How much faster than the window's own timing the wheels allow (inf at rest)."""
        velocity = (feedforward @ self._blocks.T).reshape(self.horizon, -1, self._wheel_dim)
        need = (np.sqrt((velocity * velocity).sum(axis=2)) / self._limits).max()
        return REFERENCE_MARGIN / need if need > 0.0 else math.inf
