"""Checks for arguments at the library's front door (constructors, ``step()``).

Each check raises the error type its caller passes, with a message that names
the argument and says what was expected and what arrived.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import MpcError


def is_integer(value: object) -> bool:
    """An integer (Python or NumPy), but not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def is_finite_number(value: object) -> bool:
    """A finite real number (Python or NumPy), but not a bool."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and math.isfinite(float(value)))


def finite(name: str, value: object, error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a finite real number."""
    if not is_finite_number(value):
        raise error(f"{name} must be a finite number, got {value!r}")
    return float(value)  # type: ignore[arg-type]


def positive(name: str, value: object, error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a finite real number > 0."""
    if not is_finite_number(value) or float(value) <= 0.0:  # type: ignore[arg-type]
        raise error(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)  # type: ignore[arg-type]


def non_negative(name: str, value: object, error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a finite real number >= 0."""
    if not is_finite_number(value) or float(value) < 0.0:  # type: ignore[arg-type]
        raise error(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)  # type: ignore[arg-type]


def integer_at_least(name: str, value: object, low: int,
                     error: type[MpcError] = MpcError) -> int:
    """``value`` as an int, or ``error`` unless it is an integer >= ``low`` (bools refused)."""
    if not is_integer(value) or int(value) < low:  # type: ignore[call-overload]
        raise error(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)  # type: ignore[call-overload]


def flag(name: str, value: object, error: type[MpcError] = MpcError) -> bool:
    """``value`` if it is a bool (NumPy bools too), else ``error``: no truthy strings."""
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{name} must be True or False, got {value!r}")
    return bool(value)


def finite_vector(name: str, value: ArrayLike, length: int, what: str,
                  error: type[MpcError] = MpcError) -> FloatArray:
    """A float array of shape ``(length,)`` with finite entries (``what`` names them)."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{name} must be {length} numbers {what}, got {value!r}") from None
    if array.shape != (length,):
        raise error(f"{name} must have shape ({length},) as {what}, got shape {array.shape}")
    if not math.isfinite(float(np.abs(array).max(initial=0.0))):
        raise error(f"{name} must be finite, got {array.tolist()}")
    return array
