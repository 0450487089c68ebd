"""Path mode's tick as graphs (``Controller(..., mode="path", compiled=True)``): the progress
``s_k`` along the reference a decision beside the twists, its contour, lag and progress
terms in the cost, its bound and rate rows; built from the model's own functions, as
:mod:`mpc.tick.graphs` builds time mode's.

What differs from time mode:

- The reference is sampled at the progress guess, not at ``t + offsets``: that guess
  follows the last plan's progress. The progress graphs (:mod:`mpc.tick.progress`) give
  the times to sample at and turn the samples into the model's parameter vector (its own
  layout, :mod:`mpc.model.layout`) and the progress bounds; ``prepare`` takes those and
  writes the measured pose and the last command into the vector. Only the sampling is the
  caller's (:mod:`mpc.tick.path_edge`, or an exported library's caller).
- The cost's Hessian moves with the path (its contour directions and path rates are
  parameters), so ``prepare`` carries its values to ``hessian`` and counts their change
  in the drift: the Hessian is kept across ticks by the Python tick's measure, the cost
  values' change over :data:`~mpc.solvers.hessian_reuse.COST_TOLERANCE` beside time
  mode's (:func:`_drift`), rebuilt whole when either exceeds
  :data:`~mpc.tick.reuse.REBUILD_DRIFT` (the Python tick's partial rebuild with the last
  build's sensitivities, ``COST_ONLY_DRIFT``, is not done).
- ``hessian`` adds the progress blocks to time mode's (:func:`_progress_blocks`);
  ``finish`` is time mode's with the planned progress as one more output.
- A tick with no plan to start from solves again while the progress settles (the Python
  tick's warm-up, :meth:`~mpc.control.timing.PathProgress.refine`; the progress graphs'
  ``refine`` decides, :mod:`mpc.tick.path_runner` loops): the runners' ``again`` puts the
  last command and the fallback's memory back as they were before the tick and takes the
  round's plan, unshifted, as the next guess (:data:`AGAIN`).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from mpc.control.timing import WARM_UP_ROUNDS
from mpc.model.grid import shift_maps
from mpc.model.tracking import TrackingModel
from mpc.robots.base import ScalarWheels
from mpc.robots.drive.motor_limits import stage_limits
from mpc.solvers.condensed import Condenser, tick_terms
from mpc.solvers.hessian_reuse import COST_TOLERANCE
from mpc.solvers.qp_structure import assemble_qp
from mpc.tick.graphs import (
    HOLD,
    SOLVED,
    WARM,
    TickGraphs,
    _condensed_hessian,
    _finish,
)
from mpc.tick.progress import progress_graphs
from mpc.tick.reuse import reuse_terms, terms_size

#: ``prepare``'s guess mode of a tick solved again (path mode's warm-up): the last
#: round's plan as it is, not moved on a tick (``WarmStart.fill(shift=False)``).
AGAIN = 3.0

__all__ = ["AGAIN", "PathGraphs", "build_path_graphs"]


@dataclass(frozen=True, eq=False)
class PathGraphs(TickGraphs):
    """Path mode's graphs (:class:`~mpc.tick.graphs.TickGraphs`' fields; the differences):

    - ``prepare``: ``(pose 3, reference P, bounds 2 x N+1, last 3, plan 3 x N, guess_mode 1,
      kept t) -> (gradient n, lower m, upper m, carry k, terms t, drift 1)``: ``reference``
      the model's parameter vector as :class:`~mpc.control.timing.PathProgress` filled it
      (its ``x0`` and ``last_twist`` are replaced by ``pose`` and ``last``), ``bounds`` the
      progress's lower and upper bounds [s] (stage by stage); ``terms`` time mode's and
      the cost Hessian's values (:func:`_drift`).
    - ``finish``: time mode's outputs, then ``progress`` (N+1) [s]: the planned progress
      (the guess's where the tick did not solve).

    Attributes:
        progress: progress values a plan has (N+1).
        reference_size: the parameter vector's length (P).
    """

    progress: int = 0
    reference_size: int = 0
    #: The progress arithmetic (:func:`mpc.tick.progress.progress_graphs`): ``times``,
    #: ``reference``, ``refine``, generated beside the tick's graphs.
    progress_graphs: tuple[ca.Function, ...] = ()

    def config(self) -> dict[str, int]:
        """Sizes for ``mpc_tick_config.h``: the progress's, what ``mpc_tick_step``'s
        two reference arrays hold in path mode (the parameter vector, the bounds), and the
        warm-up's rounds at most."""
        return {"MPC_PROGRESS": self.progress, "MPC_REF_SIZE": self.reference_size,
                "MPC_REF2_SIZE": 2 * self.progress, "MPC_AGAIN_MODE": int(AGAIN),
                "MPC_WARM_UP_ROUNDS": WARM_UP_ROUNDS}


def build_path_graphs(model: TrackingModel, wheels: ScalarWheels, tick: float) -> PathGraphs:
    """Path mode's tick graphs for ``model`` (``model.path``; a robot with
    :class:`ScalarWheels`: checked by :func:`mpc.tick.support.check_supported`), control
    tick ``tick`` [s]."""
    if not model.path:
        raise RuntimeError("build_path_graphs needs a path-mode model")
    n = model.horizon
    limits = stage_limits(model.robot, model.change_times, None)
    structure = assemble_qp(model, limits)
    condenser = Condenser(model, structure)
    size, m = condenser.size, condenser.constraints.shape[0]
    parameters = model.layouts.parameters
    progress_rows = structure.progress
    assert progress_rows is not None

    pose = ca.SX.sym("pose", 3)
    reference = ca.SX.sym("reference", parameters.size)
    bounds = ca.SX.sym("bounds", 2, n + 1)
    last = ca.SX.sym("last", 3)
    plan = ca.SX.sym("plan", 3, n)
    mode = ca.SX.sym("guess_mode")
    nnz = structure.cost_terms.sparsity_out(0).nnz()
    kept = ca.SX.sym("kept", terms_size(n) + nnz)

    fields = {"x0": pose, "last_twist": last}
    p = ca.vertcat(*[fields.get(name, reference[field.slice])
                     for name, field in parameters.fields.items()])
    feedforward = parameters.symbol(reference, "twists_ref")
    poses_ref = parameters.symbol(reference, "poses_ref")
    progress_guess = parameters.symbol(reference, "progress_guess")

    _, twists_map = shift_maps(np.asarray(model.offsets, dtype=float), tick)
    shifted = plan @ ca.DM(twists_map).T  # (WarmStart.fill: twists_map @ plan, stage-major)
    guess = ca.if_else(mode == HOLD, ca.repmat(last, 1, n), ca.if_else(
        mode == WARM, shifted, ca.if_else(mode == AGAIN, plan, feedforward)))

    p_data, rollout, sensitivities, gradient, steps = tick_terms(
        model, structure.cost_terms)(p, guess, progress_guess)
    terms, drift = _drift(model, structure.hessian.data, p_data, sensitivities, steps, kept)
    rows = ca.DM(condenser.constraints)
    first = condenser.first_row
    at_guess = rows @ ca.vertcat(ca.vec(guess), progress_guess)
    shift = ca.vertcat(ca.DM(limits.before[0]) @ last, ca.SX.zeros(m - limits.rows, 1))
    # (_FixedBounds.step: the fixed bounds less the rows at the guess, stage 0's part on
    # the last command, and the progress's bounds of this tick)
    on_progress = slice(progress_rows.start - first, progress_rows.start - first + n + 1)
    lower = ca.SX(ca.DM(structure.lower[first:])) - at_guess - shift
    upper = ca.SX(ca.DM(structure.upper[first:])) - at_guess - shift
    lower[on_progress] = bounds[0, :].T - at_guess[on_progress]
    upper[on_progress] = bounds[1, :].T - at_guess[on_progress]
    carry_parts = [rollout, sensitivities, steps, guess, feedforward, poses_ref]
    carry = ca.vertcat(*[ca.densify(ca.vec(part)) for part in carry_parts],
                       p_data.nz[:], progress_guess)
    prepare = ca.Function(
        "mpc_tick_prepare", [pose, reference, bounds, last, plan, mode, kept],
        [ca.densify(gradient), ca.densify(lower), ca.densify(upper), carry, terms, drift],
        ["pose", "reference", "bounds", "last", "plan", "guess_mode", "kept"],
        ["gradient", "lower", "upper", "carry", "terms", "drift"], {"cse": True})
    sparsity = structure.cost_terms.sparsity_out(0)
    hessian = _path_hessian(model, sparsity, carry.shape[0], size)

    inverse = ca.MX.sym("inverse", ca.Sparsity.lower(size))
    g, y = ca.MX.sym("gradient", size), ca.MX.sym("y", size)
    sparse_rows = ca.DM(ca.sparsify(ca.DM(condenser.constraints)))
    whiten = ca.Function("mpc_tick_whiten", [inverse, g], [ca.densify(inverse @ g)],
                         ["inverse", "gradient"], ["f"])
    whiten_rows = ca.Function("mpc_tick_whiten_rows", [inverse],
                              [ca.densify(inverse @ sparse_rows.T)], ["inverse"], ["rows_t"])
    unwhiten = ca.Function("mpc_tick_unwhiten", [inverse, y],
                           [ca.densify((y.T @ inverse).T)], ["inverse", "y"], ["step"])

    finish = _path_finish(_finish(model, wheels, tick, size, carry.shape[0]), n,
                          carry.shape[0])
    return PathGraphs(prepare, hessian, whiten, whiten_rows, unwhiten, finish, n, size, m,
                      len(wheels.limits), carry.shape[0], int(kept.shape[0]),
                      tuple(float(x) for x in model.offsets), float(tick), progress=n + 1,
                      reference_size=parameters.size,
                      progress_graphs=progress_graphs(model))


def _drift(model: TrackingModel, initial: np.ndarray, p_data: ca.SX, sensitivities: ca.SX,
           steps: ca.SX, kept: ca.SX) -> tuple[ca.SX, ca.SX]:
    """This tick's reuse terms (time mode's, :func:`~mpc.tick.reuse.reuse_terms`, then the
    cost Hessian's values) and their drift from ``kept``: the larger of the cost's (the
    largest change of a value over :data:`~mpc.solvers.hessian_reuse.COST_TOLERANCE` times
    the largest value at set-up, ``initial``) and the sensitivities' (a rotation of the
    whole plan not counted where this tick's cost weighs positions alike in every
    direction): the Python tick's measure (:class:`~mpc.solvers.hessian_reuse.HessianReuse`)."""
    size = terms_size(model.horizon)
    moving, drift = reuse_terms(sensitivities, steps, kept[:size], model.dt, False)
    _, turned = reuse_terms(sensitivities, steps, kept[:size], model.dt, True)
    values = p_data.nz[:]
    tolerance = COST_TOLERANCE * float(np.abs(initial).max() or 1.0)
    cost = ca.mmax(ca.fabs(values - kept[size:])) / tolerance
    upper = ca.SX(p_data)
    full = upper + upper.T - ca.diag(ca.diag(upper))
    moved = ca.if_else(_isotropic(model, full), turned, drift)
    return ca.vertcat(moving, values), ca.fmax(cost, moved)


def _isotropic(model: TrackingModel, full: ca.SX) -> ca.SX:
    """1 where the cost Hessian ``full`` weighs every stage's position alike in all
    directions with no position-progress coupling (:meth:`Condenser.isotropic
    <mpc.solvers.condensed.Condenser.isotropic>`'s test, with its tolerances)."""
    variables = model.layouts.variables
    poses, progress = variables["poses"], variables["progress"]
    rows = slice(poses.start, poses.start + poses.size)
    coupled = ca.mmax(ca.fabs(full[rows, progress.start:progress.start + progress.size]))
    tests = [coupled == 0]
    for k in range(model.horizon + 1):
        at = poses.start + 3 * k
        xx, yy = full[at, at], full[at + 1, at + 1]
        tests += [ca.fabs(full[at, at + 1]) <= 1e-8,
                  ca.fabs(xx - yy) <= 1e-8 + 1e-5 * ca.fabs(yy),
                  ca.fabs(full[at, at + 2]) <= 1e-8, ca.fabs(full[at + 1, at + 2]) <= 1e-8]
    result = tests[0]
    for test in tests[1:]:
        result = ca.logic_and(result, test)
    return result


def _path_hessian(model: TrackingModel, sparsity: ca.Sparsity, carry_size: int,
                  size: int) -> ca.Function:
    """``hessian``: the condensed Hessian on ``y = (u, s)`` (``size``) from the sensitivities,
    steps and cost Hessian values in ``carry`` (:meth:`Condenser.hessian
    <mpc.solvers.condensed.Condenser.hessian>`'s blocks)."""
    n = model.horizon
    carry = ca.SX.sym("carry", carry_size)
    start = 3 * (n + 1)
    sensitivities = ca.reshape(carry[start:start + 9 * n], 9, n)
    steps = ca.reshape(carry[start + 9 * n:start + 11 * n], 2, n)
    values_start = start + 11 * n + 3 * n + 3 * n + 3 * (n + 1)
    upper = ca.SX(sparsity, carry[values_start:values_start + sparsity.nnz()])
    inputs = _condensed_hessian(model, upper, sensitivities, steps)
    coupling, progress = _progress_blocks(model, upper, sensitivities, steps)
    hessian = ca.blockcat([[inputs, coupling], [coupling.T, progress]])
    if hessian.shape != (size, size):
        raise RuntimeError("the path-mode Hessian's size differs from the condensed QP's")
    return ca.Function("mpc_tick_hessian", [carry], [ca.densify(hessian)], ["carry"],
                       ["hessian"], {"cse": True})


def _progress_blocks(model: TrackingModel, upper: ca.SX, sensitivities: ca.SX,
                     steps: ca.SX) -> tuple[ca.SX, ca.SX]:
    """The condensed Hessian's input-progress block ``S' P_xs + P_us`` (3N x N+1) and its
    progress block ``P_ss`` (N+1 x N+1), from the cost Hessian's upper triangle ``upper``.

    ``P_xs`` couples stage ``k``'s pose with ``s_k`` only (its column ``c_k``), so column
    ``k`` of ``S' P_xs`` is ``S_k' c_k``, whose block ``j < k`` is ``(B_j + b_j w(s_k -
    s_{j+1}) e3')' c_k`` (the lever arm of :func:`~mpc.tick.graphs._condensed_hessian`;
    ``s_k`` the rollout's planar steps summed before stage ``k``)."""
    n = model.horizon
    variables = model.layouts.variables
    poses, twists, progress = variables["poses"], variables["twists"], variables["progress"]
    full = upper + upper.T - ca.diag(ca.diag(upper))
    summed = [ca.SX.zeros(2, 1)]
    for k in range(n):
        summed.append(summed[-1] + steps[:, k])
    blocks = [ca.reshape(sensitivities[:, j], 3, 3) for j in range(n)]
    columns: list[ca.SX] = []
    for k in range(n + 1):
        c = full[poses.start + 3 * k:poses.start + 3 * k + 3, progress.start + k]
        parts = []
        for j in range(n):
            if j < k:
                lever = summed[k] - summed[j + 1]
                turn = blocks[j][2, 2] * (-lever[1] * c[0] + lever[0] * c[1])
                parts.append(blocks[j].T @ c + ca.vertcat(0, 0, turn))
            else:
                parts.append(ca.SX.zeros(3, 1))
        columns.append(ca.vertcat(*parts))
    twist_rows = slice(twists.start, twists.start + 3 * n)
    progress_columns = slice(progress.start, progress.start + n + 1)
    coupling = ca.horzcat(*columns) + full[twist_rows, progress_columns]
    return coupling, full[progress_columns, progress_columns]


def _path_finish(finish: ca.Function, horizon: int, carry_size: int) -> ca.Function:
    """Time mode's ``finish`` with the planned progress as one more output: the guess's
    plus the step's where the tick solved, else the guess's."""
    n = horizon
    size = finish.size1_in(0)
    inputs = [ca.SX.sym(name, finish.sparsity_in(i)) for i, name in
              enumerate(finish.name_in())]
    outputs = finish(*inputs)
    step, carry = inputs[0], inputs[2]
    guess = carry[carry_size - (n + 1):]
    planned = ca.if_else(outputs[0] == SOLVED, guess + step[size - (n + 1):], guess)
    return ca.Function("mpc_tick_finish", inputs, [*outputs, planned],
                       [*finish.name_in()], [*finish.name_out(), "progress"], {"cse": True})
