"""How fast a steered wheel must turn to follow a reference: the steering demand.

A steered module (swerve; a caster's steer axis, the caster taken as trailing along its
axis's velocity) points along its velocity ``w = W_i u`` (the flip rule takes the
direction modulo a half turn). Along a reference whose body twist is ``u`` with rate
``du/dt``, that direction turns at

    |w x dw/dt| / |w|^2   [rad/s],   dw/dt = W_i du/dt,

in the body frame, which is what a module's steering rate limit bounds. Driving a path
at a path rate ``sdot`` (``u = g sdot``, :mod:`trajectories.retiming`) the turn rate is
that of ``g`` and ``h = dg/ds`` times ``sdot``: a bound on ``sdot`` alone.

Where a module's velocity passes close to zero its direction sweeps fast (half a turn as
it passes); a module that slow can lag its direction at little cost, and the controller's
clamp lets one wait at rest while it turns. So a module slower than :data:`STEER_FLOOR`
of its speed limit is not held to the steering rate here, and a failed one (speed limit
0, held at rest) not at all. A module's steering demand is ``min(turn rate / limit,
speed / floor)``: at most 1 exactly where it turns within its limit or is below the
floor, continuous, and proportional to the path rate (so a timing scaled by its peak
demand keeps within it).
"""

from __future__ import annotations

import numpy as np

from ._validation import FloatArray

#: A steered module slower than this fraction of its speed limit may lag its direction:
#: the steering rate is not asked of it (2 % of a swerve module's 1.5 m/s: 3 cm/s).
STEER_FLOOR = 0.02


def direction_rates(blocks: FloatArray, twists: FloatArray,
                    twist_rates: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Each module's direction rate and speed, both (m, n), for body twists and their rates
    (m, 3): ``|w x dw| / |w|^2`` [rad/s] (0 where ``w = 0``) and ``|w|`` [rad/s], with
    ``w = W_i u`` and ``dw = W_i du`` for the module velocity maps ``blocks`` (n, 2, 3)."""
    w = np.einsum("ndj,mj->mnd", blocks, twists)
    dw = np.einsum("ndj,mj->mnd", blocks, twist_rates)
    cross = np.abs(w[..., 0] * dw[..., 1] - w[..., 1] * dw[..., 0])
    squares = w[..., 0] ** 2 + w[..., 1] ** 2
    moving = squares > 0.0
    rates = np.divide(cross, squares, out=np.zeros_like(cross), where=moving)
    return rates, np.sqrt(squares)


def steer_demand(blocks: FloatArray, speed_limits: FloatArray, steer_limits: FloatArray,
                 twists: FloatArray, twist_rates: FloatArray) -> FloatArray:
    """Peak steering demand over the modules, (m,) (1 = at the limit; see the module), for
    body twists and their rates (m, 3): ``min(rate / steer limit, speed / floor)`` with
    the floor :data:`STEER_FLOOR` of the speed limit ``speed_limits`` (n,) [rad/s]; a
    failed module (limit 0) counts 0."""
    rates, speeds = direction_rates(blocks, twists, twist_rates)
    floor = STEER_FLOOR * speed_limits
    working = floor > 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        demand = np.minimum(rates / steer_limits, speeds / np.where(working, floor, 1.0))
    ratio: FloatArray = np.where(working, demand, 0.0).max(axis=1)
    return ratio
