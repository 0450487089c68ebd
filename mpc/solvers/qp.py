"""Fast path: one sparse QP per tick solved by OSQP (real-time iteration).

Each tick linearises the CasADi model around the guess (the shifted previous
plan; one mapped call for all stages), writes the dynamics entries of ``A``,
the bounds and the cost terms into the buffers OSQP was set up with
(:mod:`.qp_structure`: patterns never change), warm starts primal and dual
from the shifted previous solution, and solves with bounded work.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import osqp

from mpc.arrays import FloatArray
from mpc.buffered import BufferedFunction
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from mpc.profiling import TickProfile
from mpc.robots.drive.motor_limits import stage_limits, update_stage_limits
from mpc.solvers.base import SolveResult
from mpc.solvers.qp_structure import assemble_qp, fill_inequality_bounds, fill_limit_values

_ACCEPTED = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)
#: Out of work before converging: the iterate may still be a usable plan.
_UNFINISHED = (osqp.SolverStatus.OSQP_MAX_ITER_REACHED, osqp.SolverStatus.OSQP_TIME_LIMIT_REACHED)

#: An unfinished iterate is used if its primal residual (the largest violation
#: of the linearised dynamics [m, rad] or of a wheel row [rad/s]) and its dual
#: residual (the cost's stationarity error, in cost units) are below these:
#: real-time iteration uses the iterate it has. Converged solves here end near
#: (0.002, 0.3); a solve stopped after one iteration is around (0.05, 300).
#: The final clamp keeps the command within the wheel limits either way.
USABLE_PRIMAL_RESIDUAL = 0.05
USABLE_DUAL_RESIDUAL = 10.0


class _DirectOsqp:
    """osqp-python's extension object, called directly.

    The public ``update`` and ``solve`` wrappers cost a fifth of the whole tick here
    (bound clipping, a derivative cache, a namespace built from every info
    field; docs/design/osqp-direct-core.md). osqp 1.x keeps the extension object
    behind them as ``OSQP._solver``: a private API, so :func:`direct_core`
    only uses it when it has every method needed, and a test holds it to the
    public API's answer. Our bounds are always finite, so the wrapper's
    clipping to +-OSQP_INFTY is a no-op.
    """

    NEEDED = ("update_data_vec", "update_data_mat", "warm_start", "solve", "info", "solution")

    def __init__(self, core: Any) -> None:
        self.core = core

    def run(self, q: FloatArray, lower: FloatArray, upper: FloatArray, p_data: FloatArray,
            a_data: FloatArray, x: FloatArray, y: FloatArray) -> tuple[Any, FloatArray,
                                                                       FloatArray]:
        core = self.core
        core.update_data_vec(q=q, l=lower, u=upper)
        core.update_data_mat(P_x=p_data, P_i=None, A_x=a_data, A_i=None)
        core.warm_start(x, y)
        core.solve()
        return core.info, core.solution.x, core.solution.y


class _PublicOsqp:
    """The same through osqp-python's public API."""

    def __init__(self, solver: osqp.OSQP) -> None:
        self.solver = solver

    def run(self, q: FloatArray, lower: FloatArray, upper: FloatArray, p_data: FloatArray,
            a_data: FloatArray, x: FloatArray, y: FloatArray) -> tuple[Any, FloatArray,
                                                                       FloatArray]:
        solver = self.solver
        solver.update(q=q, l=lower, u=upper, Px=p_data, Ax=a_data)
        solver.warm_start(x=x, y=y)
        result = solver.solve(raise_error=False)
        return result.info, result.x, result.y


def direct_core(solver: osqp.OSQP) -> _DirectOsqp | _PublicOsqp:
    """The fastest way to drive ``solver`` that this osqp version offers."""
    core = getattr(solver, "_solver", None)
    if core is not None and all(hasattr(core, name) for name in _DirectOsqp.NEEDED):
        return _DirectOsqp(core)
    return _PublicOsqp(solver)


class QpSolver:
    """OSQP real-time-iteration solver of a :class:`~mpc.model.tracking.TrackingModel`.

    Args:
        model: the tracking problem.
        polygon_sides: sides of the polygon inscribed in a swerve module's speed
            disk (even, >= 4); robots with exact linear rows ignore it.
        max_iter: OSQP iterations per tick at most.
        time_limit: OSQP time per tick at most [s]; 0 for none.
        tolerance: OSQP's absolute and relative tolerance.
        use_extension: call osqp's extension object directly where this osqp version
            has it (:class:`_DirectOsqp`, a quicker tick); False uses the public API.
    """

    name = "osqp"
    profile: TickProfile | None = None

    def __init__(self, model: TrackingModel, polygon_sides: int | None = None, max_iter: int = 500,
                 time_limit: float = 0.0, tolerance: float = 1e-5,
                 use_extension: bool = True) -> None:
        self.model = model
        self.limits = stage_limits(model.robot, model.change_times, polygon_sides)
        self.structure = structure = assemble_qp(model, self.limits)
        n = model.horizon
        self._p_data = structure.hessian.data.copy()
        self._q = np.zeros(model.layouts.variables.size)
        self._bound_tick: TickInput | None = None  # the tick the cost buffer reads from
        self._evaluate_cost = BufferedFunction(
            structure.cost_terms, [np.zeros(model.layouts.parameters.size)],
            [self._p_data, self._q])
        self._a_data = structure.constraints.data.copy()
        self._lower, self._upper = structure.lower.copy(), structure.upper.copy()
        self._n_gaps = 3 * (n + 1)
        self._solver = osqp.OSQP()
        self._solver.setup(
            structure.hessian, self._q, structure.constraints, self._lower, self._upper,
            verbose=False, warm_starting=True, polishing=False, max_iter=int(max_iter),
            time_limit=float(time_limit) if time_limit > 0 else 1e10,
            eps_abs=float(tolerance), eps_rel=float(tolerance), check_termination=5)
        self._initial_rho = float(self._solver.settings.rho)
        self.backend = direct_core(self._solver) if use_extension else _PublicOsqp(self._solver)
        self._dual: FloatArray | None = None
        self._zero_dual = np.zeros(structure.lower.size)
        # Zero-copy linearisation: CasADi reads the (N, 3) arrays as its 3 x N inputs and
        # writes (N, 21) rows (c_k, vec A_k, vec B_k).
        self._lin_poses = np.zeros((n, 3))
        self._lin_twists = np.zeros((n, 3))
        self._lin_out = np.zeros((n, 21))
        self._linearize = BufferedFunction(model.linearization,
                                           [self._lin_poses, self._lin_twists], [self._lin_out])

    def reset(self) -> None:
        """Forget the warm start and OSQP's adapted step size, so that a run repeats exactly."""
        self._dual = None
        self._solver.update_settings(rho=self._initial_rho)

    def solve(self, tick: TickInput) -> SolveResult:
        """Solve one tick around the guess in ``tick``."""
        structure = self.structure
        self._lin_poses[:] = tick.guess_poses[:-1]
        self._lin_twists[:] = tick.guess_twists
        self._linearize()
        stages = self._lin_out
        self._a_data[structure.dynamics_slots] = -stages[:, 3:]
        lower, upper, gaps = self._lower, self._upper, self._n_gaps
        lower[:3] = tick.pose
        lower[3:gaps] = stages[:, :3].ravel()
        upper[:gaps] = lower[:gaps]
        if not self.limits.constant:
            update_stage_limits(self.model.robot, self.limits, tick.guess_twists,
                                tick.last_twist, tick.steer_angles)
            if self.limits.changed:
                fill_limit_values(structure, self._a_data)
        fill_inequality_bounds(structure, tick, lower, upper)
        if tick is not self._bound_tick:  # read p in place from now on (no copy a tick)
            self._evaluate_cost = BufferedFunction(self.structure.cost_terms, [tick.parameters],
                                                   [self._p_data, self._q])
            self._bound_tick = tick
        self._evaluate_cost()
        dual = self._zero_dual if self._dual is None else self._dual[structure.dual_shift]
        info, solution, multipliers = self.backend.run(
            self._q, lower, upper, self._p_data, self._a_data, tick.guess, dual)
        usable = info.status_val in _ACCEPTED or (
            info.status_val in _UNFINISHED
            and info.prim_res <= USABLE_PRIMAL_RESIDUAL
            and info.dual_res <= USABLE_DUAL_RESIDUAL)
        # A sum is non-finite if any entry is (or if it overflows: then too, distrust it).
        success = usable and math.isfinite(solution.sum())
        self._dual = multipliers.copy() if success else None
        variables = self.model.layouts.variables
        return SolveResult(
            success=success,
            status=str(info.status),
            poses=variables.view(solution, "poses"),
            twists=variables.view(solution, "twists"),
            progress=variables.view(solution, "progress") if self.model.path else None,
            # OSQP's own time: the KKT refactorisation done in update() plus the iterations.
            solve_time=float(info.update_time + info.solve_time),
            iterations=int(info.iter),
        )
