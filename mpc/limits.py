"""Wheel limits as constraints on the twist, and the last-line safety clamp.

Wheel ``i`` with velocity map ``W_i`` (see :mod:`mpc.robots.base`) must keep
``||W_i u_k|| <= max_wheel_speed_i`` and
``||W_i (u_k - u_{k-1})|| <= max_wheel_accel_i * dt``.

For a QP both become two-sided linear rows ``lower <= C u <= upper``: a
Swedish wheel's row is exact; a swerve module's disk is replaced by the
inscribed regular polygon with ``polygon_sides`` sides (half as many
two-sided rows), conservative by at most ``1 - cos(pi / sides)``.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.errors import ControllerError
from mpc.robots.base import FloatArray, IntArray, Robot


def polygon_rows(robot: Robot, polygon_sides: int) -> tuple[FloatArray, IntArray]:
    """Rows ``C`` (m, 3) and per-row wheel index (m,) so ``|C u| <= factor * limit``.

    For Swedish wheels the rows are ``J`` and the factor is 1; for swerve
    modules they are the polygon's half-plane normals applied to ``W_i``.
    """
    if robot.wheel_dim == 1:
        return robot.wheel_blocks[:, 0, :].copy(), np.arange(robot.n_wheels)
    if polygon_sides < 4 or polygon_sides % 2:
        raise ControllerError(
            f"polygon_sides must be an even integer >= 4, got {polygon_sides!r}"
        )
    angles = 2.0 * math.pi * np.arange(polygon_sides // 2) / polygon_sides
    normals = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # (M/2, 2)
    rows = np.einsum("md,ndj->nmj", normals, robot.wheel_blocks)
    wheel = np.repeat(np.arange(robot.n_wheels), len(angles))
    return rows.reshape(-1, 3), wheel


def polygon_factor(robot: Robot, polygon_sides: int) -> float:
    """The inscribed polygon's apothem as a fraction of the disk radius (1 for Swedish)."""
    return 1.0 if robot.wheel_dim == 1 else math.cos(math.pi / polygon_sides)


def clamp_command(
    robot: Robot, target: FloatArray, last: FloatArray, dt: float
) -> tuple[FloatArray, bool]:
    """Bring ``target`` within every wheel limit, moving it as little as the rules allow.

    1. Speed: project out any motion of a failed wheel (limit 0), then
       scale ``target`` uniformly into the speed limits (a solver's output
       is off by its tolerance at most, so this is a tiny scaling).
    2. Acceleration: step from ``last`` towards that twist only as far as
       every wheel's acceleration limit allows. Both ends lie in the convex
       speed-limit set, so the whole step does too.

    Returns the clamped twist and whether it differs from ``target``. If
    ``last`` itself breaks a speed limit (the limits were just derated),
    acceleration cannot be honoured as well; the speed limits win.
    """
    original = target
    if robot.rest_projector is not None:
        target = robot.rest_projector @ target
    limit = robot.max_wheel_speed
    speed = _magnitudes(robot, target)
    over = speed > limit + 1e-12  # [rad/s]: rounding left by the projection
    safe = target
    if over.any():
        # The smallest limit / speed over the wheels; a failed wheel (limit 0) stops the robot.
        safe = target * (limit[over] / speed[over]).min() * (1.0 - 1e-12)
    accel = robot.max_wheel_accel
    if accel is None:
        return safe, safe is not original
    if (_magnitudes(robot, last) > limit * (1 + 1e-9) + 1e-12).any():
        return safe, safe is not original
    fraction = (accel * dt / np.maximum(_magnitudes(robot, safe - last), 1e-300)).min()
    if fraction >= 1.0:
        return safe, safe is not original
    return last + fraction * (1.0 - 1e-12) * (safe - last), True


def _magnitudes(robot: Robot, twist: FloatArray) -> FloatArray:
    """Each wheel's speed ``||W_i twist||`` [rad/s], shape (n,)."""
    velocity = robot.flat_wheel_blocks @ twist
    if robot.wheel_dim == 1:
        return np.abs(velocity)
    return np.hypot(velocity[0::2], velocity[1::2])
