"""The joint-free stand-in of a wheel whose contact point may move in any direction at up to
``r max_wheel_speed`` (casters, slider units): each contact's speed disk, as the rows the
solvers' joint-free paths take. The solvers themselves use each type's stage limits."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.robots.base import SpeedRows
from mpc.validation import integer_at_least


def disk_speed_rows(wheel_blocks: FloatArray, polygon_sides: int) -> SpeedRows:
    """Each contact's speed disk ``|v(C)| <= bound`` as an inscribed polygon of
    ``polygon_sides`` sides (rows in pairs of opposite faces).

    Args:
        wheel_blocks: each contact's velocity map from the body twist (n, 2, 3).
        polygon_sides: sides of the polygon (>= 4; an odd number is rounded down).
    """
    sides = integer_at_least("polygon_sides", polygon_sides, 4, RobotError)
    angles = 2.0 * math.pi * np.arange(sides // 2) / (2 * (sides // 2))
    normals = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # (M/2, 2)
    rows = np.einsum("md,ndj->nmj", normals, wheel_blocks)
    wheel = np.repeat(np.arange(len(wheel_blocks)), len(angles))
    return SpeedRows(rows.reshape(-1, 3), wheel, math.cos(math.pi / (2 * (sides // 2))))


def disk_casadi_limits(flat_wheel_blocks: FloatArray, twist: ca.SX, bounds: FloatArray
                       ) -> tuple[ca.SX, FloatArray, FloatArray]:
    """Each contact's speed disk, squared: ``|v(C)|^2 <= bound^2``.

    Args:
        flat_wheel_blocks: the contacts' velocity maps stacked (2 n, 3).
        twist: the body twist (3,).
        bounds: each contact's speed bound [m/s] (n,).
    """
    velocity = ca.DM(flat_wheel_blocks) @ twist
    bounds = np.asarray(bounds, dtype=float)
    return (velocity[0::2] ** 2 + velocity[1::2] ** 2, np.full(bounds.shape, -np.inf),
            bounds**2)
