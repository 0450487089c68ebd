"""Reference trajectories: a path (x, y) combined with a heading profile.

A :class:`Trajectory` gives, at times t [s], the reference pose, velocity and
acceleration in the world frame (REP-103: x forward, y left, yaw
counter-clockwise), and the reference body twist the controller tracks:

    (vx, vy) = R(theta)^T @ (xdot, ydot),  omega = thetadot,
    R(theta) = [[cos theta, -sin theta], [sin theta, cos theta]].
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mpc.validation import MAX_COORDINATE

from ._validation import FloatArray, as_times, shown
from .errors import TrajectoryError
from .heading import HeadingProfile, HeadingSpec, make_heading
from .path import PathDerivatives


@dataclass(frozen=True, eq=False)
class TrajectorySample:
    """Reference state at some times, world frame, each array of shape (..., 3).

    ``pose`` = (x, y, theta) [m, m, rad], ``velocity`` = (xdot, ydot, thetadot)
    [m/s, m/s, rad/s], ``acceleration`` = (xddot, yddot, thetaddot)
    [m/s^2, m/s^2, rad/s^2]. theta is continuous (unwrapped), never wrapped
    into (-pi, pi]. The leading shape is the shape of the times sampled.
    Compared by identity (the fields are arrays).
    """

    pose: FloatArray
    velocity: FloatArray
    acceleration: FloatArray


def body_twist(sample: TrajectorySample) -> FloatArray:
    """Reference body twist (vx, vy, omega) [m/s, m/s, rad/s] of a sample, shape (..., 3).

    (vx, vy) = R(theta)^T @ (xdot, ydot) and omega = thetadot, where theta and
    the world velocity come from ``sample``. Vectorised over the leading shape.
    """
    if not hasattr(sample, "pose") or not hasattr(sample, "velocity"):
        raise TrajectoryError(
            "sample must be a TrajectorySample (with pose and velocity), got "
            f"{shown(sample)}"
        )
    pose = np.asarray(sample.pose)
    velocity = np.asarray(sample.velocity)
    if pose.shape != velocity.shape or pose.shape[-1:] != (3,):
        raise TrajectoryError(
            "sample pose and velocity must have the same shape (..., 3), got "
            f"{pose.shape} and {velocity.shape}"
        )
    theta = pose[..., 2]
    cos, sin = np.cos(theta), np.sin(theta)
    xdot, ydot = velocity[..., 0], velocity[..., 1]
    twist = np.empty(velocity.shape)
    twist[..., 0] = cos * xdot + sin * ydot
    twist[..., 1] = cos * ydot - sin * xdot
    twist[..., 2] = velocity[..., 2]
    return twist


class Trajectory(abc.ABC):
    """A reference trajectory: a path from :meth:`_path` plus a heading profile.

    Subclasses implement :meth:`_path` and the time properties, and call
    ``super().__init__(heading)`` last in their constructor (binding the
    heading may sample the path). A finite trajectory (``end_time`` not None)
    holds its end poses outside [start_time, end_time]: pose clamped, all
    velocities and accelerations zero, heading profile evaluated at the
    clamped time.
    """

    def __init__(self, heading: HeadingSpec) -> None:
        self._heading = make_heading(heading).bind(self)

    @property
    def heading(self) -> HeadingProfile:
        """The heading profile, bound to this trajectory."""
        return self._heading

    @property
    def period(self) -> float | None:
        """Period [s], or None if the trajectory is not periodic."""
        return None

    @property
    def start_time(self) -> float:
        """Time [s] at which the trajectory starts (0 unless a subclass says otherwise)."""
        return 0.0

    @property
    def end_time(self) -> float | None:
        """Time [s] after which the end pose is held, or None for an infinite trajectory."""
        return None

    @property
    def duration(self) -> float | None:
        """end_time - start_time [s], or None for an infinite trajectory."""
        end = self.end_time
        return None if end is None else end - self.start_time

    @abc.abstractmethod
    def _path(self, t: FloatArray) -> PathDerivatives:
        """Path derivatives at validated times ``t`` (finite; inside the span if finite)."""

    def path(self, t: npt.ArrayLike) -> PathDerivatives:
        """Path (x, y) [m] and its first three derivatives at times t [s], each (..., 2)."""
        return self._held_path(as_times(t))[1]

    def _held_path(
        self, times: FloatArray
    ) -> tuple[FloatArray, PathDerivatives, npt.NDArray[np.bool_] | None]:
        """(times clamped to the span, path there held outside it, mask of times outside)."""
        end = self.end_time
        if end is None:
            return times, self._path(times), None
        inside = np.minimum(np.maximum(times, self.start_time), end)
        path = self._path(inside)
        outside = inside != times
        if not outside.any():
            return inside, path, None
        still = outside[..., np.newaxis]
        held = PathDerivatives(
            path.position,
            np.where(still, 0.0, path.velocity),
            np.where(still, 0.0, path.acceleration),
            np.where(still, 0.0, path.jerk),
        )
        return inside, held, outside

    def sample(self, t: npt.ArrayLike) -> TrajectorySample:
        """Reference pose, velocity and acceleration at times t [s].

        ``t`` is a finite number or an array of any shape; the arrays of the
        result have shape ``t.shape + (3,)`` ((3,) for a scalar).
        """
        times = as_times(t)
        inside, path, outside = self._held_path(times)
        theta, rate, accel = self._heading.evaluate(inside, path)
        if outside is not None:
            rate = np.where(outside, 0.0, rate)
            accel = np.where(outside, 0.0, accel)
        # pose, velocity and acceleration: the leading slices of one array (fewer NumPy
        # calls; this runs every control tick), each slice contiguous.
        values = np.empty((3,) + times.shape + (3,))
        planar, angular = values[..., :2], values[..., 2]
        planar[0], planar[1], planar[2] = path.position, path.velocity, path.acceleration
        angular[0], angular[1], angular[2] = theta, rate, accel
        pose, velocity, acceleration = values[0], values[1], values[2]
        # One sum is finite iff every entry is (and no sum overflows): a reference whose
        # numbers overflow (extreme sizes, waypoints 1e-300 s apart) fails here, named.
        if not math.isfinite(float(values.sum())):
            self._not_finite(times, pose, velocity, acceleration)
        if not float(np.abs(pose[..., :2]).max(initial=0.0)) <= MAX_COORDINATE:
            far = np.abs(pose[..., :2]).max(axis=-1) > MAX_COORDINATE
            where = float(np.broadcast_to(times, far.shape)[far].flat[0])
            raise TrajectoryError(
                f"{type(self).__name__} reference gives a position too large (beyond "
                f"+-{MAX_COORDINATE:g} m, a bound of this library) at t = {where!r} s")
        return TrajectorySample(pose, velocity, acceleration)

    def _not_finite(self, times: FloatArray, *arrays: FloatArray) -> None:
        """Raise the error for a sample that is not finite (or whose sum overflows)."""
        for name, array in zip(("pose", "velocity", "acceleration"), arrays, strict=True):
            bad = ~np.isfinite(array).all(axis=-1)
            if bad.any():
                where = float(np.broadcast_to(times, bad.shape)[bad].flat[0])
                raise TrajectoryError(
                    f"{type(self).__name__} reference gives a non-finite {name} at "
                    f"t = {where!r} s: its sizes or timing overflow double precision")
        raise TrajectoryError(f"{type(self).__name__} reference gives numbers too large to "
                              "add up (over 1e308): its sizes or timing overflow")

    def body_twist(self, t: npt.ArrayLike) -> FloatArray:
        """Reference body twist (vx, vy, omega) [m/s, m/s, rad/s] at times t, (..., 3)."""
        return body_twist(self.sample(t))
