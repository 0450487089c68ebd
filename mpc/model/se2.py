"""Rigid motion in the plane for a constant body twist, in CasADi and NumPy.

Pose ``(x, y, theta)`` in the world frame, body twist ``(vx, vy, omega)``
(REP-103: x forward, y left, yaw counter-clockwise) held for ``dt`` seconds:

    p+ = p + R(theta) @ V(omega dt) @ (vx, vy) dt,   theta+ = theta + omega dt
    V(a) = [[sin a / a, -(1 - cos a) / a], [(1 - cos a) / a, sin a / a]]

Where ``|omega dt|`` is tiny the Taylor series keeps values and derivatives
finite. :func:`twist_logarithm` is the inverse: the twist that drives one
pose exactly to another in ``dt``.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import ControllerError
from mpc.validation import finite_vector, non_negative

#: Below this ``|omega * dt|`` [rad] the maps use their Taylor series.
SMALL_ROTATION = 1e-3


def twist_integral(pose: ca.SX, twist: ca.SX, dt: float | ca.SX) -> ca.SX:
    """Pose after driving a constant body twist for ``dt`` seconds (CasADi; ``dt`` may be
    symbolic)."""
    angle = twist[2] * dt
    small = ca.fabs(angle) < SMALL_ROTATION
    safe = ca.if_else(small, 1.0, angle)  # never divide by ~0, even in the unused branch
    sin_over = ca.if_else(small, 1 - angle**2 / 6 + angle**4 / 120, ca.sin(safe) / safe)
    # 1 - cos a = 2 sin^2(a / 2) avoids cancellation.
    cos_over = ca.if_else(
        small, angle / 2 - angle**3 / 24 + angle**5 / 720, 2 * ca.sin(safe / 2) ** 2 / safe
    )
    forward = dt * (sin_over * twist[0] - cos_over * twist[1])
    left = dt * (cos_over * twist[0] + sin_over * twist[1])
    c, s = ca.cos(pose[2]), ca.sin(pose[2])
    return ca.vertcat(pose[0] + c * forward - s * left, pose[1] + s * forward + c * left,
                      pose[2] + angle)


def integrate(pose: ArrayLike, twist: ArrayLike, dt: float) -> FloatArray:
    """The pose (x, y, theta) [m, m, rad] after driving the body ``twist`` (vx, vy, omega)
    [m/s, m/s, rad/s] from ``pose`` for ``dt`` >= 0 [s] (:func:`twist_integral` in NumPy;
    each checked: ControllerError names a bad one)."""
    start = finite_vector("pose", pose, 3, "(x, y, theta) [m, m, rad]", ControllerError)
    drive = finite_vector("twist", twist, 3, "(vx, vy, omega) [m/s, m/s, rad/s]",
                          ControllerError)
    duration = non_negative("dt [s]", dt, ControllerError)
    return integrate_unchecked(start, drive, duration)


def integrate_unchecked(pose: FloatArray, twist: FloatArray, dt: float) -> FloatArray:
    """:func:`integrate` without the checks (the delay prediction's, every tick)."""
    angle = float(twist[2]) * dt
    if abs(angle) < SMALL_ROTATION:
        sin_over = 1 - angle * angle / 6 + angle**4 / 120
        cos_over = angle / 2 - angle**3 / 24 + angle**5 / 720
    else:
        sin_over = math.sin(angle) / angle
        cos_over = 2 * math.sin(angle / 2) ** 2 / angle
    forward = dt * (sin_over * twist[0] - cos_over * twist[1])
    left = dt * (cos_over * twist[0] + sin_over * twist[1])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * forward - s * left, pose[1] + s * forward + c * left,
                     pose[2] + angle])


def twist_logarithm(start: ca.SX, end: ca.SX, dt: float) -> ca.SX:
    """The constant body twist that drives ``start`` exactly to ``end`` in ``dt`` (the inverse
    of :func:`twist_integral`); columns are stages, so ``start``/``end`` may be 3 x N.

    With ``a = dtheta`` and ``d`` the displacement in the start's body frame,
    ``(vx, vy) dt = [[h cot h, h], [-h, h cot h]] @ d`` where ``h = a / 2``
    (series ``1 - h^2 / 3`` for ``h cot h`` near zero).
    """
    delta = end - start
    c, s = ca.cos(start[2, :]), ca.sin(start[2, :])
    forward = c * delta[0, :] + s * delta[1, :]
    left = c * delta[1, :] - s * delta[0, :]
    half = delta[2, :] / 2
    small = ca.fabs(half) < SMALL_ROTATION / 2
    safe = ca.if_else(small, 1.0, half)
    diagonal = ca.if_else(small, 1 - half**2 / 3, safe / ca.tan(safe))
    return ca.vertcat(diagonal * forward + half * left, diagonal * left - half * forward,
                      delta[2, :]) / dt
