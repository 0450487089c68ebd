"""Heading profiles: how the heading theta(t) of a holonomic robot is chosen.

A holonomic robot's heading is independent of its path. A profile gives the
heading and its first two time derivatives, (theta, thetadot, thetaddot)
[rad, rad/s, rad/s^2], at times t [s], given the path's derivatives at those
times. Headings are continuous (unwrapped), never wrapped into (-pi, pi].

A trajectory calls :meth:`HeadingProfile.bind` once, at construction, so that
profiles needing the whole path (:class:`TangentHeading`) can precompute what
they need; the others return themselves.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from mpc.validation import real_array

from ._validation import FloatArray, finite_number, is_real_scalar, shown
from .errors import TrajectoryError
from .path import PathDerivatives, TimedPath
from .tangent_branch import MIN_TANGENT_SPEED, TWO_PI, TangentBranch, tangent_branch

__all__ = ["FINITE_DIFFERENCE_STEP", "MIN_TANGENT_SPEED", "SECOND_DIFFERENCE_STEP", "TWO_PI",
           "FixedHeading", "FunctionHeading", "HeadingDerivatives", "HeadingProfile",
           "HeadingSpec", "SpinHeading", "TangentHeading", "make_heading"]

_STILL_SPEED_SQUARED = 1e-24  # [m^2/s^2] at evaluation: fall back to the grid branch

FINITE_DIFFERENCE_STEP = 1e-5  # [s] central differences for a missing first derivative
SECOND_DIFFERENCE_STEP = 1e-4  # [s] central second difference of the angle


class HeadingDerivatives(NamedTuple):
    """Heading and its derivatives at some times, each of the times' shape."""

    angle: FloatArray  # theta [rad], continuous
    rate: FloatArray  # thetadot [rad/s]
    acceleration: FloatArray  # thetaddot [rad/s^2]


class HeadingProfile(abc.ABC):
    """How theta(t) is chosen; subclasses are frozen dataclasses."""

    def bind(self, trajectory: TimedPath) -> HeadingProfile:
        """The profile ready to evaluate along ``trajectory`` (default: itself)."""
        return self

    @abc.abstractmethod
    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """Heading, rate and acceleration at times ``t`` [s] (any shape).

        ``path`` holds the path's derivatives at the same times, each of shape
        ``t.shape + (2,)``. Results have shape ``t.shape``.
        """


@dataclass(frozen=True)
class FixedHeading(HeadingProfile):
    """theta(t) = angle [rad]: the robot keeps one orientation."""

    angle: float = 0.0  # [rad]

    def __post_init__(self) -> None:
        object.__setattr__(self, "angle", finite_number("FixedHeading angle [rad]", self.angle))

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """Constant angle, zero rate and acceleration."""
        return HeadingDerivatives(
            np.full(t.shape, self.angle), np.zeros(t.shape), np.zeros(t.shape)
        )


@dataclass(frozen=True)
class SpinHeading(HeadingProfile):
    """theta(t) = initial + rate * t: spinning at a constant rate while translating."""

    rate: float  # [rad/s], counter-clockwise positive
    initial: float = 0.0  # [rad] heading at t = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "rate", finite_number("SpinHeading rate [rad/s]", self.rate))
        object.__setattr__(
            self, "initial", finite_number("SpinHeading initial [rad]", self.initial)
        )

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """Linear angle, constant rate, zero acceleration."""
        return HeadingDerivatives(
            self.initial + self.rate * t, np.full(t.shape, self.rate), np.zeros(t.shape)
        )


@dataclass(frozen=True)
class FunctionHeading(HeadingProfile):
    """theta(t) given by user callables of t [s] (vectorised: array in, same shape out).

    ``angle(t)`` gives theta [rad], ``rate(t)`` thetadot [rad/s], ``accel(t)``
    thetaddot [rad/s^2]. A missing ``rate`` is the central difference
    ``(angle(t + h) - angle(t - h)) / (2 h)`` with ``h = 1e-5`` s. A missing
    ``accel`` is ``(rate(t + h) - rate(t - h)) / (2 h)``, ``h = 1e-5`` s, when
    ``rate`` is given, else ``(angle(t + h) - 2 angle(t) + angle(t - h)) / h^2``
    with ``h = 1e-4`` s.
    """

    angle: Callable[[FloatArray], npt.ArrayLike]
    rate: Callable[[FloatArray], npt.ArrayLike] | None = None
    accel: Callable[[FloatArray], npt.ArrayLike] | None = None

    def __post_init__(self) -> None:
        if not callable(self.angle):
            raise TrajectoryError(
                f"FunctionHeading angle must be a callable theta(t) [rad], got {shown(self.angle)}"
            )
        for name in ("rate", "accel"):
            function = getattr(self, name)
            if function is not None and not callable(function):
                raise TrajectoryError(
                    f"FunctionHeading {name} must be None or a callable of t, got {shown(function)}"
                )

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """The callables' values, missing derivatives by central differences."""
        h = FINITE_DIFFERENCE_STEP
        angle = _call(self.angle, t, "angle")
        if self.rate is not None:
            rate = _call(self.rate, t, "rate")
        else:
            rate = (_call(self.angle, t + h, "angle") - _call(self.angle, t - h, "angle")) / (
                2.0 * h
            )
        if self.accel is not None:
            accel = _call(self.accel, t, "accel")
        elif self.rate is not None:
            accel = (_call(self.rate, t + h, "rate") - _call(self.rate, t - h, "rate")) / (2.0 * h)
        else:
            h2 = SECOND_DIFFERENCE_STEP
            accel = (
                _call(self.angle, t + h2, "angle")
                - 2.0 * angle
                + _call(self.angle, t - h2, "angle")
            ) / (h2 * h2)
        return HeadingDerivatives(angle, rate, accel)


def _call(function: Callable[[FloatArray], npt.ArrayLike], t: FloatArray, name: str) -> FloatArray:
    try:
        result = function(t)
    except TypeError as error:
        if t.ndim == 0:  # a scalar time: the callable's own TypeError
            raise
        # math.sin and the like take one number: the times come as an array
        raise TrajectoryError(
            f"the heading function's {name}(t) must take an array of times [s] and return an "
            f"array of that shape (vectorised: np.sin, not math.sin); called with an array of "
            f"shape {t.shape} it raised TypeError: {error}") from None
    values = real_array(f"the heading function's {name}(t)", result,
                        "real numbers [rad, rad/s or rad/s^2]", TrajectoryError)
    if values.shape != t.shape:
        try:
            values = np.broadcast_to(values, t.shape)
        except ValueError as error:
            raise TrajectoryError(
                f"FunctionHeading {name}(t) must return an array of the shape of t {t.shape}, "
                f"got shape {values.shape}"
            ) from error
    if not np.isfinite(values).all():
        where = float(np.broadcast_to(t, values.shape)[~np.isfinite(values)][0])
        raise TrajectoryError(f"the heading function's {name}(t) returned a non-finite value "
                              f"at t = {where!r} s")
    return values


@dataclass(frozen=True)
class TangentHeading(HeadingProfile):
    """theta = atan2(ydot, xdot) + offset: the robot faces along its path.

    thetadot = (xdot*yddot - ydot*xddot) / |v|^2, and thetaddot is its exact
    derivative, using the path's jerk. The 2*pi branch is chosen so that theta
    is continuous in t across separate calls: at :meth:`bind` the tangent angle
    is unwrapped on a dense grid over one period (periodic paths; it then grows
    by the path's winding, e.g. 2*pi per turn of a circle) or over the
    trajectory's time span (finite paths), and each sample takes the branch
    nearest that grid. At t = 0 of a periodic path theta - offset lies in
    (-pi, pi].

    :meth:`bind` raises :class:`TrajectoryError` if the path speed is below
    1e-9 m/s anywhere on the grid. Exception: a finite path that starts or ends
    at rest (e.g. clamped waypoints) takes the limit direction of motion
    there, and where the speed is (numerically) zero the heading rate and
    acceleration are reported as 0.
    """

    offset: float = 0.0  # [rad] added to the tangent angle
    _branch: TangentBranch | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "offset", finite_number("TangentHeading offset [rad]", self.offset)
        )

    def bind(self, trajectory: TimedPath) -> TangentHeading:
        """A copy holding the unwrapped tangent angle of ``trajectory`` on a grid."""
        bound = TangentHeading(self.offset)
        object.__setattr__(bound, "_branch", tangent_branch(trajectory))
        return bound

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """Tangent angle plus offset on the continuous branch, exact rate and acceleration."""
        branch = self._branch
        if branch is None:
            raise TrajectoryError(
                "TangentHeading must be bound to a trajectory (bind(trajectory)) before use"
            )
        v, a, j = path.velocity, path.acceleration, path.jerk
        vx, vy = v[..., 0], v[..., 1]
        ax, ay = a[..., 0], a[..., 1]
        raw = np.arctan2(vy, vx)
        reference = branch.reference(t)
        # raw + 2 pi k, k chosen to land nearest the continuous reference
        angle = np.rint((reference - raw) * (1.0 / TWO_PI))
        angle *= TWO_PI
        angle += raw
        speed_squared = vx * vx + vy * vy
        cross_va = vx * ay - vy * ax
        dot_va = vx * ax + vy * ay
        cross_vj = vx * j[..., 1] - vy * j[..., 0]
        still = speed_squared < _STILL_SPEED_SQUARED
        if still.any():
            speed_squared = np.where(still, 1.0, speed_squared)
            angle = np.where(still, reference, angle)
            cross_va = np.where(still, 0.0, cross_va)
            cross_vj = np.where(still, 0.0, cross_vj)
        rate = cross_va / speed_squared
        accel = cross_vj / speed_squared - 2.0 * rate * dot_va / speed_squared
        return HeadingDerivatives(angle + self.offset, rate, accel)


HeadingSpec: TypeAlias = float | str | HeadingProfile | Callable[[FloatArray], npt.ArrayLike]
"""What ``heading=`` accepts: see :func:`make_heading`."""

_ACCEPTED_HEADINGS = (
    "heading must be a finite angle [rad] (fixed heading), the string 'fixed' (angle 0) "
    "or 'tangent', a HeadingProfile (FixedHeading, TangentHeading, SpinHeading, "
    "FunctionHeading) or a callable theta(t) [rad]"
)


def make_heading(spec: HeadingSpec) -> HeadingProfile:
    """The heading profile described by ``spec``.

    - a finite number: :class:`FixedHeading` at that angle [rad];
    - ``"fixed"``: ``FixedHeading(0.0)``; ``"tangent"``: ``TangentHeading()``;
    - a :class:`HeadingProfile`: itself;
    - any other callable: ``FunctionHeading(spec)`` (theta(t) [rad], vectorised).

    Anything else raises :class:`TrajectoryError` listing these forms.
    """
    if isinstance(spec, HeadingProfile):
        return spec
    if isinstance(spec, str):
        if spec == "tangent":
            return TangentHeading()
        if spec == "fixed":
            return FixedHeading()
        raise TrajectoryError(f"{_ACCEPTED_HEADINGS}, got the string {spec!r}")
    if is_real_scalar(spec):
        try:
            return FixedHeading(finite_number("heading", spec))
        except TrajectoryError:
            raise TrajectoryError(f"{_ACCEPTED_HEADINGS}, got {shown(spec)}") from None
    if callable(spec):
        return FunctionHeading(spec)
    raise TrajectoryError(f"{_ACCEPTED_HEADINGS}, got {shown(spec)} of type {type(spec).__name__}")
