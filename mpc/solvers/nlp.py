"""Exact path: the nonlinear tracking problem solved by IPOPT (the yardstick).

Multiple shooting over ``z`` with the exact dynamics, parameterised by ``p``
(see :mod:`mpc.model.layout`), its derivatives built once per distinct
problem (solvers of one problem share them: :func:`build_ipopt`), warm started
from the guess (the shifted previous plan). Wheel limits are exact: each robot
gives its own CasADi expressions (:meth:`~mpc.robots.Robot.casadi_limits`: linear rows
for Swedish wheels, disks for swerve modules), on every twist for speed and
on every change of twist for acceleration. In path mode the reference is
expanded to second order in the progress around where it was sampled
(within the trust region the bounds on ``s_k`` set) and the progress bounds
are bounds on ``z``.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from typing import Any

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from mpc.profiling import TickProfile
from mpc.robots.drive.motor_nlp import nlp_stage_limits
from mpc.solvers.base import SolveResult

#: CasADi's derivatives of each problem built so far (IPOPT's ``grad_f``, ``jac_g`` and
#: ``hess_lag``), keyed by :func:`_problem_key`: deriving them is most of a caster robot's
#: set-up, so solvers of one problem share them (each builds its own IPOPT from them).
_DERIVATIVES: OrderedDict[str, dict[str, ca.Function]] = OrderedDict()
#: Problems kept at most, and their derivatives' CasADi instructions at most (a caster
#: robot's take 1.5 million, a Mecanum robot's 14 thousand); least recently used dropped.
_DERIVATIVES_MAX = 32
_DERIVATIVES_INSTRUCTIONS = 4_000_000
_DERIVATIVES_LOCK = threading.Lock()
#: nlpsol's names of the derivatives, by the option that takes each.
_DERIVED = {"grad_f": "nlp_grad_f", "jac_g": "nlp_jac_g", "hess_lag": "nlp_hess_l"}


def _problem_key(problem: dict[str, ca.SX], options: dict[str, Any]) -> str:
    """A digest of everything that defines the derivatives: the expressions of the cost and
    constraints in ``x`` and ``p`` (every number in them) and nlpsol's options (IPOPT's own,
    such as ``max_iter``, change the solve, not the derivatives)."""
    function = ca.Function("problem", [problem["x"], problem["p"]],
                           [problem["f"], problem["g"]])
    shared = {name: value for name, value in options.items() if name != "ipopt"}
    text = function.serialize() + repr(sorted(shared.items()))
    return hashlib.sha256(text.encode()).hexdigest()


def _kept_instructions() -> int:
    return sum(f.n_instructions() for kept in _DERIVATIVES.values() for f in kept.values())


def build_ipopt(problem: dict[str, ca.SX], options: dict[str, Any]) -> ca.Function:
    """IPOPT for ``problem`` with ``options``, from the derivatives of an identical problem
    built before if there is one (:data:`_DERIVATIVES`)."""
    key = _problem_key(problem, options)
    with _DERIVATIVES_LOCK:
        derivatives = _DERIVATIVES.get(key)
        if derivatives is not None:
            _DERIVATIVES.move_to_end(key)
    if derivatives is not None:
        return ca.nlpsol("tracking_nlp", "ipopt", problem, {**options, **derivatives})
    solver = ca.nlpsol("tracking_nlp", "ipopt", problem, options)
    with _DERIVATIVES_LOCK:
        _DERIVATIVES[key] = {option: solver.get_function(name)
                             for option, name in _DERIVED.items()}
        while len(_DERIVATIVES) > 1 and (len(_DERIVATIVES) > _DERIVATIVES_MAX
                                         or _kept_instructions() > _DERIVATIVES_INSTRUCTIONS):
            _DERIVATIVES.popitem(last=False)
    return solver


class NlpSolver:
    """IPOPT solver of a :class:`~mpc.model.tracking.TrackingModel`.

    Solvers of one problem (the same cost and constraints) share CasADi's derivatives of
    it, built by the first; each keeps its own IPOPT, options and bounds.

    Args:
        model: the tracking problem.
        max_iter: IPOPT iterations per tick at most.
        time_limit: IPOPT wall time per tick at most [s]; 0 for none.
        tolerance: IPOPT's ``tol``.
    """

    name = "ipopt"
    profile: TickProfile | None = None

    def __init__(self, model: TrackingModel, max_iter: int = 100, time_limit: float = 0.0,
                 tolerance: float = 1e-8) -> None:
        self.model = model
        z, p = model.symbols()
        constraints: list[ca.SX] = [model.shooting_gaps(z, p)]
        lower: list[FloatArray] = []
        upper: list[FloatArray] = []
        gaps = 3 * (model.horizon + 1)
        lower.append(np.zeros(gaps))
        upper.append(np.zeros(gaps))
        variables, parameters = model.layouts
        steer = (parameters.symbol(p, "steer_angles") if "steer_angles" in parameters.fields
                 else None)
        g, low, high = nlp_stage_limits(
            model.robot, variables.symbol(z, "twists"), parameters.symbol(p, "last_twist"), steer,
            model.change_times)
        constraints += g
        lower += low
        upper += high
        if model.path:
            progress = variables.symbol(z, "progress")
            constraints.append(progress[1:] - progress[:-1])
            lower.append(np.zeros(model.horizon))
            upper.append(model.max_progress_rate * model.durations)
        problem = {"x": z, "p": p, "f": model.cost(z, p, exact=True),
                   "g": ca.vertcat(*constraints)}
        options: dict[str, Any] = {
            "expand": True, "print_time": False, "record_time": True, "error_on_fail": False,
            "ipopt": {"print_level": 0, "sb": "yes", "max_iter": int(max_iter),
                      "tol": float(tolerance),
                      "max_wall_time": float(time_limit) if time_limit > 0 else 1e20},
        }
        self._solver = build_ipopt(problem, options)
        self._lbg = np.concatenate(lower)
        self._ubg = np.concatenate(upper)
        self._lbx = np.full(variables.size, -np.inf)
        self._ubx = np.full(variables.size, np.inf)
        self._progress = variables["progress"].slice if model.path else None

    def reset(self) -> None:
        """Nothing to forget: IPOPT is warm started from the primal guess only."""

    def solve(self, tick: TickInput) -> SolveResult:
        """Solve one tick from the guess in ``tick``."""
        if self._progress is not None and tick.path is not None:
            self._lbx[self._progress] = tick.path.lower
            self._ubx[self._progress] = tick.path.upper
        output = self._solver(x0=tick.guess, p=tick.parameters, lbg=self._lbg, ubg=self._ubg,
                              lbx=self._lbx, ubx=self._ubx)
        stats = self._solver.stats()
        solution = output["x"].full().ravel()
        success = bool(stats.get("success", False)) and bool(np.all(np.isfinite(solution)))
        variables = self.model.layouts.variables
        return SolveResult(
            success=success,
            status=str(stats.get("return_status", "unknown")),
            poses=variables.view(solution, "poses"),
            twists=variables.view(solution, "twists"),
            progress=variables.view(solution, "progress") if self.model.path else None,
            solve_time=float(stats.get("t_wall_total", 0.0)),
            iterations=int(stats.get("iter_count", 0)),
        )
