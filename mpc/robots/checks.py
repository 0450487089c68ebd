"""Checks every drive layout shares: twists as callers pass them, and the rank of a wheel
Jacobian (a layout must drive every twist).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.validation import shown


def as_twists(twist: ArrayLike, name: str = "twist") -> FloatArray:
    """A float array of shape (3,) or (k, 3), checked finite."""
    try:
        array = np.asarray(twist, dtype=float)
    except (TypeError, ValueError):
        raise RobotError(f"{name} must be numbers (vx, vy, omega), got {shown(twist)}") from None
    if array.ndim not in (1, 2) or array.shape[-1] != 3:
        raise RobotError(
            f"{name} must have shape (3,) or (k, 3) as (vx, vy, omega), got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise RobotError(f"{name} must be finite, got {array}")
    return array


def check_holonomic(stacked_rows: FloatArray, what: str) -> None:
    """Raise RobotError unless the stacked wheel rows have rank 3 (and are finite)."""
    if not np.isfinite(stacked_rows).all():
        raise RobotError(f"{what}: its wheel Jacobian is not finite: its sizes overflow")
    singular = np.linalg.svd(stacked_rows, compute_uv=False)
    if singular.size < 3 or singular[2] <= 1e-9 * max(singular[0], 1e-300):
        raise RobotError(
            f"{what} is not holonomic: its wheel Jacobian has rank < 3 "
            f"(singular values {np.round(singular, 12).tolist()}); "
            "wheels that are all parallel or all at one point cannot drive every twist"
        )
