"""The path part of a trajectory: positions and their time derivatives.

:class:`PathDerivatives` is what a path gives at some times, and
:class:`TimedPath` is what a heading profile may ask of the trajectory it
is bound to (both the base class and the heading profiles use this module,
which imports neither).
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

import numpy.typing as npt

from ._validation import FloatArray


class PathDerivatives(NamedTuple):
    """The path (x, y) and its first three time derivatives, each (..., 2), world frame."""

    position: FloatArray  # [m]
    velocity: FloatArray  # [m/s]
    acceleration: FloatArray  # [m/s^2]
    jerk: FloatArray  # [m/s^3]


class TimedPath(Protocol):
    """A path over time: what :meth:`HeadingProfile.bind` may use of a trajectory."""

    @property
    def period(self) -> float | None:
        """Period [s], or None if not periodic."""
        ...

    @property
    def start_time(self) -> float:
        """Start [s]."""
        ...

    @property
    def end_time(self) -> float | None:
        """End [s], or None for an infinite path."""
        ...

    def path(self, t: npt.ArrayLike) -> PathDerivatives:
        """Path (x, y) [m] and its first three derivatives at times t [s]."""
        ...
