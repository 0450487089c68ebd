"""When the compiled tick rebuilds its Hessian: the rule as graph arithmetic.

The QP is posed in the step from the guess with the cost's exact gradient there, so a
Hessian kept from an earlier tick only shapes the step (it slows the real-time
iteration's convergence a little, it does not move its fixed point; see
:mod:`mpc.solvers.hessian_reuse`). A kept Hessian keeps its Cholesky factor, its inverse
and the whitened rows with it, and (constant-Jacobian robots: constant rows) daqp keeps
its rows too: a tick that keeps it updates only daqp's gradient and bounds.

``prepare`` measures how far this tick's input sensitivities ``B_k`` and the rollout's
planar steps (times ``dt``, as they enter the state sensitivities) moved from the ones
the kept Hessian was built from, as a multiple of
:data:`~mpc.solvers.hessian_reuse.SENSITIVITY_TOLERANCE` ``* dt``: the Python tick's
measure (:class:`~mpc.solvers.hessian_reuse.HessianReuse`), rotations of the whole plan
not counted where the cost weighs positions alike in every direction. The runners rebuild
when it exceeds :data:`REBUILD_DRIFT` (whole and at once, not staged over four ticks as
the Python tick's rebuild is), when nothing is kept (the first tick, after a reset, after a
failed tick, for the second solve from the last command held).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mpc.solvers.condensed import Condenser
from mpc.solvers.hessian_reuse import SENSITIVITY_TOLERANCE

#: The Hessian is rebuilt at a tick whose drift (prepare's ``drift``) exceeds this
#: multiple of the tolerance: the Python tick's :data:`~mpc.solvers.dense.REBUILD_EARLY`
#: (with ``dense.REBUILD_NOW`` set to it, the two ticks rebuild on the same ticks). Read
#: when a controller is built; below 0: every tick (no reuse).
REBUILD_DRIFT = 1.0


def terms_size(horizon: int) -> int:
    """Numbers a tick's reuse terms take: ``vec B_k`` (9 a stage) and the planar steps (2 a
    stage), as they are and turned to stage 0's body frame."""
    return 22 * horizon


def reuse_terms(sensitivities: ca.SX, steps: ca.SX, kept: ca.SX, dt: float,
                isotropic: bool) -> tuple[ca.SX, ca.SX]:
    """This tick's reuse terms (:func:`terms_size`) and their drift from ``kept`` (the terms
    of the kept Hessian's build), in multiples of the tolerance.

    Args:
        sensitivities: ``vec B_k`` (9 x N, column-major blocks).
        steps: the rollout's planar steps (2 x N) [m].
        kept: the terms the kept Hessian was built from (``terms_size(N)``).
        dt: the model's stage duration [s].
        isotropic: the cost weighs positions alike in every direction: a rotation of the
            whole plan leaves the Hessian as it is, so the drift is the smaller of the
            terms' and the turned terms' (:func:`~mpc.solvers.hessian_reuse._unrotated`).
    """
    n = sensitivities.shape[1]
    raw = ca.vertcat(ca.vec(sensitivities), ca.vec(steps))
    first = ca.reshape(sensitivities[:, 0], 3, 3)
    angle = ca.atan2(first[1, 0] - first[0, 1], first[0, 0] + first[1, 1])
    c, s = ca.cos(angle), ca.sin(angle)
    turn = ca.vertcat(ca.horzcat(c, s), ca.horzcat(-s, c))  # world -> stage 0's frame
    blocks = []
    for k in range(n):
        block = ca.reshape(sensitivities[:, k], 3, 3)
        blocks.append(ca.vec(ca.vertcat(turn @ block[:2, :], block[2, :])))
    turned = ca.vertcat(*blocks, ca.vec(turn @ steps))
    tolerance = SENSITIVITY_TOLERANCE * dt
    size = 9 * n

    def moved(now: ca.SX, then: ca.SX) -> ca.SX:
        return ca.fmax(ca.mmax(ca.fabs(now[:size] - then[:size])),
                       ca.mmax(ca.fabs(now[size:] - then[size:])) * dt) / tolerance

    drift = moved(raw, kept[:11 * n])
    if isotropic:
        drift = ca.fmin(drift, moved(turned, kept[11 * n:]))
    return ca.vertcat(raw, turned), drift


def isotropic_cost(condenser: Condenser, p_data: ca.DM) -> bool:
    """Whether the (constant) cost Hessian ``p_data`` (its upper triangle's values, as
    :func:`~mpc.solvers.condensed.tick_terms` gives them) weighs positions alike in every
    direction (:meth:`~mpc.solvers.condensed.Condenser.isotropic`)."""
    values = np.asarray(ca.DM(p_data).nonzeros(), dtype=float)
    if not np.all(np.isfinite(values)):
        raise RuntimeError("the cost Hessian is not finite")
    condenser.scatter(values)
    return condenser.isotropic()


def must_rebuild(kept: bool, drift: float, above: float) -> bool:
    """The rule (``tick.c`` has the same line): rebuild when nothing is kept or the drift
    exceeds ``above`` (a NaN drift keeps, as the Python tick's comparison does: its QP
    fails on the NaN gradient either way, and a failed tick drops what is kept)."""
    return not kept or drift > above
