"""Trajectories through timed samples of pose, velocity and acceleration, joined exactly.

Between samples k and k+1 each of x, y, theta is the quintic polynomial
that matches position, velocity and acceleration at both samples (quintic Hermite), so
the reference is C2 and exact at every sample. Choreo's optimiser holds the acceleration
of sample k over the interval (x_k+1 = x_k + v_k h + a_k h^2 / 2); on such samples the
quintic differs from that piecewise-quadratic motion by ``(a_k+1 - a_k) h^2 s^3 (1 - s)^2
/ 2`` (s = tau / h), at most 0.0173 |a_k+1 - a_k| h^2 (4e-5 m for 1 m/s^2 at h = 0.05 s),
and unlike it has continuous accelerations. The sampled theta may be wrapped: each
step is taken within pi of the trapezoidal prediction (omega_k + omega_k+1) h / 2.

Without accelerations (e.g. odometry: pose and twist) each interval is the cubic Hermite
polynomial matching position and velocity at both ends (C1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.interpolate import BPoly, PPoly

from mpc.validation import MAX_COORDINATE, MAX_TIME, real_array, within

from ._validation import FloatArray, first_overflow, shown
from .base import Trajectory
from .errors import TrajectoryError
from .heading import HeadingDerivatives, HeadingProfile, HeadingSpec
from .path import PathDerivatives


class _Pieces:
    """Piecewise polynomials (scipy ``PPoly`` layout) and derivatives 0..3, evaluated at once."""

    def __init__(self, polynomial: PPoly) -> None:
        breaks = np.asarray(polynomial.x, dtype=np.float64)
        ascending = np.asarray(polynomial.c, dtype=np.float64)[::-1]  # (k, pieces, m): tau^p
        count, pieces, width = ascending.shape
        table = np.zeros((pieces, count, 4, width))
        for order in range(4):
            for power in range(count - order):
                factor = math.factorial(power + order) // math.factorial(power)
                table[:, power, order, :] = factor * ascending[power + order]
        self._count, self._width = count, width
        self._starts, self._interior = breaks[:-1], breaks[1:-1]
        self._table = table.reshape(pieces, count, 4 * width)

    def first_overflow(self) -> int | None:
        """Index of the first piece with a non-finite coefficient, None if all are finite."""
        return first_overflow(self._table)

    def evaluate(self, t: FloatArray) -> FloatArray:
        """Values and derivatives 0..3 at times t: shape t.shape + (4, m) (Horner's rule)."""
        index = np.searchsorted(self._interior, t, side="right")
        tau = (t - self._starts[index])[..., np.newaxis]
        rows = self._table.take(index, axis=0)
        value = rows[..., self._count - 1, :].copy()
        for power in range(self._count - 2, -1, -1):
            value *= tau
            value += rows[..., power, :]
        return value.reshape(np.shape(t) + (4, self._width))


@dataclass(frozen=True, repr=False)
class _SampledHeading(HeadingProfile):
    """theta from the samples' Hermite polynomial."""

    pieces: _Pieces

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """Polynomial value, first and second derivative."""
        d = self.pieces.evaluate(t)
        return HeadingDerivatives(d[..., 0, 2], d[..., 1, 2], d[..., 2, 2])

    def __repr__(self) -> str:
        return "SampledHeading()"


class SampledTrajectory(Trajectory):
    """Timed samples of pose, velocity and optionally acceleration, joined exactly.

    With ``accelerations`` every interval is the quintic Hermite polynomial matching pose,
    velocity and acceleration at both ends (C2); without, the cubic Hermite matching pose
    and velocity (C1). theta is unwrapped as in the module docstring. ``heading=None``
    keeps the sampled theta; any heading spec (:func:`~trajectories.make_heading`)
    replaces it. Outside [times[0], times[-1]] the end pose is held. Not periodic.

    Args:
        times: (n,) strictly increasing, n >= 2 [s].
        poses: (n, 3) rows (x, y, theta) [m, m, rad], world frame.
        velocities: (n, 3) world (xdot, ydot, thetadot) [m/s, m/s, rad/s].
        accelerations: (n, 3) world [m/s^2, m/s^2, rad/s^2] or None.
    """

    def __init__(self, times: npt.ArrayLike, poses: npt.ArrayLike, velocities: npt.ArrayLike,
                 accelerations: npt.ArrayLike | None = None,
                 heading: HeadingSpec | None = None) -> None:
        t = within("times", _array("times", times, None), MAX_TIME, "[s]", TrajectoryError)
        if t.ndim != 1 or t.size < 2 or not (np.diff(t) > 0.0).all():
            raise TrajectoryError(f"times must be 1-D, at least 2, strictly increasing [s], "
                                  f"got {shown(t)}")
        arrays = [_array(name, value, (t.size, 3)) for name, value in
                  (("poses", poses), ("velocities", velocities), ("accelerations",
                   accelerations)) if value is not None]
        within("poses", arrays[0], MAX_COORDINATE, "(m, m, rad)", TrajectoryError)
        arrays[0][:, 2] = _unwrapped(t, arrays[0][:, 2], arrays[1][:, 2])
        for array in arrays:
            array.flags.writeable = False
        t.flags.writeable = False
        self._times, self._samples = t, tuple(arrays)
        with np.errstate(all="ignore"):  # overflow is checked below
            self._pieces = _Pieces(PPoly.from_bernstein_basis(
                BPoly.from_derivatives(t, np.stack(arrays, axis=1))))
        bad = self._pieces.first_overflow()
        if bad is not None:
            raise TrajectoryError(
                "sample times are too close together for the motion between them: the "
                f"polynomial overflows double precision near times[{bad}]={float(t[bad])!r}")
        super().__init__(_SampledHeading(self._pieces) if heading is None else heading)

    @property
    def times(self) -> FloatArray:
        """Sample times (n,) [s], read-only."""
        return self._times

    @property
    def poses(self) -> FloatArray:
        """Sample poses (n, 3) [m, m, rad], theta unwrapped, read-only."""
        return self._samples[0]

    @property
    def velocities(self) -> FloatArray:
        """Sample world velocities (n, 3) [m/s, m/s, rad/s], read-only."""
        return self._samples[1]

    @property
    def accelerations(self) -> FloatArray | None:
        """Sample world accelerations (n, 3) [m/s^2, m/s^2, rad/s^2] or None, read-only."""
        return self._samples[2] if len(self._samples) > 2 else None

    @property
    def start_time(self) -> float:
        return float(self._times[0])

    @property
    def end_time(self) -> float:
        return float(self._times[-1])

    def _path(self, t: FloatArray) -> PathDerivatives:
        d = self._pieces.evaluate(t)[..., :2]
        return PathDerivatives(d[..., 0, :], d[..., 1, :], d[..., 2, :], d[..., 3, :])

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(<{self._times.size} samples, t in "
                f"[{self.start_time!r}, {self.end_time!r}] s>, heading={self.heading!r})")


def _array(name: str, value: npt.ArrayLike, shape: tuple[int, int] | None) -> FloatArray:
    array = real_array(name, value, "an array of numbers", TrajectoryError)
    if shape is not None and array.shape != shape:
        raise TrajectoryError(f"{name} must have shape {shape}, got {array.shape}")
    if not np.isfinite(array).all():
        raise TrajectoryError(f"{name} must be finite, got {shown(array)}")
    return array


def _unwrapped(t: FloatArray, theta: FloatArray, rate: FloatArray) -> FloatArray:
    """theta with each step within pi of the trapezoidal prediction from the rates."""
    predicted = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t)
    surprise = np.diff(theta) - predicted
    surprise -= 2.0 * math.pi * np.round(surprise / (2.0 * math.pi))
    return theta[0] + np.concatenate(([0.0], np.cumsum(predicted + surprise)))
