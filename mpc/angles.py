"""Angle helpers shared by every layer of :mod:`mpc` (robots, simulation, plots)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """Wrap angle(s) into (-pi, pi] [rad]."""
    wrapped = np.mod(np.asarray(angle, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    return np.where(wrapped == -math.pi, math.pi, wrapped)
