"""Boundary checks shared by the trajectory modules (private)."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
import numpy.typing as npt

from mpc.validation import as_float, has_bool
from mpc.validation import shown as _shown

from .errors import TrajectoryError

FloatArray = npt.NDArray[np.float64]


def as_times(t: npt.ArrayLike) -> FloatArray:
    """Times [s] as a float64 array of any shape (0-d for a scalar), all finite: booleans
    and strings (numeric ones too) are refused, not converted."""
    if type(t) is np.ndarray and t.dtype == np.float64:  # the controller's own, every tick
        times = t.copy()
    else:
        times = _converted_times(t)
    # A finite sum means every entry is finite (a huge sum that overflows is checked again).
    if not math.isfinite(float(times.sum())) and not np.isfinite(times).all():
        if times.ndim == 0:
            raise TrajectoryError(
                f"t must be a finite number or an array of finite numbers [s], got {shown(t)}"
            )
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(times))[0])
        raise TrajectoryError(
            "t must be a finite number or an array of finite numbers [s], got an array of "
            f"shape {times.shape} with t[{', '.join(map(str, bad))}]={float(times[bad])!r}"
        )
    return times


def _converted_times(t: npt.ArrayLike) -> FloatArray:
    """``t`` as a float64 array (a copy), booleans and strings refused."""
    try:
        raw = np.asarray(t)
        if raw.dtype.kind not in "iuf" or has_bool(t):
            raise TypeError("not real numbers")
        times = raw.astype(np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError) as error:
        raise TrajectoryError(
            f"t must be a finite number or an array of finite numbers [s], got {shown(t)}"
        ) from error
    return times


def shown(value: Any) -> str:
    """One-line repr of a value for a message (NumPy scalars as plain Python numbers, huge
    integers by their number of digits): :func:`mpc.validation.shown`."""
    return _shown(value)


def is_real_scalar(value: Any) -> bool:
    """True for a real number (not a bool), including 0-d numeric arrays."""
    if isinstance(value, bool):
        return False
    if isinstance(value, numbers.Real):
        return True
    return isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"


def finite_number(name: str, value: Any) -> float:
    """``value`` as a float, or TrajectoryError if it is not a finite real number."""
    if not is_real_scalar(value) or not math.isfinite(as_float(value)):
        raise TrajectoryError(f"{name} must be a finite number, got {shown(value)}")
    return as_float(value)


def positive_number(name: str, value: Any) -> float:
    """``value`` as a float, or TrajectoryError if it is not finite and > 0."""
    if not is_real_scalar(value) or not (math.isfinite(as_float(value))
                                         and as_float(value) > 0.0):
        raise TrajectoryError(f"{name} must be a finite number > 0, got {shown(value)}")
    return as_float(value)


def non_negative_number(name: str, value: Any) -> float:
    """``value`` as a float, or TrajectoryError if it is not finite and >= 0."""
    if not is_real_scalar(value) or not (math.isfinite(as_float(value))
                                         and as_float(value) >= 0.0):
        raise TrajectoryError(f"{name} must be a finite number >= 0, got {shown(value)}")
    return as_float(value)


def point2(name: str, value: Any) -> FloatArray:
    """A read-only float array of shape (2,) with finite entries."""
    try:
        if has_bool(value) or np.asarray(value).dtype.kind not in "iuf":
            raise TypeError("not real numbers")
        point = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError) as error:
        raise TrajectoryError(
            f"{name} must be 2 finite numbers (x, y) [m], got {shown(value)}"
        ) from error
    if point.shape != (2,) or not np.isfinite(point).all():
        raise TrajectoryError(
            f"{name} must be 2 finite numbers (x, y) [m], got {shown(value)} (shape {point.shape})"
        )
    point.flags.writeable = False
    return point


def first_overflow(table: FloatArray) -> int | None:
    """Index of the first piece (axis 0) of a piecewise polynomial's coefficient table with a
    non-finite coefficient, None if all are finite."""
    bad = ~np.isfinite(table.reshape(table.shape[0], -1)).all(axis=1)
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def samples_in(value: Any, low: int, high: int, what: str) -> int:
    """``samples`` as an int in ``[low, high]`` (``high`` a bound of this library, ``what``
    says what they count), or TrajectoryError."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not (
        low <= value <= high
    ):
        raise TrajectoryError(f"samples must be an integer from {low} to {high} ({what}; the "
                              f"upper one a bound of this library), got {shown(value)}")
    return int(value)
