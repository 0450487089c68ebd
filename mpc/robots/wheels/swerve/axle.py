"""Axle-offset swerve modules: the wheel beside its steer axis (Neobotix MPO-700).

**Axle-offset modules** (``axle_offset = L > 0`` [m], Neobotix MPO-700, Care-O-bot 3): the
wheel sits ``L`` along its axle to the right of the steer axis, contact
``C = P + L (sin b, -cos b)`` for steer angle ``b`` (the wheel's rolling heading
``e = (cos b, sin b)``). No lateral slip still aligns ``e`` with ``v_i`` (the offset adds
``omega L e`` to the contact's velocity, along the wheel), so the steer angle and the flip
rule are those of a centred module; the wheel's speed is corrected for the body's
rotation and for the module's own steering::

    r * phidot = e . v(C) + L * betadot = e . v_i + L * (omega + betadot)

(``betadot`` the steer rate [rad/s]; one open-source driver omits the ``L betadot``
term). Limits: the drive rate before steering is bounded by ``|v_i| + L |omega|``
(either sign of ``e``), so the speed limit becomes ``|v_i| + L |omega| <= r max`` (a cone:
exact in the NLP as smooth rows, the polygon rows doubled with ``+-L omega`` in the QP).
The steering term is not in the plan (it depends on the change of twist); the final
clamp keeps every command's corrected drive rate within the limit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import lapack

from mpc.arrays import FloatArray
from mpc.robots.checks import as_twists
from mpc.robots.wheels.swerve.modules import SwerveModules


def axle_speed_ratio(robot: SwerveModules, twist: ArrayLike) -> FloatArray | float:
    """Peak wheel speed / limit with the speed ``(|v_i| + L |omega|) / r``; a failed wheel
    (limit 0) gives 0 at rest and ``inf`` otherwise."""
    xi = as_twists(twist)
    limit = robot.max_wheel_speed
    magnitude = robot.wheel_speeds(xi)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(limit > 0.0, magnitude / np.where(limit > 0.0, limit, 1.0),
                         np.where(magnitude > 1e-12, np.inf, 0.0))
    peak = ratio.max(axis=-1)
    return float(peak) if np.ndim(peak) == 0 else peak


def axle_forward_kinematics(robot: SwerveModules, wheel_speeds: FloatArray,
                            steer_angles: FloatArray,
                            steer_rates: FloatArray | None) -> FloatArray:
    """The body twist while the modules steer at ``steer_rates`` [rad/s] (None: 0): least
    squares of ``e_i . v_i + L omega = r phidot_i - L betadot_i`` and ``n_i . v_i = 0``."""
    lever = robot.axle_offset
    c, s = np.cos(steer_angles), np.sin(steer_angles)
    ground = robot.ground_maps()
    rows = np.empty((2 * robot.n_wheels, 3))
    rows[0::2] = c[:, None] * ground[:, 0] + s[:, None] * ground[:, 1]
    rows[0::2, 2] += lever
    rows[1::2] = -s[:, None] * ground[:, 0] + c[:, None] * ground[:, 1]
    rolling = robot.wheel_radius * np.asarray(wheel_speeds, dtype=float)
    if steer_rates is not None:
        rolling = rolling - lever * steer_rates
    # The normal equations (3 x 3, by LAPACK's Cholesky solve: this runs in every tick's
    # wheel commands, and np.linalg.lstsq is much slower: docs/design/tick-costs.md); the
    # slip rows' right-hand sides are 0, so only the rolling rows enter. Rows without full
    # rank (not a layout the robot accepts) go to the least squares.
    _, twist, info = lapack.dposv(rows.T @ rows, rows[0::2].T @ rolling)
    if info != 0:
        values = np.zeros(2 * robot.n_wheels)
        values[0::2] = rolling
        twist = np.linalg.lstsq(rows, values, rcond=None)[0]
    return np.asarray(twist, dtype=float)
