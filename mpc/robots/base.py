"""What every drive layout shares: wheel velocity maps and their limits.

Every layout is described to the controller the same way. Wheel ``i`` has a
small matrix ``W_i`` (shape ``(d, 3)``) mapping the body twist
``xi = (vx, vy, omega)`` to its wheel velocity ``W_i @ xi`` in rad/s:

- Swedish wheels (omni, Mecanum): ``d = 1``, the row ``J_i`` of the
  inverse-kinematics Jacobian; the speed is signed.
- Swerve modules: ``d = 2``, the module's ground velocity divided by the
  wheel radius; the speed is its norm.

The limits are ``||W_i @ xi|| <= max_wheel_speed[i]`` and
``||W_i @ (xi_k - xi_{k-1})|| <= max_wheel_accel[i] * dt``: linear rows for
Swedish wheels, disks for swerve modules.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mpc.errors import RobotError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def positive_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise RobotError unless finite and > 0."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise RobotError(f"{name} must be a finite number > 0, got {value!r}") from None
    if not math.isfinite(number) or number <= 0.0:
        raise RobotError(f"{name} must be a finite number > 0, got {value!r}")
    return number


def finite(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise RobotError unless finite."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise RobotError(f"{name} must be a finite number, got {value!r}") from None
    if not math.isfinite(number):
        raise RobotError(f"{name} must be a finite number, got {value!r}")
    return number


def as_twists(twist: ArrayLike, name: str = "twist") -> FloatArray:
    """Return a float array of shape (3,) or (k, 3), checked finite."""
    array = np.asarray(twist, dtype=float)
    if array.ndim not in (1, 2) or array.shape[-1] != 3:
        raise RobotError(
            f"{name} must have shape (3,) or (k, 3) as (vx, vy, omega), got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise RobotError(f"{name} must be finite, got {array}")
    return array


def readonly(array: ArrayLike) -> FloatArray:
    out = np.array(array, dtype=float)
    out.setflags(write=False)
    return out


def check_holonomic(stacked_rows: FloatArray, what: str) -> None:
    """Raise RobotError unless the stacked wheel rows have rank 3."""
    singular = np.linalg.svd(stacked_rows, compute_uv=False)
    if singular.size < 3 or singular[2] <= 1e-9 * max(singular[0], 1e-300):
        raise RobotError(
            f"{what} is not holonomic: its wheel Jacobian has rank < 3 "
            f"(singular values {np.round(singular, 12).tolist()}); "
            "wheels that are all parallel or all at one point cannot drive every twist"
        )


@dataclass(frozen=True, eq=False)
class Robot(abc.ABC):
    """Common interface of every drive layout (see the module docstring).

    Subclasses fill ``wheel_blocks``, ``nominal_max_wheel_speed`` and
    ``nominal_max_wheel_accel`` in ``__post_init__``.
    ``derating`` scales each wheel's limits, 1.0 for a healthy wheel and 0.0
    for a failed one held at rest; see :meth:`derated`.
    """

    name: str
    derating: tuple[float, ...] | None = field(default=None, kw_only=True)

    # Filled by subclasses.
    wheel_blocks: FloatArray = field(init=False, repr=False)  # (n, d, 3) [rad/s per twist unit]
    nominal_max_wheel_speed: FloatArray = field(init=False, repr=False)  # (n,) [rad/s]
    nominal_max_wheel_accel: FloatArray | None = field(init=False, repr=False)  # (n,) [rad/s^2]
    #: Projects a twist onto those that keep every failed wheel (limit 0) at
    #: rest, ``I - pinv(W_f) W_f``; None when no wheel has failed.
    rest_projector: FloatArray | None = field(init=False, repr=False, default=None)

    def _check_derating(self) -> None:
        if self.derating is None:
            return
        factors = np.asarray(self.derating, dtype=float)
        if factors.shape != (self.n_wheels,) or not np.all(np.isfinite(factors)):
            raise RobotError(
                f"derating must be {self.n_wheels} finite factors, got {self.derating!r}"
            )
        if np.any(factors < 0.0) or np.any(factors > 1.0):
            raise RobotError(f"derating factors must lie in [0, 1], got {self.derating!r}")
        failed = self.wheel_blocks[factors == 0.0].reshape(-1, 3)
        if failed.size:
            projector = np.eye(3) - np.linalg.pinv(failed) @ failed
            object.__setattr__(self, "rest_projector", readonly(projector))

    @property
    def n_wheels(self) -> int:
        return int(self.wheel_blocks.shape[0])

    @property
    def flat_wheel_blocks(self) -> FloatArray:
        """``wheel_blocks`` stacked into (n * d, 3): wheel i's rows are i*d .. i*d + d - 1."""
        return self.wheel_blocks.reshape(-1, 3)

    @property
    def wheel_dim(self) -> int:
        """1 for Swedish wheels (signed speed), 2 for swerve modules (velocity vector)."""
        return int(self.wheel_blocks.shape[1])

    @property
    def max_wheel_speed(self) -> FloatArray:
        """Per-wheel speed limit [rad/s], after derating."""
        if self.derating is None:
            return self.nominal_max_wheel_speed
        return self.nominal_max_wheel_speed * np.asarray(self.derating)

    @property
    def max_wheel_accel(self) -> FloatArray | None:
        """Per-wheel acceleration limit [rad/s^2] after derating, or None if unlimited."""
        # Derating limits speed only: a failed wheel is held at rest by its
        # speed limit, and an acceleration limit of 0 would make the step
        # from its last (moving) command to rest infeasible.
        return self.nominal_max_wheel_accel

    def wheel_velocities(self, twist: ArrayLike) -> FloatArray:
        """Wheel velocity vectors ``W_i @ twist`` [rad/s], shape (..., n, d)."""
        xi = as_twists(twist)
        return np.einsum("ndj,...j->...nd", self.wheel_blocks, xi)

    @abc.abstractmethod
    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Inverse kinematics: wheel speeds [rad/s] for body twist(s), shape (..., n)."""

    def speed_ratio(self, twist: ArrayLike) -> FloatArray | float:
        """Peak ``|wheel speed| / limit`` over the wheels (1.0 = at the limit).

        A failed wheel (limit 0) gives 0 at rest and ``inf`` otherwise.
        """
        magnitude = np.linalg.norm(self.wheel_velocities(twist), axis=-1)
        limit = self.max_wheel_speed
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(
                limit > 0.0,
                magnitude / np.where(limit > 0.0, limit, 1.0),
                np.where(magnitude > 1e-12, np.inf, 0.0),
            )
        peak = ratio.max(axis=-1)
        return float(peak) if np.ndim(peak) == 0 else peak

    def is_feasible(self, twist: ArrayLike, rtol: float = 1e-9) -> bool | NDArray[np.bool_]:
        """Whether every wheel is within its speed limit (relative tolerance ``rtol``)."""
        result = np.asarray(self.speed_ratio(twist)) <= 1.0 + rtol
        return bool(result) if result.ndim == 0 else result

    def desaturate(self, twist: ArrayLike) -> FloatArray:
        """Scale twist(s) uniformly into the wheel limits, keeping the direction.

        Twists already within the limits are returned unchanged. This is
        WPILib's ``desaturateWheelSpeeds`` expressed on the twist.
        """
        xi = as_twists(twist)
        ratio = np.asarray(self.speed_ratio(xi))
        with np.errstate(divide="ignore"):
            scale = np.where(ratio > 1.0, 1.0 / ratio, 1.0)
        return xi * scale[..., None]

    def derated(self, factors: dict[int, float] | ArrayLike) -> Robot:
        """A copy with per-wheel limits scaled by ``factors`` in [0, 1].

        ``{2: 0.0}`` models wheel 2 failed and held at rest; ``{0: 0.5}`` a
        wheel that reaches only half its speed. Acceleration limits are kept.
        """
        current = np.ones(self.n_wheels) if self.derating is None else np.array(self.derating)
        if isinstance(factors, dict):
            for index, value in factors.items():
                if not 0 <= int(index) < self.n_wheels:
                    raise RobotError(
                        f"wheel index must be in 0..{self.n_wheels - 1}, got {index!r}"
                    )
                current[int(index)] = float(value)
        else:
            current = np.asarray(factors, dtype=float)
        return self._with_derating(tuple(float(v) for v in current))

    @abc.abstractmethod
    def _with_derating(self, derating: tuple[float, ...]) -> Robot: ...
