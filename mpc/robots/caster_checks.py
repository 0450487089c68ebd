"""Checking a caster vehicle's description and joint vectors: values given as one number or
one per caster, the steer axes' positions, and contacts that never meet.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, readonly
from mpc.errors import MpcError, RobotError


def per_caster(name: str, value: object, count: int, unit: str) -> FloatArray:
    """Finite numbers > 0 given as one number or one per caster, returned as (count,)."""
    if isinstance(value, (bool, np.bool_)) or (
            isinstance(value, (list, tuple)) and any(isinstance(v, bool) for v in value)):
        raise RobotError(f"{name} must be a number or {count} numbers {unit}, got {value!r}")
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise RobotError(f"{name} must be a number or {count} numbers {unit}, "
                         f"got {value!r}") from None
    if array.shape == ():
        array = np.full(count, float(array))
    if array.shape != (count,):
        raise RobotError(f"{name} must be a number or {count} numbers (one per caster) {unit}, "
                         f"got shape {array.shape}")
    if not np.all(np.isfinite(array)) or np.any(array <= 0.0):
        raise RobotError(f"{name} must be finite numbers > 0 {unit}, got {array.tolist()}")
    return readonly(array)


def check_positions(value: object) -> FloatArray:
    """The steer axes as a finite (n, 2) float array [m], n >= 2, or RobotError."""
    try:
        if isinstance(value, (bool, np.bool_)):
            raise TypeError
        positions = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise RobotError("positions must be an (n, 2) array of numbers [m], "
                         f"got {value!r}") from None
    if positions.ndim != 2 or positions.shape[1] != 2 or positions.shape[0] < 2:
        raise RobotError("positions must have shape (n, 2) with n >= 2 casters, "
                         f"got shape {positions.shape}")
    if not np.all(np.isfinite(positions)):
        raise RobotError(f"positions must be finite, got {positions.tolist()}")
    return positions


def check_distinct_contacts(positions: FloatArray, offset: FloatArray) -> None:
    """RobotError unless every two axes are farther apart than the sum of their offsets
    (their contacts then never meet, at any steer angles)."""
    gap = np.hypot(*(positions[:, None, :] - positions[None, :, :]).transpose(2, 0, 1))
    reach = offset[:, None] + offset[None, :]
    close = np.argwhere(np.triu(gap <= reach, k=1))
    if close.size:
        i, j = (int(v) for v in close[0])
        raise RobotError(
            f"casters {i} and {j} must have distinct contact points at every steer angle: "
            f"their axes are {gap[i, j]:.6g} m apart, at most offset[{i}] + offset[{j}] = "
            f"{reach[i, j]:.6g} m")


def joint_vector(name: str, value: ArrayLike, n: int, unit: str,
                 error: type[MpcError] = RobotError) -> FloatArray:
    """One finite number per caster as an (n,) float array, or ``error``."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{name} must be {n} numbers {unit}, got {value!r}") from None
    if array.shape != (n,):
        raise error(f"{name} must have shape ({n},) {unit}, one per caster, "
                    f"got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise error(f"{name} must be finite, got {array.tolist()}")
    return array
