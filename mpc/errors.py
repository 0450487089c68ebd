"""The project's exceptions: a small typed hierarchy.

Every bad input raises a subclass of :class:`MpcInputError`, which is a
``ValueError``, so callers can catch either. Messages say what was expected
and what arrived.
"""

from __future__ import annotations

import math
import numbers


class MpcError(Exception):
    """Base class of every exception raised by :mod:`mpc`."""


class MpcInputError(MpcError, ValueError):
    """An argument has the wrong shape, type, value or name."""


class RobotError(MpcInputError):
    """A robot description is invalid (geometry, limits, file or preset)."""


class ControllerError(MpcInputError):
    """A controller option or a ``step()`` argument is invalid."""


class SolverFailedError(MpcError):
    """Raised only when a caller asks for an exception on solver failure."""


def is_integer(value: object) -> bool:
    """An integer (Python or NumPy), but not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def is_finite_number(value: object) -> bool:
    """A finite real number (Python or NumPy), but not a bool."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and math.isfinite(float(value)))
