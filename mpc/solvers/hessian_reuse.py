"""When the condensed QP's Hessian is rebuilt: the real-time iteration keeps a factorised
Hessian while the cost terms, the input sensitivities and the rollout's steps stay within
tolerances of the ones it was built from (a stale Hessian slows the iteration's
convergence; it does not move its fixed point, see :mod:`.condensed`).
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray

#: Largest change of an input sensitivity ``B_k`` [s] before the Hessian is rebuilt, as a
#: fraction of ``dt`` (0.02: a heading that moved by 0.02 rad relative to the others). A
#: stale Hessian slows the iteration's convergence; it does not move its fixed point (see
#: :mod:`.condensed`); it is a trade of tracking precision (one step a tick) for speed.
#: Looser tolerances made ticks a little quicker and tracking worse
#: (docs/design/hessian-reuse.md).
SENSITIVITY_TOLERANCE = 2e-2

#: Largest change of a cost Hessian entry before the Hessian is rebuilt, as a fraction of
#: the largest entry at set-up (path mode: the path's direction turns the contour terms).
#: Swerve's path mode rebuilds on every tick (its progress entries move ~15 % a tick as
#: the window shifts); looser, its stale progress block cost daqp more iterations than the
#: rebuild saves (docs/design/hessian-reuse.md).
COST_TOLERANCE = 0.5


class HessianReuse:
    """The terms the Hessian in use (or being built) came from, and how far a tick's terms
    have moved from them.

    Args:
        p_data: the cost Hessian's entries at set-up (their largest scales
            :data:`COST_TOLERANCE`).
        dt: the model's stage duration [s] (scales :data:`SENSITIVITY_TOLERANCE`).
        horizon: stages; a tick's moving terms are one vector of ``11 N``: ``vec B_k`` (9
            a stage), then the rollout's planar steps (2 a stage).
    """

    def __init__(self, p_data: FloatArray, dt: float, horizon: int) -> None:
        self.dt = dt
        self._cache: _HessianCache | None = None  # what the Hessian was built from
        self._p_stale = False  # the scattered cost terms differ from the cached Hessian's
        self._tolerance = SENSITIVITY_TOLERANCE * dt
        self._p_tolerance = COST_TOLERANCE * float(np.abs(p_data).max() or 1.0)
        # how each moving term enters S: a sensitivity as it is, a step times dt
        self._scale = np.concatenate((np.ones(9 * horizon), np.full(2 * horizon, dt)))
        self._work = np.empty(11 * horizon)

    def forget(self) -> None:
        """Drop the cache: the next tick rebuilds."""
        self._cache = None

    def drift(self, p_data: FloatArray, terms: FloatArray, sensitivity: FloatArray,
              displacement: FloatArray, p_changed: bool, isotropic: bool,
              enough: float) -> tuple[float, float]:
        """How far the cost terms, and the moving ``terms`` (the sensitivities
        ``sensitivity`` and the rollout's steps ``displacement`` times ``dt``, as they enter
        ``S``), moved since the remembered build, each as a multiple of its tolerance
        (``inf`` with nothing remembered). Where the cost weighs positions alike in every
        direction (``isotropic``), a rotation of the whole plan does not count (looked at
        only when the second is above ``enough``)."""
        cache = self._cache
        if cache is None:
            return math.inf, math.inf
        p_moved = 0.0
        if p_changed or self._p_stale:
            p_moved = float(np.abs(p_data - cache.p_data).max()) / self._p_tolerance
        self._p_stale = self._p_stale or p_changed
        work = np.subtract(terms, cache.terms, out=self._work)
        np.abs(work, out=work)
        work *= self._scale
        moved = float(work.max()) / self._tolerance
        if isotropic and moved > enough:
            moved = min(moved, cache.moved_turned(*_unrotated(sensitivity, displacement),
                                                  self.dt) / self._tolerance)
        return p_moved, moved

    def remember(self, p_data: FloatArray, terms: FloatArray, sensitivity: FloatArray,
                 displacement: FloatArray) -> None:
        """The terms a new build starts from."""
        self._cache = _HessianCache(p_data.copy(), terms.copy(), sensitivity.copy(),
                                    displacement.copy())
        self._p_stale = False

    def remember_cost(self, p_data: FloatArray) -> None:
        """New cost terms for a build that keeps the last one's sensitivities and steps."""
        if self._cache is None:
            raise RuntimeError("remember_cost needs a build to keep the moving terms of")
        self._cache.p_data = p_data.copy()
        self._p_stale = False


class _HessianCache:
    """The cost terms and the moving terms a Hessian was built from (also as sensitivities
    and steps; those turned to stage 0's body frame when first asked: only an isotropic
    cost looks at them, and turning costs as much as the rest of the check)."""

    def __init__(self, p_data: FloatArray, terms: FloatArray, sensitivity: FloatArray,
                 displacement: FloatArray) -> None:
        self.p_data = p_data
        self.terms = terms
        self.sensitivity = sensitivity
        self.displacement = displacement
        self._turned: tuple[FloatArray, FloatArray] | None = None

    def moved_turned(self, sensitivity: FloatArray, displacement: FloatArray,
                     dt: float) -> float:
        """The largest change of a turned sensitivity or of a turned step times ``dt`` from
        the cached ones turned."""
        if self._turned is None:
            self._turned = _unrotated(self.sensitivity, self.displacement)
        b, d = self._turned
        return max(float(np.abs(sensitivity - b).max()),
                   float(np.abs(displacement - d).max()) * dt)


def _unrotated(sensitivity: FloatArray,
               steps: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The sensitivities (N, 3, 3) and planar steps (N, 2) with the world frame turned so
    that stage 0's body x axis is the world x axis: equal for plans that differ by a
    rotation of the whole plan."""
    first = sensitivity[0]
    angle = math.atan2(first[1, 0] - first[0, 1], first[0, 0] + first[1, 1])
    c, s = math.cos(angle), math.sin(angle)
    turn = np.array([[c, s], [-s, c]])  # world -> stage 0's frame
    turned = np.empty_like(sensitivity)
    np.matmul(turn, sensitivity[:, :2, :], out=turned[:, :2, :])
    turned[:, 2, :] = sensitivity[:, 2, :]
    return turned, steps @ turn.T
