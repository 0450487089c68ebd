"""Fast path on a condensed QP: daqp, a dual active-set solver, one dense QP per tick.

Each tick: one CasADi call gives the cost terms, the rollout of the guess twists
from the measured pose with its input sensitivities, and the cost's exact gradient
along it (:func:`~mpc.solvers.condensed.tick_terms`); the QP is condensed onto
the inputs (:mod:`.condensed`) and daqp solves it, warm started from its own last
active set (daqp keeps it between solves).

The QP is posed in the step from the guess with the cost's exact gradient
there, so the Hessian only shapes the step: a new one is begun only when the
sensitivities or the rollout's steps moved by :data:`REBUILD_EARLY` times
:data:`SENSITIVITY_TOLERANCE` since the last build (:mod:`.hessian_reuse`), and
built over four ticks so that no tick carries a whole rebuild; it is rebuilt at
once when they moved beyond :data:`REBUILD_NOW` times, or the cost terms beyond
:data:`COST_TOLERANCE`. daqp sees the QP in whitened steps (Hessian the
identity), so a new Hessian costs it new rows, not a refactorisation.

Rows a robot marks as guards (``StageLimits.guards``: swerve's speed faces at +-45 and 90
deg) stay out of daqp's problem: the plan is checked against them and the tick solved again
with them when it breaks one. Rows whose refill may be skipped (``StageLimits.inside``:
swerve's faces, supporting lines of its speed disks) are kept from the last tick while the
last plan kept well inside the disks with none of them active: no new rows for daqp; the
plan is checked, and the rows turned and the tick solved again when it reaches an edge.
Rows a robot marks as seldom needed (``StageLimits.screened``: motor rows) leave daqp's
problem once no plan has needed them for a while (:mod:`.row_screen`): the plan is checked
against them, and the tick solved again with those it breaks.

daqp is an order of magnitude quicker here than the other QP solvers installable
(``mpc-bench qp-replay`` solves a run's recorded :class:`WhitenedQp` s with each;
docs/design/qp-solver-choice.md).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any, NamedTuple

import casadi as ca
import daqp
import numpy as np
from scipy import sparse
from scipy.linalg import lapack

from mpc.arrays import FloatArray
from mpc.buffered import BufferedFunction
from mpc.model.jit import jitted
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from mpc.profiling import TickProfile
from mpc.robots.drive.motor_limits import stage_limits, update_stage_limits
from mpc.robots.limits import (
    StageLimits,
    leading_rows,
    overshoot,
    rounding_slack,
    stage_values,
    trailing_rows,
)
from mpc.solvers.base import SolveResult
from mpc.solvers.condensed import Condenser, plan_poses, tick_terms
from mpc.solvers.hessian_reuse import COST_TOLERANCE, SENSITIVITY_TOLERANCE, HessianReuse
from mpc.solvers.qp_structure import QpStructure, assemble_qp, fill_inequality_bounds
from mpc.solvers.row_screen import RowScreen

__all__ = ["COST_ONLY_DRIFT", "COST_TOLERANCE", "KEEP_ROWS_BELOW", "REBUILD_EARLY",
           "REBUILD_NOW", "SENSITIVITY_TOLERANCE", "DenseSolver", "WhitenedQp"]

#: A new Hessian is begun once the sensitivities or the rollout's steps moved this
#: multiple of their tolerance from the one in use; it is built over four ticks of about
#: the same work (see :meth:`DenseSolver._rebuild_stages`), so no tick carries a whole
#: rebuild. Cost terms that moved beyond their tolerance (path mode's contour directions)
#: rebuild at once: staged, they left the fixed-heading circles slower and further off the
#: path (docs/design/hessian-reuse.md).
REBUILD_EARLY = 1.0

#: Beyond this multiple of their tolerance (the plan moves fast: a turning heading; or the
#: guess jumped) the Hessian is rebuilt at once: three more ticks on one that far off took
#: daqp to its iteration limit at N = 100 (docs/design/hessian-reuse.md).
REBUILD_NOW = 2.0

#: A rebuild for moved cost terms keeps the last build's state sensitivities ``S`` (a
#: part of the rebuild) while the sensitivities and steps are within this multiple of
#: their tolerance of that build's; at the whole tolerance path mode lagged a feasible
#: reference (docs/design/hessian-reuse.md).
COST_ONLY_DRIFT = 0.25

#: Row sets up to this many entries are multiplied dense, larger ones sparse
#: (:class:`_FixedBounds`).
_DENSE_ROWS = 20_000

#: daqp's constraint flags: an equality row (active and immutable); a row active at its
#: upper, at its lower bound (a warm start).
_EQUALITY, _ACTIVE, _ACTIVE_LOWER = 5, 1, 3

#: A plan whose moving rows are all inactive and that keeps within this fraction of the
#: sets they support (``StageLimits.inside``: swerve's speed disks) lets the next tick keep
#: those rows rather than refill them (checked after its solve all the same; the margin
#: keeps plans near the edge from solving twice).
KEEP_ROWS_BELOW = 0.98

#: The exit flags of a tick whose second daqp model, with the guard rows, or with screened
#: rows its plan broke, could not be set up.
_GUARDED_SET_UP_FAILED, _SCREENED_SET_UP_FAILED = -100, -101

#: Rounds of a tick solved again with screened rows its plan broke (:mod:`.row_screen`)
#: before every row is back in daqp's problem.
_SCREEN_ROUNDS = 2

_STATUS = {1: "solved", 2: "solved (soft)", -1: "infeasible", -2: "cycling", -3: "unbounded",
           -4: "maximum iterations reached", -5: "nonconvex", -6: "initial point infeasible",
           -7: "time limit reached",
           _GUARDED_SET_UP_FAILED: "daqp set-up failed (with the guard rows)",
           _SCREENED_SET_UP_FAILED: "daqp set-up failed (with rows the plan broke)"}


class WhitenedQp(NamedTuple):
    """The QP a tick hands daqp (its first; not the guarded or screened solves again), in
    whitened steps ``y``: minimise ``y'y / 2 + gradient' y`` subject to ``lower <= rows y <=
    upper`` (copies, kept by :attr:`DenseSolver.record`)."""

    gradient: FloatArray
    rows: FloatArray
    lower: FloatArray
    upper: FloatArray


class DenseSolver:
    """daqp real-time-iteration solver of a :class:`~mpc.model.tracking.TrackingModel`.

    Args:
        model: the tracking problem.
        polygon_sides: sides of the polygon inscribed in a swerve module's speed
            disk (even, >= 4); robots with exact linear rows ignore it.
        max_iter: daqp iterations per tick at most.
        time_limit: daqp time per tick at most [s]; 0 for none.
        jit: compile the tick's CasADi terms and the plan's poses to C
            (:func:`~mpc.model.jit.jitted`).
    """

    name = "daqp"

    def __init__(self, model: TrackingModel, polygon_sides: int | None = None, max_iter: int = 1000,
                 time_limit: float = 0.0, jit: bool = False) -> None:
        self.model = model
        n = model.horizon
        every = stage_limits(model.robot, model.change_times, polygon_sides)
        self._every_limit = every
        # Guard rows (StageLimits.guards, each stage's last) stay out of daqp's problem:
        # the plan is checked against them, and solved again with them when it breaks one
        # (_solve_guarded). Both sets are views of the robot's rows, refilled with them.
        self.limits = every  # the rows daqp solves with
        self._guards: StageLimits | None = None
        # Rows whose refill may be skipped (StageLimits.inside): kept this tick, and whether
        # the last plan allows keeping them the next; daqp's moving rows, to check both.
        self._kept_rows = self._keep_rows_next = False
        self._guard_slack = 0.0  # how far past a guard row rounding may take a plan
        if every.guards:
            self.limits = leading_rows(every, every.rows - every.guards)
            self._guards = trailing_rows(every, every.guards)
            if self._guards.before.any():
                raise RuntimeError("guard rows must be on u_k alone (StageLimits.guards)")
            self._guard_slack = rounding_slack(self._guards.lower, self._guards.upper)
        structure = assemble_qp(model, self.limits)
        self.structure = structure
        moving = self.limits.rows if self.limits.moving is None else self.limits.moving
        self._moving_rows = (self.limits.rows * np.arange(n)[:, None]  # daqp's, stage-major
                             + np.arange(moving)).ravel()
        self.condenser = Condenser(model, structure)
        self._p_data = structure.hessian.data.copy()
        terms, plan = tick_terms(model, structure.cost_terms), plan_poses(n)
        self._terms = jitted(terms) if jit else terms
        self._terms_for: TickInput | None = None
        self._evaluate: BufferedFunction | None = None
        self._rollout = np.zeros((n + 1, 3))
        # the terms that move the Hessian, in one vector (one drift check): vec B_k (N, 9)
        # column-major as CasADi writes them, then the rollout's planar steps (N, 2)
        self._moving = np.zeros(11 * n)
        self._sensitivity_vec = self._moving[:9 * n].reshape(n, 9)
        self._displacement = self._moving[9 * n:].reshape(n, 2)
        self._gradient = np.zeros(self.condenser.size)  # the cost's, in y, at the guess
        self._step = np.zeros(self.condenser.size)  # the QP's step in y from the guess
        self._poses = np.zeros((n + 1, 3))  # the plan's
        self._plan = BufferedFunction(
            jitted(plan) if jit else plan,
            [self._rollout, self._sensitivity_vec, self._step[:3 * n], self._displacement],
            [self._poses])
        self._lower, self._upper = structure.lower.copy(), structure.upper.copy()
        self._fixed_bounds = (_FixedBounds(structure, self.condenser)
                              if self.limits.constant else None)
        self._reuse = HessianReuse(self._p_data, model.dt, n)
        self._scattered = np.full_like(self._p_data, np.nan)
        # A cost Hessian that no parameter moves (time mode's) is scattered once, not
        # compared with the last one every tick.
        p = ca.SX.sym("p", structure.cost_terms.size1_in(0))
        self._p_moves = bool(ca.depends_on(structure.cost_terms(p)[0], p))
        self._p_settled = False
        self._isotropic = False  # whether the cost weighs positions alike in every direction
        self._settings = {"iter_limit": int(max_iter), "time_limit": float(time_limit)}
        self._solver: daqp.Model | None = None
        # daqp gets the problem in whitened steps y = L' d (H = L L'), its Hessian the
        # identity: a new Hessian or new rows (swerve, motor limits) cost a Cholesky
        # factor, its inverse and one batch of small products here rather than daqp's
        # refactorisation and triangular solves of every row (quicker rebuild ticks:
        # docs/design/hessian-reuse.md).
        self._unwhiten = np.eye(self.condenser.size)  # L^{-T}: d = L^{-T} y
        self._whitened_rows = self.condenser.constraints.copy()
        self._extra = _SparseRows(self.condenser.constraints[n * self.limits.rows:])
        self._rebuild: Iterator[bool] | None = None  # a Hessian being built, stage by stage
        self._rows_stale = True  # the whitened rows are not yet of the present L^{-T}
        self._rows_new = False  # new whitened rows for daqp (a finished rebuild's)
        self._whitened_gradient = np.zeros(self.condenser.size)  # the last one daqp got
        self.factorisations = 0  # Hessian rebuilds so far (for benchmarks)
        self.cost_rebuilds = 0  # of those, with the last build's S (for benchmarks)
        self.guarded_solves = 0  # ticks solved again with the guard rows (for benchmarks)
        self.kept_rows = 0  # ticks that kept the last refill's rows (for benchmarks)
        self.late_refills = 0  # of those, ticks whose plan made them refill after all
        # Rows left out of daqp's problem while no plan needs them (StageLimits.screened;
        # not with guards or kept rows, which count on daqp having every row they do not,
        # nor with constant rows, whose whitened set a Hessian rebuild installs a tick
        # late); a new model's warm start when the rows it has changed (its multipliers, in
        # the solver's row order).
        self._screen: RowScreen | None = None
        if (self.limits.screened and not self.limits.constant and not every.guards
                and self.limits.inside is None):
            extra = self.condenser.constraints.shape[0] - n * self.limits.rows
            self._screen = RowScreen(self.limits, extra)
        self._next_start: FloatArray | None = None
        self.screened_solves = 0  # ticks solved again with rows their plan broke
        self.profile: TickProfile | None = None  # phase stopwatch, set by the controller
        # Each tick's QP, copied, when a list (``mpc-bench qp-replay``: other solvers on them)
        self.record: list[WhitenedQp] | None = None

    @property
    def stage_rows_solved(self) -> int:
        """Limit rows a stage in daqp's problem now: the rows without the guards, fewer
        while screened rows are left out (:mod:`.row_screen`)."""
        screen = self._screen
        return self.limits.rows if screen is None else int(screen.in_play.sum())

    def reset(self) -> None:
        """Forget the active set and the cached factorisation."""
        self._keep_rows_next = False
        self._solver = None
        self._rebuild = None
        self._reuse.forget()
        self._next_start = None
        if self._screen is not None:
            self._screen.reset()

    def _bind(self, tick: TickInput) -> BufferedFunction:
        """The tick's terms (:func:`~mpc.solvers.condensed.tick_terms`) as a CasADi buffer
        that reads the tick's vectors in place."""
        if self._terms_for is not tick or self._evaluate is None:
            inputs = [tick.parameters, tick.guess_twists]
            if tick.path is not None:
                inputs.append(tick.path.guess_progress)
            self._evaluate = BufferedFunction(
                self._terms, inputs,
                [self._p_data, self._rollout, self._sensitivity_vec, self._gradient,
                 self._displacement])
            self._terms_for = tick
        return self._evaluate

    def _sensitivities(self) -> FloatArray:
        """``B_k`` (N, 3, 3) from the column-major vectors CasADi wrote."""
        return self._sensitivity_vec.reshape(-1, 3, 3).transpose(0, 2, 1)

    def solve(self, tick: TickInput) -> SolveResult:
        """Solve one tick around the guess twists (and progress) in ``tick``."""
        profile = self.profile
        sensitivity, displacement, (cost_drift, drift) = self._linearise(tick)
        if profile is not None:
            profile.mark("solve: model")
        gradient = self._gradient
        rows_changed = self._refill_rows(tick)
        lower, upper = every_lower, every_upper = self._step_bounds(tick)
        screen = self._screen
        if screen is not None:
            lower, upper = screen.picked(lower), screen.picked(upper)
        if profile is not None:
            profile.mark("solve: condense")
        pending = self._rebuild
        building = pending is not None
        if self._solver is None or cost_drift > 1.0 or drift > REBUILD_NOW:  # all now
            # Only the cost terms moved (path mode's, most ticks): the sensitivities and
            # steps are close to the last build's, whose S is kept; not where that is so
            # only up to a rotation.
            cost_only = (self._solver is not None and drift <= COST_ONLY_DRIFT
                         and not self._isotropic)
            for _ in self._start_rebuild(sensitivity, displacement, cost_only):  # all of it
                pass
            self._rebuild, building = None, True
        elif pending is None:
            if drift > REBUILD_EARLY:
                self._start_rebuild(sensitivity, displacement)
                building = True
        elif not next(pending, False):
            self._rebuild = None  # the new Hessian took over this tick
        if profile is not None and building:
            profile.mark("solve: hessian")
        solver = self._update(gradient, lower, upper, rows_changed, profile)
        if profile is not None:
            profile.mark("solve: daqp update")
        if self.record is not None:
            self.record.append(WhitenedQp(self._whitened_gradient.copy(),
                                          self._whitened_rows.copy(), lower.copy(),
                                          upper.copy()))
        if solver is None:  # daqp refused the problem at set-up: a failed tick
            n = self.model.horizon
            return SolveResult(success=False, status="daqp set-up failed",
                               poses=np.full((n + 1, 3), np.nan),
                               twists=np.full((n, 3), np.nan), solve_time=0.0, iterations=0)
        whitened_step, _, flag, info = solver.solve()
        if profile is not None:
            profile.mark("solve: daqp solve")
        step = np.matmul(self._unwhiten, whitened_step, out=self._step)
        if screen is not None and flag > 0:
            flag, info = self._check_screened(tick, screen, info, every_lower, every_upper)
        twists = self._plan_twists(tick)
        if self._kept_rows and flag > 0 and not self._rows_may_stay(info, twists, 1.0):
            flag, info, lower, upper = self._solve_refilled(tick, solver, info)
            twists = self._plan_twists(tick)
        self._keep_rows_next = flag > 0 and self._rows_may_stay(info, twists, KEEP_ROWS_BELOW)
        if flag > 0 and not self._guards_hold(twists):
            flag, info = self._solve_guarded(tick, lower, upper, info)
            twists = self._plan_twists(tick)
        if profile is not None:
            profile.mark("solve: checks")
        result = self._result(tick, step, twists, int(flag), info)
        if profile is not None:
            profile.mark("solve: result")
        return result

    def _linearise(self, tick: TickInput
                   ) -> tuple[FloatArray, FloatArray, tuple[float, float]]:
        """Evaluate the tick's terms (the cost's, the rollout of the guess and the
        gradient along it): the sensitivities ``B_k``, the rollout's planar steps, and how
        far the cost terms and these moved from the Hessian's (multiples of the
        tolerances, :meth:`HessianReuse.drift`)."""
        self._bind(tick)()
        sensitivity = self._sensitivities()
        p_changed = (not self._p_settled
                     and not (self._p_data == self._scattered).all())  # (array_equal: slower)
        self._p_settled = not self._p_moves
        if p_changed:
            self.condenser.scatter(self._p_data)
            self._scattered[:] = self._p_data
            self._isotropic = self.condenser.isotropic()
        displacement = self._displacement
        drift = self._reuse.drift(self._p_data, self._moving, sensitivity, displacement,
                                  p_changed, self._isotropic, REBUILD_EARLY)
        return sensitivity, displacement, drift

    def _start_rebuild(self, sensitivity: FloatArray, displacement: FloatArray,
                       cost_only: bool = False) -> Iterator[bool]:
        """Begin a new Hessian from this tick's terms (``cost_only``: this tick's cost terms
        and the last build's ``S``, a part of a rebuild): its first stage
        runs now; the rest are returned (and kept in ``_rebuild``)."""
        self.factorisations += 1
        if cost_only:
            self.cost_rebuilds += 1
            self._reuse.remember_cost(self._p_data)
        else:
            self._reuse.remember(self._p_data, self._moving, sensitivity, displacement)
        rebuild = self._rebuild_stages(None if cost_only else (sensitivity, displacement))
        next(rebuild)
        self._rebuild = rebuild
        return rebuild

    def _rebuild_stages(self, terms: tuple[FloatArray, FloatArray] | None
                        ) -> Iterator[bool]:
        """A new Hessian in stages of about the same work, one a tick (see
        :data:`REBUILD_EARLY`): the state sensitivities ``S`` from this tick's ``terms``
        (sensitivities and steps; None: the last build's ``S``); ``H`` and its Cholesky
        factor; the whitening ``L^{-T}`` and the rows whitened by it; then the switch (daqp
        gets the rows with the same tick's gradient, so every QP is posed with one
        Hessian)."""
        condenser = self.condenser
        states = (condenser.last_states() if terms is None
                  else condenser.state_sensitivities(*terms))
        yield True
        factor = _factor(self.condenser.hessian(states))
        yield True
        unwhiten = _inverse_transpose(factor)
        whitened = None if not self.limits.constant else self._whitened(unwhiten)
        yield True
        self._unwhiten = unwhiten
        if whitened is None:  # rows that move every tick are whitened with them
            self._rows_stale = True
        else:
            self._whitened_rows, self._rows_new = whitened, True

    def _refill_rows(self, tick: TickInput) -> bool:
        """Refill the limit rows of robots whose limits move (swerve); whether they did.
        Rows that may stay (``StageLimits.inside``) are kept as they are when the last
        plan kept well inside their sets with none of them active (``_kept_rows``: the
        plan is checked after the solve)."""
        self._kept_rows = self._keep_rows_next and self.limits.inside is not None
        if self._kept_rows:
            self.kept_rows += 1
            return False
        if self.limits.constant:
            return False
        every = self._every_limit
        update_stage_limits(self.model.robot, every, tick.guess_twists, tick.last_twist,
                            tick.steer_angles)
        self.limits.changed = every.changed  # (the same rows, seen as daqp's)
        return every.changed

    def _step_bounds(self, tick: TickInput) -> tuple[FloatArray, FloatArray]:
        """The condensed rows' bounds on the step from the guess."""
        fixed = self._fixed_bounds
        if fixed is not None:
            return fixed.step(tick)
        fill_inequality_bounds(self.structure, tick, self._lower, self._upper)
        condenser = self.condenser
        first = condenser.first_row
        at_guess = self._rows_at_guess(tick)
        return self._lower[first:] - at_guess, self._upper[first:] - at_guess

    def _rows_at_guess(self, tick: TickInput) -> FloatArray:
        """The inequality rows' values at the guess, the limit rows stage by stage (stage
        0's part on the last command is in its bounds)."""
        limits, condenser = self.limits, self.condenser
        n, m = limits.horizon, limits.rows
        values = np.empty(condenser.constraints.shape[0])
        stage_values(limits, tick.guess_twists, out=values[:n * m].reshape(n, m))
        if values.size > n * m:
            values[n * m:] = condenser.constraints[n * m:] @ tick.guess[condenser.columns]
        return values

    def _update(self, gradient: FloatArray, lower: FloatArray, upper: FloatArray,
                rows_changed: bool, profile: TickProfile | None = None) -> daqp.Model | None:
        """Hand daqp what changed, in whitened steps ``y = L' d``: Hessian the identity,
        rows ``A L^{-T}``, gradient ``L^{-1} g`` (None if daqp refuses to set it up);
        ``profile``, if given, marks the whitening's end."""
        new_rows = rows_changed or self._rows_stale or self._rows_new
        if self._rows_stale or rows_changed:
            # rows whitened by the same L^{-T} before, and not moved since, are kept
            self._whitened_rows = self._whitened(self._unwhiten, self._whitened_rows,
                                                 moving_only=not self._rows_stale)
        self._rows_stale = self._rows_new = False
        whitened_gradient = self._unwhiten.T @ gradient
        self._whitened_gradient = whitened_gradient
        if profile is not None:
            profile.mark("solve: whiten")
        start, self._next_start = self._next_start, None
        if self._solver is None or start is not None:  # new, or other rows (_check_screened)
            if start is not None and self._screen is not None:
                start = self._screen.picked(start)
            self._solver = self._set_up(whitened_gradient, self._whitened_rows, lower, upper,
                                        start)
            return self._solver  # None if daqp refused it: the next tick sets up again
        update: dict[str, FloatArray] = {"f": whitened_gradient, "bupper": upper,
                                         "blower": lower}
        if new_rows:
            update["A"] = self._whitened_rows
        self._solver.update(**update)
        return self._solver

    def _set_up(self, gradient: FloatArray, rows: FloatArray, lower: FloatArray,
                upper: FloatArray, multipliers: FloatArray | None = None
                ) -> daqp.Model | None:
        """A daqp model of the whitened problem (None if daqp refuses it), its first rows
        marked active where ``multipliers`` (of those rows) are not 0: a warm start."""
        sense = np.zeros(upper.size, dtype=np.intc)
        if multipliers is not None:
            head = sense[:multipliers.size]
            head[multipliers > 0.0] = _ACTIVE
            head[multipliers < 0.0] = _ACTIVE_LOWER
        sense[lower == upper] = _EQUALITY
        solver = daqp.Model()
        flag, _ = solver.setup(np.eye(self.condenser.size), gradient, rows, upper, lower, sense)
        if flag < 0:
            return None
        settings = solver.settings
        settings.update(self._settings)
        solver.settings = settings
        return solver

    def _check_screened(self, tick: TickInput, screen: RowScreen, info: dict[str, Any],
                        lower: FloatArray, upper: FloatArray) -> tuple[int, dict[str, Any]]:
        """After a solve with screened rows left out (:mod:`.row_screen`; ``lower`` and
        ``upper`` the bounds of every row): note the rows the plan has active; solve again
        (a model of its own, warm started, into ``_step``) with the rows left out that the
        plan breaks, every row after :data:`_SCREEN_ROUNDS` such rounds; then leave out,
        from the next tick, the rows no plan has needed for a while. daqp's exit flag and
        its info (the solves' times and iterations summed)."""
        flag, rounds = 1, 0
        if not math.isfinite(float(self._step.sum())):  # not a plan: nothing to check
            return flag, info
        multipliers = screen.full(info["lam"])  # in the solver's row order
        screen.solved(multipliers)
        while (broken := screen.broken(self.limits, self._plan_twists(tick),
                                       tick.last_twist)).size:
            rounds += 1
            screen.admit(broken if rounds <= _SCREEN_ROUNDS else np.arange(screen.stage_rows),
                         self.limits)
            self.screened_solves += 1
            self._whitened_rows = self._whitened(self._unwhiten)
            solver = None
            for start in (screen.picked(multipliers), None):  # warm; cold if daqp refuses
                solver = self._set_up(self._whitened_gradient, self._whitened_rows,
                                      screen.picked(lower), screen.picked(upper), start)
                if solver is not None:
                    break
            self._solver = solver
            if solver is None:
                self._step[:] = np.nan
                return _SCREENED_SET_UP_FAILED, info
            self._limit_time(solver, info)
            whitened_step, _, flag, second = solver.solve()
            solver.settings = self._settings
            np.matmul(self._unwhiten, whitened_step, out=self._step)
            info = _with_first(second, info)
            if flag <= 0:
                return int(flag), info
            multipliers = screen.full(info["lam"])
            screen.solved(multipliers, again=True)
        if screen.retire(self.limits):  # the next tick's model: the rows left (same Hessian)
            self._next_start = multipliers
            self._rows_stale = True
        return int(flag), info

    def _limit_time(self, solver: daqp.Model, first: dict[str, Any]) -> None:
        """A second solve in a tick gets what is left of the time limit after the first
        (its set-up and solve times, ``first``: daqp's info)."""
        limit = self._settings["time_limit"]
        if limit > 0.0:
            settings = solver.settings
            used = float(first["solve_time"]) + float(first["setup_time"])
            settings["time_limit"] = max(limit - used, 1e-6)
            solver.settings = settings

    def _solve_refilled(self, tick: TickInput, solver: daqp.Model, first: dict[str, Any]
                        ) -> tuple[int, dict[str, Any], FloatArray, FloatArray]:
        """A tick that kept the last rows and whose plan reached the edge of their sets:
        the rows turned to this tick's guess after all and the tick solved again (daqp keeps
        its active set; into ``_step``). daqp's exit flag, its info with the first solve's
        (``first``) time and iterations added, and the new step bounds."""
        self._kept_rows = self._keep_rows_next = False
        self.late_refills += 1
        rows_changed = self._refill_rows(tick)
        lower, upper = self._step_bounds(tick)
        self._update(self._gradient, lower, upper, rows_changed)  # the model set up before
        whitened_step, _, flag, info = solver.solve()
        np.matmul(self._unwhiten, whitened_step, out=self._step)
        return int(flag), _with_first(info, first), lower, upper

    def _plan_twists(self, tick: TickInput) -> FloatArray:
        """The plan's twists (N, 3): the guess's plus the step's (in ``_step``)."""
        return tick.guess_twists + self._step[:self.condenser.n_inputs].reshape(-1, 3)

    def _rows_may_stay(self, info: dict[str, FloatArray], twists: FloatArray,
                       ratio: float) -> bool:
        """Whether no moving row is active in the plan of ``twists`` (N, 3) (daqp's
        multipliers in ``info``) and it keeps within ``ratio`` of the sets the moving rows
        support (``StageLimits.inside``)."""
        inside = self.limits.inside
        if inside is None or info["lam"][self._moving_rows].any():
            return False
        return inside(twists, ratio)

    def _guards_hold(self, twists: FloatArray) -> bool:
        """Whether the plan's ``twists`` (N, 3) keep within the guard rows (True without
        any; the rows are on ``u_k`` alone, see :attr:`StageLimits.guards`)."""
        guards = self._guards
        if guards is None:
            return True
        # (stage 0's part on the last command is zero: guards are on u_k alone)
        return bool(overshoot(guards, stage_values(guards, twists)).max()
                    <= self._guard_slack)

    def _solve_guarded(self, tick: TickInput, lower: FloatArray, upper: FloatArray,
                       first: dict[str, Any]) -> tuple[int, dict[str, Any]]:
        """Solve the tick again with the guard rows too (a model of its own, set up for
        it, within what is left of the time limit; into ``_step``): daqp's exit flag, and
        its info with the first solve's (``first``) time and iterations added."""
        guards = self._guards
        assert guards is not None  # only called with guards
        self.guarded_solves += 1
        n, m = guards.horizon, guards.rows
        at_guess = stage_values(guards, tick.guess_twists)  # (on u_k alone)
        whitened = np.empty((n * m, self.condenser.size))
        _whiten_stages(guards.now, guards.before, self._unwhiten, whitened.reshape(n, m, -1))
        problem = (self._whitened_gradient, np.concatenate([self._whitened_rows, whitened]),
                   np.concatenate([lower, (guards.lower - at_guess).ravel()]),
                   np.concatenate([upper, (guards.upper - at_guess).ravel()]))
        # Warm: the first solve's active rows (most of the answer's) marked active; cold
        # if daqp refuses that start.
        flag, info = _GUARDED_SET_UP_FAILED, first
        for multipliers in (first.get("lam"), None):
            solver = self._set_up(*problem, multipliers=multipliers)
            if solver is None:
                continue
            self._limit_time(solver, first)
            whitened_step, _, flag, info = solver.solve()
            if flag > 0:
                break
        if flag == _GUARDED_SET_UP_FAILED:
            self._step[:] = np.nan
            return flag, first
        np.matmul(self._unwhiten, whitened_step, out=self._step)
        return int(flag), _with_first(info, first)

    def _whitened(self, unwhiten: FloatArray, out: FloatArray | None = None,
                  moving_only: bool = False) -> FloatArray:
        """``A L^{-T}`` (into ``out`` if given), stage by stage: stage ``k``'s limit rows
        touch ``u_k`` and ``u_{k-1}`` only, so it is a batch of (m, 3) x (3, n) products
        (small enough that BLAS stays on one thread; one dense product of the whole matrix
        was slow with threads on a loaded machine: docs/design/dense-row-products.md).
        ``moving_only``: ``out``
        holds the rest already, and only the rows a refill moves are done again
        (``limits.moving`` a stage, on ``u_k`` alone: a swerve module's speed faces, 12 of
        the 28 rows a stage daqp solves with). With rows screened out (:mod:`.row_screen`),
        the rows in daqp's problem only."""
        limits = self.limits
        n, m = limits.horizon, limits.rows
        screen = self._screen
        size = self.condenser.constraints.shape[0] if screen is None else screen.size
        whitened = out if out is not None and out.shape[0] == size else np.empty(
            (size, unwhiten.shape[1]))
        if screen is not None and screen.rows is not None:  # the rows in daqp's problem
            play = screen.in_play
            rows = whitened[:size - screen.extra].reshape(n, -1, unwhiten.shape[1])
            _whiten_stages(limits.now[:, play], limits.before[:, play], unwhiten, rows)
            if screen.extra:
                self._extra.times(unwhiten, out=whitened[size - screen.extra:])
            return whitened
        rows = whitened[:n * m].reshape(n, m, -1)
        if moving_only and out is not None and limits.moving is not None:
            k = limits.moving
            np.matmul(limits.now[:, :k], unwhiten[:3 * n].reshape(n, 3, -1), out=rows[:, :k])
            return whitened
        _whiten_stages(limits.now, limits.before, unwhiten, rows)
        if whitened.shape[0] > n * m:  # path mode's progress rows
            self._extra.times(unwhiten, out=whitened[n * m:])
        return whitened

    def _result(self, tick: TickInput, step: FloatArray, twists: FloatArray, flag: int,
                info: dict[str, float]) -> SolveResult:
        """The plan the step (in ``_step``) gives: its ``twists`` (the guess's plus the
        step's), its poses to first order through the sensitivities
        (:func:`~mpc.solvers.condensed.plan_poses`)."""
        n3 = self.condenser.n_inputs
        self._plan()
        progress = None
        if tick.path is not None:
            progress = tick.path.guess_progress + step[n3:]
        return SolveResult(
            success=flag > 0 and math.isfinite(float(step.sum())),
            status=_STATUS.get(flag, f"daqp exit flag {flag}"),
            poses=self._poses.copy(), twists=twists,
            progress=progress, solve_time=float(info["solve_time"]) + float(info["setup_time"]),
            iterations=int(info["iterations"]))


class _FixedBounds:
    """The step's bounds for limit rows that never move (``limits.constant``: not swerve's
    linearised disks, casters', or motor limits'): the rows' bounds are fixed, so a tick
    is the rows' values at the guess (one product), stage 0's part on the last command,
    and path mode's progress bounds. The product is dense for small row sets and sparse
    for large ones, whichever was quicker, and quicker than filling every bound anew
    (docs/design/dense-row-products.md)."""

    def __init__(self, structure: QpStructure, condenser: Condenser) -> None:
        rows = condenser.constraints
        self._rows: FloatArray | sparse.csr_matrix = (
            rows if rows.size <= _DENSE_ROWS else sparse.csr_matrix(rows))
        self._columns = condenser.columns
        first = condenser.first_row
        self._lower_fixed = structure.lower[first:].copy()
        self._upper_fixed = structure.upper[first:].copy()
        self._lower = np.empty_like(self._lower_fixed)
        self._upper = np.empty_like(self._upper_fixed)
        limits = structure.limits
        start = structure.limit_slots.start - first
        self._first_stage = slice(start, start + limits.rows)  # stage 0's limit rows
        self._before = limits.before[0]
        progress = structure.progress
        self._progress = (None if progress is None else
                          slice(progress.start - first, progress.start - first + progress.stages))

    def step(self, tick: TickInput) -> tuple[FloatArray, FloatArray]:
        """This tick's bounds on the step (lower, upper), buffers kept between calls."""
        at_guess = self._rows @ tick.guess[self._columns]
        lower = np.subtract(self._lower_fixed, at_guess, out=self._lower)
        upper = np.subtract(self._upper_fixed, at_guess, out=self._upper)
        shift = self._before @ tick.last_twist
        lower[self._first_stage] -= shift
        upper[self._first_stage] -= shift
        rows, path = self._progress, tick.path
        if rows is not None and path is not None:
            np.subtract(path.lower, at_guess[rows], out=lower[rows])
            np.subtract(path.upper, at_guess[rows], out=upper[rows])
        return lower, upper


class _SparseRows:
    """Rows with few nonzeros each (path mode's progress rows: one or two), for their
    product with a dense matrix as that many scaled row gathers (a dense product with
    the mostly-zero rows cost three times as much)."""

    def __init__(self, rows: FloatArray) -> None:
        width = max(int((rows != 0).sum(axis=1).max(initial=0)), 1)
        self.columns = np.zeros((rows.shape[0], width), dtype=np.intp)
        self.values = np.zeros((rows.shape[0], width))
        for i, row in enumerate(rows):
            nonzero = np.flatnonzero(row)
            self.columns[i, :nonzero.size] = nonzero
            self.values[i, :nonzero.size] = row[nonzero]

    def times(self, matrix: FloatArray, out: FloatArray) -> None:
        """``rows @ matrix`` into ``out``."""
        np.multiply(self.values[:, 0, None], matrix[self.columns[:, 0]], out=out)
        for j in range(1, self.values.shape[1]):
            out += self.values[:, j, None] * matrix[self.columns[:, j]]


def _with_first(info: dict[str, Any], first: dict[str, Any]) -> dict[str, Any]:
    """A second solve's daqp ``info`` with the first's time and iterations added."""
    for key in ("solve_time", "setup_time", "iterations"):
        info[key] += first[key]
    return info


def _whiten_stages(now: FloatArray, before: FloatArray, unwhiten: FloatArray,
                   out: FloatArray) -> None:
    """Limit rows (``now``, ``before``: (N, m, 3)) times ``L^{-T}`` into ``out`` (N, m,
    columns), stage by stage: stage ``k``'s rows touch ``u_k`` and ``u_{k-1}`` only."""
    n = now.shape[0]
    blocks = unwhiten[:3 * n].reshape(n, 3, -1)
    np.matmul(now, blocks, out=out)
    if n > 1:
        out[1:] += np.matmul(before[1:], blocks[:-1])


def _factor(hessian: FloatArray) -> FloatArray:
    """``L`` with ``H = L L'`` (LAPACK directly: numpy's and scipy's wrappers cost several
    times the work); a Hessian that is not positive definite (daqp would refuse it too) is
    regularised first. ``H`` is symmetric: its transpose is the same matrix in the column
    order LAPACK reads, so it goes in without a transposing copy."""
    factor, info = lapack.dpotrf(hessian.T, lower=1, clean=1)
    if info != 0:
        factor, info = lapack.dpotrf(hessian + 1e-9 * np.trace(hessian)
                                     * np.eye(hessian.shape[0]), lower=1, clean=1)
    return factor


def _inverse_transpose(factor: FloatArray) -> FloatArray:
    """``L^{-T}`` of a lower-triangular ``L``."""
    inverse, _ = lapack.dtrtri(factor, lower=1, overwrite_c=1)  # the factor is ours
    return np.ascontiguousarray(inverse.T)
