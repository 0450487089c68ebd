"""A swerve module's limits for the solvers: speed and acceleration disks, steering rate.

For module ``i`` with velocity ``v = W_i u`` [rad/s] (ground velocity / r):

- speed: ``|v_k| <= max_wheel_speed``; acceleration: ``|v_k - v_{k-1}| <= max_wheel_accel dt``;
- steering: the module turns at most ``max_steer_rate dt`` a tick. With the flip rule a
  module may reverse instead of turning, so what is bounded is the turn modulo a half
  turn: ``|v_k x v_{k-1}| <= sin(max_steer_rate dt) |v_k| |v_{k-1}|``.

The NLP takes the disks and, between consecutive stages of the plan, the steering
bound exactly (squared, so smooth). The QP takes each disk as a regular polygon
(:meth:`SwerveRobot.qp_speed_rows`) and the steering rate as the cost on the change
of module velocity (``Weights.module_rate``). For every command, the final clamp
(:func:`mpc.control.clamp.clamp_command`) keeps every module within all three limits:
the first command's turn against the present steer angles is the clamp's to keep,
in both paths.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray

if TYPE_CHECKING:
    from mpc.robots.swerve import SwerveRobot


def nlp_stage_limits(robot: SwerveRobot, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                     change_times: FloatArray
                     ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
    """The exact limits for the NLP (squared forms; see the module docstring), ``u_k``
    following ``u_{k-1}`` by ``change_times[k]`` [s] (the ``dt`` of the module docstring)."""
    blocks = [ca.DM(block) for block in robot.wheel_blocks]
    speed, accel = robot.max_wheel_speed, robot.max_wheel_accel
    values: list[ca.SX] = []
    lower: list[FloatArray] = []
    upper: list[FloatArray] = []

    def add(value: ca.SX, high: float) -> None:
        values.append(value)
        lower.append(np.array([-np.inf]))
        upper.append(np.array([high]))

    for k in range(twists.shape[1]):
        for i, block in enumerate(blocks):
            v = block @ twists[:, k]
            w = block @ (last if k == 0 else twists[:, k - 1])
            add(ca.sumsqr(v), float(speed[i]) ** 2)
            dt = float(change_times[k])
            if accel is not None:
                add(ca.sumsqr(v - w), float(accel[i] * dt) ** 2)
            if k > 0:
                sine2 = math.sin(min(robot.max_steer_rate * dt, math.pi / 2)) ** 2
                cross = v[0] * w[1] - v[1] * w[0]
                add(cross**2 - sine2 * ca.sumsqr(v) * ca.sumsqr(w), 0.0)
    return values, lower, upper


def turns(robot: SwerveRobot, velocities: FloatArray, steer_angles: FloatArray) -> FloatArray:
    """How far each module must turn [rad] to drive ``velocities`` (n, 2) from its present
    angle, with the flip rule (so in [0, pi / 2]); 0 for a module at rest."""
    angle = np.arctan2(velocities[:, 1], velocities[:, 0])
    turn = np.abs(np.mod(angle - steer_angles + math.pi / 2, math.pi) - math.pi / 2)
    moving = np.hypot(velocities[:, 0], velocities[:, 1]) * robot.wheel_radius > 1e-6
    return np.where(moving, turn, 0.0)


def steering_fraction(robot: SwerveRobot, last: FloatArray, target: FloatArray,
                      steer_angles: FloatArray, dt: float) -> float:
    """The largest ``f`` in [0, 1] such that ``last + f (target - last)`` turns no module
    by more than ``max_steer_rate dt`` from its present angle (bisection; 1 if the
    target itself does not)."""
    reach = robot.max_steer_rate * dt * (1.0 - 1e-9)
    blocks = robot.wheel_blocks

    def fits(fraction: float) -> bool:
        velocities = blocks @ (last + fraction * (target - last))
        return bool(np.all(turns(robot, velocities, steer_angles) <= reach))

    if fits(1.0):
        return 1.0
    low, high = 0.0, 1.0
    if not fits(low):  # the last command itself is out of line (e.g. after a reset)
        return 0.0
    for _ in range(30):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if fits(middle) else (low, middle)
    return low
