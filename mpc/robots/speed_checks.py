"""Checks of twists against a robot's wheel speed limits: the peak speed ratio, feasibility,
and uniform desaturation into the limits (methods every :class:`~mpc.robots.base.Robot`
has).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import BoolArray, FloatArray
from mpc.robots.checks import as_twists


class SpeedLimitChecks:
    """:meth:`speed_ratio`, :meth:`is_feasible` and :meth:`desaturate` of a robot."""

    if TYPE_CHECKING:
        @property
        def max_wheel_speed(self) -> FloatArray: ...

        def wheel_velocities(self, twist: ArrayLike) -> FloatArray: ...

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

    def is_feasible(self, twist: ArrayLike, rtol: float = 1e-9) -> bool | BoolArray:
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
