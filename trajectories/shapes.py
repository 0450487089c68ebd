"""Closed periodic paths used by the benchmarks: a circle and a figure-eight."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from mpc.validation import checked_constructor, shown

from ._validation import FloatArray, finite_number, point2, positive_number
from .base import Trajectory
from .errors import TrajectoryError
from .heading import HeadingSpec
from .path import PathDerivatives


class _SinusoidPath:
    """x and y as sinusoids of time, with all four derivatives in one vectorised pass.

    Coordinate i is ``center_i + amplitude_i * sin(rate_i * t + phase_i)``, so
    its k-th derivative is ``amplitude_i * rate_i^k * sin(rate_i * t + phase_i + k pi/2)``.
    """

    def __init__(
        self, rates: FloatArray, phases: FloatArray, amplitudes: FloatArray, center: FloatArray
    ) -> None:
        order = np.arange(4.0)[:, np.newaxis]
        self._rates = np.broadcast_to(rates, (4, 2)).copy()  # [rad/s]
        self._phases = phases + order * (0.5 * math.pi)  # [rad]
        with np.errstate(over="ignore"):  # a gain that overflows is named when sampled
            self._gains = amplitudes * rates**order  # [m/s^k]
        self._offsets = np.zeros((4, 2))
        self._offsets[0] = center

    def __call__(self, t: FloatArray) -> PathDerivatives:
        derivatives = np.multiply.outer(t, self._rates)  # t.shape + (4, 2)
        derivatives += self._phases
        np.sin(derivatives, out=derivatives)
        derivatives *= self._gains
        derivatives += self._offsets
        return PathDerivatives(
            derivatives[..., 0, :],
            derivatives[..., 1, :],
            derivatives[..., 2, :],
            derivatives[..., 3, :],
        )


@checked_constructor(TrajectoryError)
class Circle(Trajectory):
    """Counter-clockwise circle, periodic.

    p(t) = center + radius * (cos(w t + phase), sin(w t + phase)), w = 2 pi / period,
    with radius [m], period [s], center (x, y) [m], phase [rad]. Path speed is
    constant, radius * w [m/s]. ``heading`` is any form :func:`make_heading`
    accepts (default: fixed at 0 rad).
    """

    def __init__(
        self,
        radius: float,
        period: float,
        center: npt.ArrayLike = (0.0, 0.0),
        heading: HeadingSpec = 0.0,
        phase: float = 0.0,
    ) -> None:
        self._radius = positive_number("radius [m]", radius)
        self._period = positive_number("period [s]", period)
        self._center = point2("center", center)
        self._phase = finite_number("phase [rad]", phase)
        self._omega = 2.0 * math.pi / self._period
        # x = R sin(w t + phase + pi/2), y = R sin(w t + phase)
        self._sinusoids = _SinusoidPath(
            np.array([self._omega, self._omega]),
            np.array([self._phase + 0.5 * math.pi, self._phase]),
            np.array([self._radius, self._radius]),
            self._center,
        )
        super().__init__(heading)

    @classmethod
    def with_speed(cls, size: float, speed: float, **kwargs: Any) -> Circle:
        """A circle of radius ``size`` [m] driven at path speed ``speed`` [m/s].

        period = 2 pi size / speed; ``kwargs`` are passed to the constructor.
        """
        radius = positive_number("radius [m]", size)
        speed = positive_number("speed [m/s]", speed)
        return cls(radius, 2.0 * math.pi * radius / speed, **kwargs)

    @property
    def radius(self) -> float:
        """Radius [m]."""
        return self._radius

    @property
    def center(self) -> FloatArray:
        """Centre (x, y) [m], read-only."""
        return self._center

    @property
    def phase(self) -> float:
        """Angle of the start point on the circle [rad]."""
        return self._phase

    @property
    def period(self) -> float:
        """Time for one turn [s]."""
        return self._period

    @property
    def max_speed(self) -> float:
        """Peak path speed [m/s] (constant on a circle): radius * 2 pi / period."""
        return self._radius * self._omega

    def _path(self, t: FloatArray) -> PathDerivatives:
        return self._sinusoids(t)

    def __repr__(self) -> str:
        return (
            f"Circle(radius={self._radius!r}, period={self._period!r}, "
            f"center={tuple(self._center.tolist())!r}, heading={self.heading!r}, "
            f"phase={self._phase!r})"
        )


@checked_constructor(TrajectoryError)
class FigureEight(Trajectory):
    """Figure-eight (lemniscate of Gerono), periodic.

    p(t) = center + (a sin(w t), a sin(w t) cos(w t)), w = 2 pi / period, with
    amplitude a [m] (half the width; the height is a), period [s]. Starts at
    the centre crossing heading along (1, 1)/sqrt(2); peak path speed is
    sqrt(2) a w [m/s], reached at the crossing.
    """

    def __init__(
        self,
        amplitude: float,
        period: float,
        center: npt.ArrayLike = (0.0, 0.0),
        heading: HeadingSpec = 0.0,
    ) -> None:
        self._amplitude = positive_number("amplitude [m]", amplitude)
        self._period = positive_number("period [s]", period)
        self._center = point2("center", center)
        self._omega = 2.0 * math.pi / self._period
        # x = a sin(w t), y = a sin(w t) cos(w t) = (a/2) sin(2 w t)
        self._sinusoids = _SinusoidPath(
            np.array([self._omega, 2.0 * self._omega]),
            np.zeros(2),
            np.array([self._amplitude, 0.5 * self._amplitude]),
            self._center,
        )
        super().__init__(heading)

    @classmethod
    def with_speed(cls, size: float, speed: float, **kwargs: Any) -> FigureEight:
        """A figure-eight of amplitude ``size`` [m] with peak path speed ``speed`` [m/s].

        |v|^2 = a^2 w^2 (cos^2(w t) + cos^2(2 w t)) peaks at 2 a^2 w^2 (t = 0), so
        period = 2 pi sqrt(2) size / speed; ``kwargs`` are passed to the constructor.
        """
        amplitude = positive_number("amplitude [m]", size)
        speed = positive_number("speed [m/s]", speed)
        return cls(amplitude, 2.0 * math.pi * math.sqrt(2.0) * amplitude / speed, **kwargs)

    @property
    def amplitude(self) -> float:
        """Amplitude a [m]."""
        return self._amplitude

    @property
    def center(self) -> FloatArray:
        """Centre (x, y) [m], read-only."""
        return self._center

    @property
    def period(self) -> float:
        """Time for one full figure-eight [s]."""
        return self._period

    @property
    def max_speed(self) -> float:
        """Peak path speed [m/s]: sqrt(2) * amplitude * 2 pi / period."""
        return math.sqrt(2.0) * self._amplitude * self._omega

    def _path(self, t: FloatArray) -> PathDerivatives:
        return self._sinusoids(t)

    def __repr__(self) -> str:
        return (
            f"FigureEight(amplitude={self._amplitude!r}, period={self._period!r}, "
            f"center={tuple(self._center.tolist())!r}, heading={self.heading!r})"
        )


@checked_constructor(TrajectoryError)
class OutAndBack(Trajectory):
    """Out along x and back, periodic: a flat ellipse, or a straight line for width 0.

    p(t) = center + (length / 2 * sin(w t), width / 2 * (1 - cos(w t))), w = 2 pi / period:
    from ``center`` out along +x to ``length / 2``, back ``width`` [m] to the left (+y),
    past the centre to ``-length / 2`` and back to the start. With ``width > 0`` the
    direction of travel turns through 180 degrees at each end (at the rate
    ``length / width * w`` [rad/s] there, the path speed down to ``width / 2 * w``): every
    caster of a powered-caster robot must swing round. With ``width = 0`` the robot stops
    at each end and reverses. ``heading`` as for :class:`Circle` (default fixed at 0).
    """

    def __init__(
        self,
        length: float,
        period: float,
        width: float = 0.0,
        center: npt.ArrayLike = (0.0, 0.0),
        heading: HeadingSpec = 0.0,
    ) -> None:
        self._length = positive_number("length [m]", length)
        self._period = positive_number("period [s]", period)
        self._width = finite_number("width [m]", width)
        if self._width < 0.0:
            raise TrajectoryError(f"width [m] must be >= 0, got {shown(width)}")
        self._center = point2("center", center)
        self._omega = 2.0 * math.pi / self._period
        # x = L/2 sin(w t), y = W/2 + W/2 sin(w t - pi/2)
        self._sinusoids = _SinusoidPath(
            np.array([self._omega, self._omega]),
            np.array([0.0, -0.5 * math.pi]),
            np.array([0.5 * self._length, 0.5 * self._width]),
            self._center + np.array([0.0, 0.5 * self._width]),
        )
        super().__init__(heading)

    @property
    def length(self) -> float:
        """Length of the run [m]."""
        return self._length

    @property
    def width(self) -> float:
        """Distance between the way out and the way back [m]."""
        return self._width

    @property
    def period(self) -> float:
        """Time for one out-and-back [s]."""
        return self._period

    def _path(self, t: FloatArray) -> PathDerivatives:
        return self._sinusoids(t)

    def __repr__(self) -> str:
        return (
            f"OutAndBack(length={self._length!r}, period={self._period!r}, "
            f"width={self._width!r}, center={tuple(self._center.tolist())!r}, "
            f"heading={self.heading!r})"
        )
