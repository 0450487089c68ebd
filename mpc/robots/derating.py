"""Per-wheel speed derating: factors in [0, 1] (0, or at least :data:`MIN_DERATING`) scaling
each wheel's speed limit (0: a failed wheel held at rest), checked, merged, and the projector
that keeps failed wheels at rest.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, readonly
from mpc.errors import RobotError
from mpc.validation import is_finite_number, is_integer, real_array, shown

#: Smallest derating factor above 0: a wheel's speed is computed from twists of the other
#: wheels' scale, so a limit far smaller reads their rounding (docs/design/min-derating.md).
MIN_DERATING = 1e-6


def check_derating(derating: object, n_wheels: int) -> tuple[float, ...]:
    """``derating`` as ``n_wheels`` floats in [0, 1], or RobotError."""
    factors = real_array("derating", derating, f"{n_wheels} numbers in [0, 1]", RobotError)
    if factors.shape != (n_wheels,) or not np.all(np.isfinite(factors)):
        raise RobotError(
            f"derating must be {n_wheels} finite factors, got {shown(derating)}"
        )
    if np.any(factors < 0.0) or np.any(factors > 1.0):
        raise RobotError(f"derating factors must lie in [0, 1], got {shown(derating)}")
    if np.any((factors > 0.0) & (factors < MIN_DERATING)):
        raise RobotError(f"derating factors must be 0 (a failed wheel, held at rest) or at "
                         f"least {MIN_DERATING:g} (a bound of this library: a limit that "
                         f"far below the other wheels' is lost in their rounding), got "
                         f"{shown(derating)}")
    return tuple(float(f) for f in factors)


def rest_projector(wheel_blocks: FloatArray, derating: tuple[float, ...]) -> FloatArray | None:
    """``I - pinv(W_f) W_f`` over the failed wheels' blocks ``W_f`` (factor 0): projects a
    twist onto those that keep them at rest; None when no wheel has failed."""
    failed = wheel_blocks[np.asarray(derating, dtype=float) == 0.0].reshape(-1, 3)
    if not failed.size:
        return None
    return readonly(np.eye(3) - np.linalg.pinv(failed) @ failed)


def merged_derating(current: tuple[float, ...] | None, factors: dict[int, float] | ArrayLike,
                    n_wheels: int) -> tuple[float, ...]:
    """The derating after :meth:`~mpc.robots.base.Robot.derated` with ``factors``: a dict
    of wheel index -> factor over ``current`` (None: every wheel 1.0), or all ``n_wheels``
    factors (checked when the robot is built)."""
    merged = np.ones(n_wheels) if current is None else np.array(current)
    if isinstance(factors, dict):
        for index, value in factors.items():
            if not is_integer(index) or not 0 <= index < n_wheels:
                raise RobotError(
                    f"wheel index must be an integer in 0..{n_wheels - 1}, got {shown(index)}"
                )
            if not is_finite_number(value):
                raise RobotError(f"derating of wheel {index} must be a number in [0, 1], "
                                 f"got {shown(value)}")
            merged[int(index)] = float(value)
        return tuple(float(v) for v in merged)
    return check_derating(factors, n_wheels)
