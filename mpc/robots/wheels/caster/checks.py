"""Checking a caster vehicle's description and joint vectors: values given as one number or
one per caster, the steer axes' positions, and contacts that never meet.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, readonly
from mpc.errors import MpcError, RobotError
from mpc.validation import MAX_COORDINATE, body_points, metres, real_array, within


def per_caster(name: str, value: object, count: int, unit: str) -> FloatArray:
    """Finite numbers > 0 given as one number or one per caster, returned as (count,);
    lengths (``unit`` "[m]") within [MIN_LENGTH, MAX_LENGTH]."""
    array = real_array(name, value, f"a number or {count} numbers {unit}", RobotError)
    if array.shape == ():
        array = np.full(count, float(array))
    if array.shape != (count,):
        raise RobotError(f"{name} must be a number or {count} numbers (one per caster) {unit}, "
                         f"got shape {array.shape}")
    if not np.all(np.isfinite(array)) or np.any(array <= 0.0):
        raise RobotError(f"{name} must be finite numbers > 0 {unit}, got {array.tolist()}")
    if unit == "[m]":
        for index, size in enumerate(array.tolist()):
            metres(f"{name}[{index}]", size, RobotError)
    return readonly(array)


def check_positions(value: object) -> FloatArray:
    """The steer axes as a finite (n, 2) float array [m], n >= 2, or RobotError."""
    return body_points("positions", value, "casters", RobotError)


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
    """One number per caster as an (n,) float array, finite and within
    +-:data:`~mpc.validation.MAX_COORDINATE`, or ``error``."""
    array = real_array(name, value, f"{n} numbers {unit}", error)
    if array.shape != (n,):
        raise error(f"{name} must have shape ({n},) {unit}, one per caster, "
                    f"got shape {array.shape}")
    return within(name, array, MAX_COORDINATE, unit, error)
