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
from mpc.robots.base import FloatArray, Robot


def polygon_rows(robot: Robot, polygon_sides: int) -> tuple[FloatArray, FloatArray]:
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
    """The twist furthest along ``last -> target`` that keeps every wheel limit.

    Both limit sets are convex and contain ``last`` (if ``last`` is within
    the speed limits), so the segment's feasible part is ``[0, lam]``; each
    wheel gives ``lam`` in closed form (a quadratic for a swerve disk).
    Returns the clamped twist and whether it had to move. If ``last`` itself
    breaks a speed limit (the limits were just derated), acceleration cannot
    be honoured as well and the target is scaled uniformly into the speed
    limits instead.
    """
    step = target - last
    blocks = robot.wheel_blocks
    start = blocks @ last  # (n, d) wheel velocities now
    direction = blocks @ step  # (n, d) their change
    limit = robot.max_wheel_speed
    aa = (start * start).sum(axis=1)
    if (aa > (limit * (1 + 1e-9) + 1e-12) ** 2).any():
        clamped = robot.desaturate(target)
        return clamped, not np.array_equal(clamped, target)
    bb = (direction * direction).sum(axis=1)
    moving = bb > 0.0
    if not moving.any():
        return target, False
    ab = (start * direction).sum(axis=1)
    safe = np.where(moving, bb, 1.0)
    # Largest lam with |start + lam direction| <= limit, per wheel.
    speed_room = (-ab + np.sqrt(np.maximum(ab * ab - bb * (aa - limit * limit), 0.0))) / safe
    fraction = speed_room[moving].min()
    accel = robot.max_wheel_accel
    if accel is not None:
        fraction = min(fraction, (accel[moving] * dt / np.sqrt(bb[moving])).min())
    if fraction >= 1.0:
        return target, False
    # Shave a relative 1e-12 so that rounding never lands a hair outside.
    return last + max(fraction * (1.0 - 1e-12), 0.0) * step, True
