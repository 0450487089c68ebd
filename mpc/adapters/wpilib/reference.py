"""A WPILib ``Trajectory`` as our reference, reproducing its ``sample(t)`` exactly."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from wpimath.trajectory import Trajectory as WpilibTrajectory

from mpc.adapters.wpilib.conversions import pose_from_pose2d
from mpc.arrays import FloatArray, IntArray
from mpc.errors import TrajectoryError
from mpc.validation import shown
from trajectories import HeadingDerivatives, HeadingProfile, HeadingSpec, Trajectory
from trajectories.path import PathDerivatives


class WpilibReference(Trajectory):
    """A WPILib ``Trajectory`` as our reference, reproducing its ``sample(t)`` exactly.

    Between states k and k+1 WPILib moves the distance ``s = v_k tau + a_k tau^2 / 2``
    (negated when reversing) and places the pose at the fraction ``f = s / chord_k`` of
    the straight step from pose k to pose k+1 (heading by the shortest turn). This is
    that curve; its velocity and acceleration are its exact time derivatives (jerk 0).
    WPILib's trajectories are for robots that face their direction of travel, so the
    heading is the poses' rotation unless ``heading`` (a heading spec, e.g. ``0.0``) says.
    Times are WPILib's: seconds since the trajectory's start. A step without translation
    holds its first pose (WPILib's ``sample`` divides by its zero length there).
    """

    def __init__(self, trajectory: WpilibTrajectory, heading: HeadingSpec | None = None) -> None:
        states = trajectory.states() if isinstance(trajectory, WpilibTrajectory) else []
        if len(states) < 2:
            raise TrajectoryError("expected a wpimath.trajectory.Trajectory with at least 2 "
                                  f"states, got {shown(trajectory)}")
        self._times = np.array([s.t for s in states])
        if np.any(np.diff(self._times) < 0.0):
            raise TrajectoryError("WPILib trajectory state times must not decrease")
        poses = np.array([pose_from_pose2d(s.pose) for s in states])
        poses[:, 2] = np.unwrap(poses[:, 2])
        self._poses = poses
        self._steps = np.diff(poses, axis=0)  # (n-1, 3): straight steps, shortest turns
        chord = np.hypot(self._steps[:, 0], self._steps[:, 1])
        self._per_metre = np.divide(1.0, chord, out=np.zeros_like(chord), where=chord > 0.0)
        speed, accel = np.array([[s.velocity, s.acceleration] for s in states]).T
        reversing = (speed < 0.0) | ((np.abs(speed) < 1e-9) & (accel < 0.0))
        sign = np.where(reversing, -1.0, 1.0)
        self._speed, self._accel = (sign * speed)[:-1], (sign * accel)[:-1]
        self._short = np.diff(self._times) < 1e-9  # WPILib returns the later state there
        super().__init__(_PoseHeading(self._pose_heading) if heading is None else heading)

    @property
    def start_time(self) -> float:
        return float(self._times[0])

    @property
    def end_time(self) -> float:
        return float(self._times[-1])

    def _fractions(self, t: FloatArray) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
        """(segment k, fraction f, df/dt [1/s], d2f/dt2 [1/s^2]) at times ``t`` in the span."""
        k = np.clip(np.searchsorted(self._times[1:], t, side="left"), 0, len(self._steps) - 1)
        tau = t - self._times[k]
        per_metre = np.where(self._short[k], 0.0, self._per_metre[k])
        f = (self._speed[k] * tau + 0.5 * self._accel[k] * tau * tau) * per_metre
        rate = (self._speed[k] + self._accel[k] * tau) * per_metre
        return k, np.where(self._short[k], 1.0, f), rate, self._accel[k] * per_metre

    def _path(self, t: FloatArray) -> PathDerivatives:
        k, f, rate, accel = self._fractions(t)
        step = self._steps[k, :2]
        return PathDerivatives(self._poses[k, :2] + f[..., None] * step, rate[..., None] * step,
                               accel[..., None] * step, np.zeros(step.shape))

    def _pose_heading(self, t: FloatArray) -> HeadingDerivatives:
        k, f, rate, accel = self._fractions(t)
        turn = self._steps[k, 2]
        return HeadingDerivatives(self._poses[k, 2] + f * turn, rate * turn, accel * turn)


@dataclass(frozen=True)
class _PoseHeading(HeadingProfile):
    """theta from the WPILib states' rotations, interpolated as WPILib does."""

    at: Callable[[FloatArray], HeadingDerivatives]

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        return self.at(t)


def reference_from_wpilib_trajectory(trajectory: WpilibTrajectory,
                                     heading: HeadingSpec | None = None) -> WpilibReference:
    """Our reference for a WPILib ``Trajectory`` (see :class:`WpilibReference`)."""
    return WpilibReference(trajectory, heading)
