"""A caster vehicle's forward joint kinematics: the body twist of drive and steer rates at
given steer angles (least squares over the contacts; the residual means slip). The
conventions are in :mod:`mpc.robots.wheels.caster.robot`'s docstring.
"""

from __future__ import annotations

import numpy as np

from mpc.arrays import FloatArray


def joint_twist(positions: FloatArray, offsets: FloatArray, radii: FloatArray,
                drive_rates: FloatArray, steer_rates: FloatArray,
                steer_angles: FloatArray) -> FloatArray:
    """The least-squares twist of ``[[1, 0, -Cy], [0, 1, Cx]] xi = r phidot e + d betadot n``
    over the casters (axes ``positions`` (n, 2) [m], trails ``offsets`` [m], ``radii`` [m];
    rates [rad/s] and angles [rad] (n,)), unchecked (the plant's hot path)."""
    n = positions.shape[0]
    c, s = np.cos(steer_angles), np.sin(steer_angles)
    d = offsets
    along = radii * drive_rates
    across = d * steer_rates
    velocity = np.empty(2 * n)
    velocity[0::2] = along * c - across * s
    velocity[1::2] = along * s + across * c
    contact_x = positions[:, 0] - d * c
    contact_y = positions[:, 1] - d * s
    rows = np.zeros((2 * n, 3))
    rows[0::2, 0] = 1.0
    rows[0::2, 2] = -contact_y
    rows[1::2, 1] = 1.0
    rows[1::2, 2] = contact_x
    return np.asarray(np.linalg.lstsq(rows, velocity, rcond=None)[0], dtype=float)
