"""The steering rate as rows on a motor robot's plan: along each stage's ramp no module's
direction may turn faster than ``max_steer_rate``.

A robot with dynamics plans each stage at a constant acceleration, and the motor plant's
wheel loops ramp each command over the tick: a module's velocity runs in a straight line
from ``b = W_i u_{k-1}`` to ``e = W_i u_k`` over ``h = change_times[k]``, and its
direction turns at ``|b x e| / (h |v(s)|^2)`` (:mod:`mpc.robots.wheels.swerve.ramp_turn`),
fastest where the line passes closest to rest. The condition, per module and stage::

    H(b, e) = |b x e| - c D(b, e) <= 0,   c = max_steer_rate h,
    D = min over 0 <= s <= 1 of |b + s (e - b)|^2

(``D`` is ``|b|^2``, ``|e|^2`` or the squared distance of the line from rest, as the
closest point is the start, the end or between). It is not convex (through rest a module
may point anywhere), so each tick it is linearised around the plan the solver starts from,
``(bbar, ebar)``, as the swerve's speed disks are: two rows, one for each sign of
``b x e`` (the cross product is bilinear: its linearisation is exact where ``b`` is fixed,
the first stage's, the last command's). Where the linearisation excludes holding the last
command on every stage (which turns no module), a row is widened to let it: with
the motor rows' own widening of the first stage, the QP always has that plan. A module
slower than :data:`ROW_FLOOR` at the stage's start in that plan gets no rows.

Without them the plan asked modules that slow while they turn for up to 17 rad/s near the
end of a tick (12 allowed): the module lagged its velocity by a fraction of a degree, its
tread scrubbed sideways past ``mu N``, and the slip lasted for ticks
(``docs/guide/traction.md``). The clamp keeps the command sent within the rate
(:func:`~mpc.robots.wheels.swerve.ramp_turn.ramp_turn_fraction`); the rows keep the plan
from asking for what it would cut.
"""

from __future__ import annotations

import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.swerve.modules import SwerveModules

#: Rows a module a stage: ``b x e`` taken positive, then negative.
ROWS_PER_MODULE = 2
#: [m/s] a module slower than this at a stage's start, in the plan the solver starts from,
#: gets no rows there.
ROW_FLOOR = 0.05
#: [(rad/s)^2] the smallest squared length of a stage's change the closest point is
#: computed for (a shorter change turns no module).
_SHORTEST = 1e-12


def with_steering_rows(robot: SwerveModules, base: StageLimits) -> StageLimits:
    """``base``'s rows (kept as they are) followed by :data:`ROWS_PER_MODULE` steering rows
    a module on every stage, all off until :func:`update_steering_rows` fills them."""
    horizon = base.horizon
    extra = ROWS_PER_MODULE * robot.n_wheels
    off = np.full((horizon, extra), np.inf)
    limits = StageLimits(
        now=np.concatenate([base.now, np.zeros((horizon, extra, 3))], axis=1),
        before=np.concatenate([base.before, np.zeros((horizon, extra, 3))], axis=1),
        lower=np.concatenate([base.lower, -off], axis=1),
        upper=np.concatenate([base.upper, off], axis=1),
        constant=False, change_times=np.array(base.change_times, dtype=float))
    limits.memory["steer_first"] = np.array([base.rows])
    return limits


def _closest(b: FloatArray, e: FloatArray, cross: FloatArray
             ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``D`` of the module docstring and its gradients in ``b`` and ``e`` (each (..., 2)),
    for lines from ``b`` to ``e`` (..., 2) with ``cross = b x e``."""
    change = e - b
    length = np.maximum((change * change).sum(axis=-1), _SHORTEST)
    s = -(b * change).sum(axis=-1) / length
    start, end = s <= 0.0, s >= 1.0
    x, ell = cross[..., None], length[..., None]
    d_cross_b = np.stack([e[..., 1], -e[..., 0]], axis=-1)
    d_cross_e = np.stack([-b[..., 1], b[..., 0]], axis=-1)
    # between: D = (b x e)^2 / |e - b|^2
    middle_b = 2.0 * x * d_cross_b / ell + 2.0 * x**2 * change / ell**2
    middle_e = 2.0 * x * d_cross_e / ell - 2.0 * x**2 * change / ell**2
    value = np.where(start, (b * b).sum(axis=-1),
                     np.where(end, (e * e).sum(axis=-1), cross**2 / length))
    grad_b = np.where(start[..., None], 2.0 * b, np.where(end[..., None], 0.0, middle_b))
    grad_e = np.where(start[..., None], 0.0, np.where(end[..., None], 2.0 * e, middle_e))
    return value, grad_b, grad_e


def update_steering_rows(robot: SwerveModules, limits: StageLimits, guess: FloatArray,
                         last: FloatArray) -> None:
    """Refill the steering rows of :func:`with_steering_rows` around ``guess`` (N, 3), the
    plan the solver starts from, and ``last``, the last command (module docstring)."""
    first = int(limits.memory["steer_first"][0])
    horizon, n = limits.horizon, robot.n_wheels
    blocks = robot.wheel_blocks  # (n, 2, 3) [rad/s per twist unit]
    previous = np.vstack([last[None, :], guess[:-1]])
    b = np.einsum("nij,kj->kni", blocks, previous)  # (N, n, 2)
    e = np.einsum("nij,kj->kni", blocks, guess)
    beta = np.hypot(b[..., 0], b[..., 1])
    active = beta * robot.wheel_radius > ROW_FLOOR
    scale = np.where(active, beta, 1.0)  # rows per |b|: in rad/s, as the others
    c = robot.max_steer_rate * limits.change_times[:, None]  # (N, 1) [rad]
    cross = b[..., 0] * e[..., 1] - b[..., 1] * e[..., 0]
    closest, closest_b, closest_e = _closest(b, e, cross)
    d_cross_b = np.stack([e[..., 1], -e[..., 0]], axis=-1)
    d_cross_e = np.stack([-b[..., 1], b[..., 0]], axis=-1)
    now, before, upper = [], [], []
    for sign in (1.0, -1.0):  # sign (b x e) - c D <= 0, linearised at (b, e)
        grad_b = (sign * d_cross_b - c[..., None] * closest_b) / scale[..., None]
        grad_e = (sign * d_cross_e - c[..., None] * closest_e) / scale[..., None]
        value = (sign * cross - c * closest) / scale
        now.append(np.einsum("kni,nij->knj", grad_e, blocks))
        before.append(np.einsum("kni,nij->knj", grad_b, blocks))
        upper.append((grad_b * b).sum(axis=-1) + (grad_e * e).sum(axis=-1) - value)
    rows_now, rows_before = np.stack(now, axis=2), np.stack(before, axis=2)  # (N, n, 2, 3)
    bound = np.stack(upper, axis=2)  # (N, n, 2)
    held = np.einsum("knrj,j->knr", rows_now + rows_before, last)  # every stage at last
    np.maximum(bound, held, out=bound)
    mask = active[..., None]
    rows = slice(first, first + ROWS_PER_MODULE * n)
    limits.now[:, rows] = np.where(mask[..., None], rows_now, 0.0).reshape(horizon, -1, 3)
    limits.before[:, rows] = np.where(mask[..., None], rows_before, 0.0).reshape(
        horizon, -1, 3)
    limits.upper[:, rows] = np.where(mask, bound, np.inf).reshape(horizon, -1)
    limits.changed = True
