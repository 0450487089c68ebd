"""The tick as CasADi graphs around two small steps in C (or LAPACK): ``prepare``, the
Cholesky factor and its inverse, ``whiten``, daqp, ``unwhiten``, ``finish``; built from the
model's own CasADi functions.

``prepare`` (SX): (measured pose, the reference window sampled at the stage times, the
last command, the last plan's twists, how to guess) -> the condensed QP on the step
``d`` from the guess (``minimise d'H d / 2 + g' d`` subject to ``lower <= A d <= upper``)
and what ``finish`` needs (``carry``). Inside: the reference heading unwrapped to the
measured one and the reference terms
(:attr:`~mpc.model.tracking.TrackingModel.reference_terms`), the guess (the last plan
moved on one tick by :func:`~mpc.model.grid.shift_maps`, the reference's feedforward, or
the last command held), the rollout with its sensitivities and the cost's exact gradient
along it (:func:`~mpc.solvers.condensed.tick_terms`), the robot's constant speed and
acceleration rows (:func:`~mpc.robots.drive.motor_limits.stage_limits`, condensed by
:class:`~mpc.solvers.condensed.Condenser`) with their bounds on the step, and how far the
sensitivities moved from those of the kept Hessian's build (:mod:`mpc.tick.reuse`: the
rule that decides whether ``hessian``, the factor and ``whiten_rows`` run this tick).

``hessian`` (SX): the condensed Hessian ``H = S' P_xx S + P_uu`` with the exact state
sensitivities ``S`` (:mod:`mpc.solvers.condensed`), from ``prepare``'s ``carry``.

The Cholesky factor ``H = L L'`` and ``L^{-1}`` are the one step not written as a graph:
written out as SX expressions they grow as N^3 and compile far too slowly, CasADi's MX
has no Cholesky node, and its triangular solve against the identity was slow
(docs/guide/compiled-tick.md); ``tick.c`` has both as two short loops, the
virtual-machine path takes LAPACK's (as :mod:`mpc.solvers.dense` does).

``whiten``, ``whiten_rows`` and ``unwhiten`` (MX: sparse products generate as loops): the
QP in whitened steps ``y = L' d`` that daqp gets (Hessian the identity: the gradient every
tick, the rows when the Hessian is rebuilt), and the step ``d = L^{-T} y``.

``finish`` (SX): (the step and daqp's exit flag, ``carry``, the last
command, the fallback's memory) -> (status, clamped twist, wheel speeds, the plan, the
next memory): the plan's poses
(:func:`~mpc.solvers.condensed.plan_poses`), the fallback policy's choice
(:class:`~mpc.control.fallback.FallbackPolicy`'s order) and the clamp into the wheel
limits (:func:`~mpc.control.clamp.clamp_command`'s scalar-wheel steps), all as
expressions.

Scope of this slice: constant-Jacobian robots (Swedish, Mecanum, omni, ball wheels) with
no failed wheel, with or without a motor model (its rows, clamp and feedforward from
:mod:`mpc.tick.motors`), swerve robots without steering range, failed module or motor
model (their rows, clamp and commands from :mod:`mpc.tick.steered`; axle-offset modules'
from :mod:`mpc.tick.offset`, their rows constant) and powered casters (their rows at the
measured angles' prediction, clamp and joint rates from :mod:`mpc.tick.casters`), time
mode (:mod:`mpc.tick.support`; path mode: :mod:`mpc.tick.path`).

Rows that move every tick (swerve's speed faces, a motor model's rows) are one mechanism:
``prepare`` gives their nonzeros (``rows``, a fixed sparsity) and ``whiten_rows`` takes
them (``tick.c``'s ``mpc_tick_whiten_moving``). A cost Hessian that moves with the
reference (a motor model's rate terms: their Coriolis term is the reference's) is carried
to ``hessian`` and its change counted in the drift, as path mode does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from mpc.control.fallback import FallbackPolicy
from mpc.model.grid import shift_maps
from mpc.model.tracking import TrackingModel
from mpc.robots.base import SPEED_SLACK, PlanarModules, ScalarWheels
from mpc.robots.drive.motor_limits import MotorStageLimits, stage_limits
from mpc.robots.wheels.swerve.limits import FACES
from mpc.solvers.condensed import Condenser, plan_poses, tick_terms
from mpc.solvers.hessian_reuse import COST_TOLERANCE
from mpc.solvers.qp_structure import assemble_qp
from mpc.tick.motors import (
    MotorGraphs,
    feedforward_size,
    motor_clamp,
    motor_feedforward,
    motor_graphs,
)
from mpc.tick.offset import steering_for
from mpc.tick.reuse import isotropic_cost, reuse_terms, terms_size
from mpc.tick.screen import screened_places
from mpc.tick.steered import Steering

#: ``prepare``'s guess modes: the reference's feedforward (no plan kept), the last plan
#: moved on one tick, the last command held at every stage (a cold guess that failed).
COLD, WARM, HOLD = 0.0, 1.0, 2.0

#: ``finish``'s status codes, in :class:`~mpc.control.command.Status`'s order.
SOLVED, PREVIOUS_PLAN, FEEDFORWARD, STOPPING = 0, 1, 2, 3

#: The exit flag ``finish`` is given for a tick whose reference could not be sampled
#: (no QP was solved; the fallback skips the feedforward, which is NaN then).
UNPLANNED = -1000


@dataclass(frozen=True, eq=False)
class TickGraphs:
    """The three graphs and their sizes.

    Attributes:
        prepare: ``(pose 3, ref_poses 3 x N+1, ref_velocities 3 x N+1, last 3, plan 3 x N,
            guess_mode 1, kept t) -> (gradient n, lower m, upper m, carry k, terms t,
            drift 1)``: the condensed QP on the step from the guess (its Hessian from
            ``hessian``), this tick's reuse terms and their drift from ``kept``, the
            terms of the kept Hessian's build (:mod:`mpc.tick.reuse`).
        hessian: ``(carry k) -> hessian n x n``: the condensed Hessian of the tick whose
            ``carry`` it is (evaluated only when the Hessian is rebuilt).
        whiten: ``(inverse n x n, gradient n) -> f n``: with ``H = L L'`` and
            ``inverse = L^{-1}`` (lower triangular: its n (n + 1) / 2 entries packed
            column by column; from the caller's factor), the gradient in whitened steps
            ``y = L' d``: ``f = L^{-1} g``.
        whiten_rows: ``(inverse n x n) -> rows_t n x m``: the rows in whitened steps,
            ``rows_t = (A L^{-T})'`` (column-major: ``A L^{-T}`` row-major, as daqp reads
            it); constant rows: only when the Hessian is rebuilt.
        unwhiten: ``(inverse n x n, y n) -> step n``: ``d = L^{-T} y``.
        finish: ``(step n, flag 1, carry k, last 3, plan 3 x N, memory 2) ->
            (status 1, twist 3, wheel_speeds w, clamped 1, poses 3 x N+1, next_plan 3 x N,
            next_memory 2)``; ``memory`` is (failures in a row, whether a plan is kept);
            a motor-aware robot's also ``feedforward`` (:attr:`feedforward`) last.
        horizon, variables (n = 3 N), rows (m), wheels (w), carry (k), terms (t); offsets: each
        stage's start from the window's [s] (N+1), where the reference is sampled; tick:
        the control tick [s].
    """

    prepare: ca.Function
    hessian: ca.Function
    whiten: ca.Function
    whiten_rows: ca.Function
    unwhiten: ca.Function
    finish: ca.Function
    horizon: int
    variables: int
    rows: int
    wheels: int
    carry: int
    terms: int
    offsets: tuple[float, ...] = ()  # each stage's start from the window's [s] (N+1)
    tick: float = 0.0  # the control tick [s]
    #: Swerve (:mod:`mpc.tick.steered`) and motor-aware robots (:mod:`mpc.tick.motors`):
    #: the rows move every tick. ``prepare`` then also takes the steer angles (``steer``)
    #: and the rows' state (``state``, its start ``row_state``; both empty for a motor
    #: model) and gives the rows' nonzeros (``rows``, ``moving_rows`` of them) and the next
    #: state; ``whiten_rows`` takes ``(inverse, rows)`` and runs every tick; swerve's
    #: ``finish`` takes the steer angles last and gives the next ones last.
    moving_rows: int = 0
    row_state: tuple[float, ...] = ()
    steer: int = 0
    #: Which of the ``rows`` move (swerve: the speed faces; the acceleration polygon's do
    #: not: whitened again only with a new Hessian; a motor model: every row).
    rows_move: tuple[bool, ...] = ()
    #: Motor-aware robots: numbers of ``finish``'s ``feedforward`` output
    #: (:func:`mpc.tick.motors.motor_feedforward`: 5 w), else 0.
    feedforward: int = 0
    #: The row screen's places, a stage's rows by kind (:func:`mpc.tick.screen.
    #: screened_places`; empty: no screen, every row in daqp's problem).
    screen_places: tuple[int, ...] = ()


def build_graphs(model: TrackingModel, wheels: ScalarWheels | PlanarModules,
                 tick: float) -> TickGraphs:
    """The tick's graphs for ``model`` (time mode, a robot with :class:`ScalarWheels` or a
    swerve robot with :class:`PlanarModules`: checked by
    :func:`mpc.tick.support.check_supported`), control tick ``tick`` [s]."""
    n = model.horizon
    steering = (steering_for(model.robot, wheels, model.change_times, tick)
                if isinstance(wheels, PlanarModules) else None)
    # (swerve's faces move with the guess; axle-offset modules' polygon does not)
    faces = steering is not None and getattr(steering, "moves", True)
    limits = (steering.limits if steering is not None
              else stage_limits(model.robot, model.change_times, None))
    motor = (motor_graphs(model.robot, limits) if isinstance(limits, MotorStageLimits)
             else None)
    structure = assemble_qp(model, limits)
    condenser = Condenser(model, structure)
    size, m = condenser.size, condenser.constraints.shape[0]
    parameters = model.layouts.parameters

    pose = ca.SX.sym("pose", 3)
    ref_poses = ca.SX.sym("ref_poses", 3, n + 1)
    ref_velocities = ca.SX.sym("ref_velocities", 3, n + 1)
    last = ca.SX.sym("last", 3)
    plan = ca.SX.sym("plan", 3, n)
    mode = ca.SX.sym("guess_mode")
    steer = ca.SX.sym("steer_angles", 0 if steering is None else steering.wheels)
    row_state = ca.SX.sym("state", 0 if steering is None else len(steering.state))

    # The reference heading moved by whole turns to within pi of the measured heading
    # (ReferenceWindow._unwrap), then its feedforward and directions.
    turns = ca.floor((ref_poses[2, 0] - pose[2]) / (2.0 * math.pi) + 0.5)
    unwrapped = ca.vertcat(ref_poses[:2, :], ref_poses[2, :] - 2.0 * math.pi * turns)
    feedforward, directions = model.reference_terms(unwrapped, ref_velocities)
    p = _parameters(parameters, {"x0": pose, "poses_ref": unwrapped,
                                 "twists_ref": feedforward, "directions": directions,
                                 "last_twist": last,
                                 **({} if steering is None else {"steer_angles": steer})})

    _, twists_map = shift_maps(np.asarray(model.offsets, dtype=float), tick)
    shifted = plan @ ca.DM(twists_map).T  # (WarmStart.fill: twists_map @ plan, stage-major)
    guess = ca.if_else(mode == HOLD, ca.repmat(last, 1, n),
                       ca.if_else(mode == WARM, shifted, feedforward))

    p_data, rollout, sensitivities, gradient, steps = tick_terms(
        model, structure.cost_terms)(p, guess)
    inputs = ca.vertcat(pose, ca.vec(ref_poses), ca.vec(ref_velocities), last, steer)
    cost_moves = bool(ca.depends_on(p_data, inputs))
    # (the cost Hessian at zero inputs: all of it where nothing moves it; else its
    # position blocks, which decide isotropy and must not move: _moving_cost)
    constant_cost = ca.evalf(ca.substitute(p_data, inputs, ca.DM.zeros(inputs.shape)))
    cost_values = _moving_cost(model, p_data, inputs) if cost_moves else None
    kept = ca.SX.sym("kept", terms_size(n) + (0 if cost_values is None else
                                              cost_values.numel()))
    terms, drift = reuse_terms(sensitivities, steps, kept[:terms_size(n)], model.dt,
                               isotropic_cost(condenser, constant_cost))
    if cost_values is not None:  # the Python tick's measure of the cost's change
        tolerance = COST_TOLERANCE * float(np.abs(np.asarray(
            structure.hessian.data, dtype=float)).max() or 1.0)
        terms = ca.vertcat(terms, cost_values)
        drift = ca.fmax(drift, ca.mmax(ca.fabs(cost_values - kept[terms_size(n):]))
                        / tolerance)
    rows: ca.DM | ca.SX = ca.DM(condenser.constraints)
    moving: list[ca.SX] = []
    if faces:  # the faces turned to the guess (mpc.tick.steered); casters' rows at the
        # angles along it from the measured ones (mpc.tick.casters)
        measured = (steer,) if getattr(steering, "measured", False) else ()
        rows, next_state = steering.rows(  # type: ignore[union-attr]
            condenser.constraints, row_state, guess, *measured)
        moving = [rows, next_state]
    first = condenser.first_row
    at_guess = rows @ ca.vec(guess)
    shift = ca.vertcat(ca.DM(limits.before[0]) @ last, ca.SX.zeros(m - limits.rows, 1))
    lower = ca.DM(structure.lower[first:]) - at_guess - shift
    upper = ca.DM(structure.upper[first:]) - at_guess - shift
    if motor is not None:  # (motor.prepare gives the bounds on the step)
        lower = upper = ca.SX.zeros(m, 1)
    carry_parts = [rollout, sensitivities, steps, guess, feedforward, unwrapped]
    carry = ca.vertcat(*[ca.densify(ca.vec(part)) for part in carry_parts],
                       *([] if cost_values is None else [cost_values]))
    # (a motor model: motor.prepare adds the rows, every one turned to the guess, and an
    # empty next state)
    moves = faces or motor is not None
    # (axle-offset modules, mpc.tick.offset: the steer angles in, the rows constant)
    extra_in, extra_names = (([steer, row_state], ["steer", "state"])
                             if moves or steering is not None else ([], []))
    prepare = ca.Function(
        "mpc_tick_prepare" if motor is None else "mpc_tick_prepare_terms",
        [pose, ref_poses, ref_velocities, last, plan, mode, kept, *extra_in],
        [ca.densify(gradient), ca.densify(lower), ca.densify(upper), carry,
         ca.densify(terms), drift, *moving],
        ["pose", "ref_poses", "ref_velocities", "last", "plan", "guess_mode", "kept",
         *extra_names],
        ["gradient", "lower", "upper", "carry", "terms", "drift",
         *(["rows", "next_state"] if moving else [])], {"cse": True})
    if motor is not None:  # (the guess: carry's fourth part)
        prepare = motor.prepare(prepare, sum(part.numel() for part in carry_parts[:3]))
    cost_at = sum(part.numel() for part in carry_parts)  # the moving cost's values
    hessian = _hessian_graph(model, constant_cost if cost_values is None
                             else (p_data.sparsity(), cost_at), carry.shape[0])

    # L^{-1}: its lower triangle packed column by column (CasADi's lower-triangular input)
    inverse = ca.MX.sym("inverse", ca.Sparsity.lower(size))
    g, y = ca.MX.sym("gradient", size), ca.MX.sym("y", size)
    sparse_rows = ca.DM(ca.sparsify(ca.DM(condenser.constraints)))
    whiten = ca.Function("mpc_tick_whiten", [inverse, g], [ca.densify(inverse @ g)],
                         ["inverse", "gradient"], ["f"])
    if moves:  # the rows prepare gives, their sparsity fixed
        row_values = ca.MX.sym("rows", prepare.sparsity_out("rows"))
        whiten_rows = ca.Function("mpc_tick_whiten_rows", [inverse, row_values],
                                  [ca.densify(inverse @ row_values.T)], ["inverse", "rows"],
                                  ["rows_t"])
    else:
        whiten_rows = ca.Function("mpc_tick_whiten_rows", [inverse],
                                  [ca.densify(inverse @ sparse_rows.T)], ["inverse"],
                                  ["rows_t"])
    unwhiten = ca.Function("mpc_tick_unwhiten", [inverse, y],
                           [ca.densify((y.T @ inverse).T)], ["inverse", "y"], ["step"])

    finish = _finish(model, wheels, tick, size, carry.shape[0], steering, motor)
    rows_move = (steering.rows_move(m) if faces and steering is not None
                 else (True,) * m if motor is not None else ())
    return TickGraphs(prepare, hessian, whiten, whiten_rows, unwhiten, finish, n, size, m,
                      len(wheels.limits), carry.shape[0], int(kept.shape[0]),
                      tuple(float(x) for x in model.offsets), float(tick),
                      prepare.nnz_out("rows") if moves else 0,
                      () if steering is None else steering.state,
                      0 if steering is None else steering.wheels, rows_move,
                      0 if motor is None else feedforward_size(model.robot),
                      screened_places(limits, motor is not None,
                                      steering.wheels * FACES
                                      if faces and steering is not None else 0))


def _moving_cost(model: TrackingModel, p_data: ca.SX, inputs: ca.SX) -> ca.SX:
    """The values of a cost Hessian the inputs move (``p_data``'s nonzeros): carried to
    ``hessian``, their change counted in the drift. Its position blocks must stay put
    (they decide whether a rotation of the plan counts, :func:`isotropic_cost`)."""
    poses = model.layouts.variables["poses"]
    rows = slice(poses.start, poses.start + poses.size)
    if ca.depends_on(ca.SX(p_data)[rows, rows], inputs):
        raise RuntimeError("the compiled tick needs a cost whose position weights no "
                           "parameter moves")
    return p_data.nz[:]


def _hessian_graph(model: TrackingModel, cost: ca.DM | tuple[ca.Sparsity, int],
                   carry_size: int) -> ca.Function:
    """``hessian``: the condensed Hessian from the sensitivities and steps in ``carry``
    (``cost``: the constant cost Hessian's upper triangle, or where one that moves has its
    values in ``carry``: its sparsity and their start)."""
    n = model.horizon
    carry = ca.SX.sym("carry", carry_size)
    start = 3 * (n + 1)
    sensitivities = ca.reshape(carry[start:start + 9 * n], 9, n)
    steps = ca.reshape(carry[start + 9 * n:start + 11 * n], 2, n)
    if isinstance(cost, tuple):
        sparsity, at = cost
        upper = ca.SX(sparsity, carry[at:at + sparsity.nnz()])
    else:
        upper = ca.SX(cost)
    hessian = _condensed_hessian(model, upper, sensitivities, steps)
    return ca.Function("mpc_tick_hessian", [carry], [ca.densify(hessian)], ["carry"],
                       ["hessian"], {"cse": True})


def _parameters(layout: object, values: dict[str, ca.SX]) -> ca.SX:
    """The parameter vector ``p`` from its fields' values (each ``width x stages``)."""
    fields = layout.fields  # type: ignore[attr-defined]
    missing = set(fields) - set(values)
    if missing:
        raise RuntimeError(f"the compiled tick does not fill parameters {sorted(missing)}")
    return ca.vertcat(*[ca.vec(values[name]) for name in fields])


def _condensed_hessian(model: TrackingModel, p_data: ca.SX, sensitivities: ca.SX,
                       steps: ca.SX) -> ca.SX:
    """``H = sum_k S_k' P_xx,k S_k + P_uu`` (3N x 3N) from the cost Hessian's upper
    triangle ``p_data`` and the rollout's sensitivities and planar steps
    (:meth:`~mpc.solvers.condensed.Condenser.state_sensitivities` and
    :meth:`~mpc.solvers.condensed.Condenser.hessian`), block by block.

    ``S_kj = B_j + b_j w(s_k - s_{j+1}) e3'`` for ``j < k`` (``s_k`` the rollout's planar
    steps summed before stage ``k``, ``w(s) = (-s_y, s_x, 0)``, ``b_j`` the heading entry
    of ``B_j``) is ``C_j + u_k r_j`` with ``C_j = B_j - b_j w(s_{j+1}) e3'``, ``u_k = w(s_k)``,
    ``r_j = b_j e3'``; so block ``(i, j)`` of ``sum_k`` over ``k > max(i, j)`` needs only
    suffix sums of ``Q_k``, ``Q_k u_k`` and ``u_k' Q_k u_k`` (``Q_k = P_xx,k``): about a
    fifth of the arithmetic of the products written out."""
    n = model.horizon
    variables = model.layouts.variables
    poses, twists = variables["poses"], variables["twists"]
    upper = p_data  # the upper triangle, with the cost Hessian's sparsity
    if upper.shape != (variables.size, variables.size):
        raise RuntimeError("tick_terms' first output must be the cost Hessian's triangle")
    full = upper + upper.T - ca.diag(ca.diag(upper))
    summed = [ca.SX.zeros(2, 1)]
    for k in range(n):
        summed.append(summed[-1] + steps[:, k])

    def lever(s: ca.SX) -> ca.SX:
        return ca.vertcat(-s[1], s[0], 0)

    e3 = ca.DM([[0, 0, 1]])
    blocks = [ca.reshape(sensitivities[:, j], 3, 3) for j in range(n)]
    reduced = [blocks[j] - blocks[j][2, 2] * lever(summed[j + 1]) @ e3 for j in range(n)]
    heading = [blocks[j][2, 2] * e3 for j in range(n)]  # r_j (1 x 3)
    # suffix sums over k >= m (m = 1 .. N) of Q_k, Q_k u_k, u_k' Q_k u_k
    weight_sum: list[ca.SX] = [ca.SX.zeros(3, 3)] * (n + 2)
    lever_sum: list[ca.SX] = [ca.SX.zeros(3, 1)] * (n + 2)
    square_sum: list[ca.SX] = [ca.SX.zeros(1, 1)] * (n + 2)
    for k in range(n, 0, -1):
        start = poses.start + 3 * k
        weight = full[start:start + 3, start:start + 3]
        u = lever(summed[k])
        weighted = weight @ u
        weight_sum[k] = weight_sum[k + 1] + weight
        lever_sum[k] = lever_sum[k + 1] + weighted
        square_sum[k] = square_sum[k + 1] + ca.dot(u, weighted)
    grid: list[list[ca.SX]] = [[ca.SX(3, 3)] * n for _ in range(n)]
    block = _hessian_block()
    for i in range(n):
        for j in range(i, n):
            m = j + 1
            value = block(reduced[i], reduced[j], heading[i][2], heading[j][2],
                          weight_sum[m], lever_sum[m], square_sum[m])
            grid[i][j] = value
            grid[j][i] = value.T
    twist_slice = slice(twists.start, twists.start + 3 * n)
    return full[twist_slice, twist_slice] + ca.blockcat(grid)


def _hessian_block() -> ca.Function:
    """Block ``(i, j)`` of the condensed Hessian's sum (see :func:`_condensed_hessian`):
    ``(C_i, C_j, b_i, b_j, sum Q, sum Q u, sum u'Q u) -> C_i' A C_j + C_i' q r_j +
    r_i' q' C_j + c r_i' r_j``. Kept a function of its own in the generated C (called,
    not inlined: N (N+1) / 2 calls of one small function compile much quicker than the
    blocks written out)."""
    left, right = ca.SX.sym("left", 3, 3), ca.SX.sym("right", 3, 3)
    b_left, b_right = ca.SX.sym("b_left"), ca.SX.sym("b_right")
    a, q, c = ca.SX.sym("a", 3, 3), ca.SX.sym("q", 3), ca.SX.sym("c")
    e3 = ca.DM([[0, 0, 1]])
    r_left, r_right = b_left * e3, b_right * e3
    value = (left.T @ a @ right + left.T @ q @ r_right + r_left.T @ (q.T @ right)
             + c * r_left.T @ r_right)
    return ca.Function("mpc_tick_hessian_block", [left, right, b_left, b_right, a, q, c],
                       [value], {"never_inline": True, "cse": True})


def _finish(model: TrackingModel, wheels: ScalarWheels | PlanarModules, tick: float,
            size: int, carry_size: int, steering: Steering | None = None,
            motor: MotorGraphs | None = None) -> ca.Function:
    """The graph after daqp and the unwhitening (module docstring); ``steering``: swerve's
    clamp and module commands (:mod:`mpc.tick.steered`), the steer angles an input and an
    output; ``motor``: the clamp's motor passes and the feedforward, one more output
    (:mod:`mpc.tick.motors`)."""
    n = model.horizon
    robot = model.robot
    step = ca.SX.sym("step", size)
    flag = ca.SX.sym("flag")
    carry = ca.SX.sym("carry", carry_size)
    last = ca.SX.sym("last", 3)
    kept = ca.SX.sym("plan", 3, n)
    memory = ca.SX.sym("memory", 2)
    steer = ca.SX.sym("steer_angles", 0 if steering is None else steering.wheels)
    parts, start = [], 0
    for rows, cols in ((3, n + 1), (9, n), (2, n), (3, n), (3, n), (3, n + 1)):
        parts.append(ca.reshape(carry[start:start + rows * cols], rows, cols))
        start += rows * cols
    rollout, sensitivities, steps, guess, feedforward, ref_poses = parts
    twists = guess + ca.reshape(step[:3 * n], 3, n)
    poses = plan_poses(n)(rollout, sensitivities, ca.reshape(step[:3 * n], 3, n), steps)
    finite = _finite(ca.sum1(step))
    success = ca.logic_and(flag > 0, finite)

    # The fallback policy (FallbackPolicy.failed), in its order.
    policy = FallbackPolicy(robot, model.offsets, tick)
    horizon = policy.horizon
    stages = policy._stages  # the stage each tick of a failure streak falls in
    failures = ca.if_else(success, 0, memory[0] + 1)
    have_plan = memory[1]
    from_plan = ca.conditional(failures, [kept[:, int(stage)] for stage in stages],
                               ca.SX.zeros(3), False)
    reference = feedforward[:, 0]
    use_plan = ca.logic_and(have_plan > 0, failures < horizon)
    use_feedforward = ca.logic_and(failures < 2 * horizon, _finite(ca.sum1(reference)))
    desaturated = (steering.desaturated(reference) if steering is not None
                   else _desaturated(wheels, reference))  # type: ignore[arg-type]
    target = ca.if_else(success, twists[:, 0], ca.if_else(
        use_plan, from_plan, ca.if_else(use_feedforward, desaturated, ca.SX.zeros(3))))
    status = ca.if_else(success, SOLVED, ca.if_else(
        use_plan, PREVIOUS_PLAN, ca.if_else(use_feedforward, FEEDFORWARD, STOPPING)))
    twist, changed = (steering.clamped(target, last, steer) if steering is not None
                      else _clamped(wheels, target, last, tick))  # type: ignore[arg-type]
    extra: list[ca.SX] = []  # a motor model: the clamp's motor passes, the feedforward
    if motor is not None:
        twist = motor_clamp(robot, wheels, twist, last, tick)  # type: ignore[arg-type]
        extra, changed = [motor_feedforward(robot, last, twist, tick)], ca.SX(1)
    clamped = ca.logic_and(changed, ca.logic_or(ca.logic_or(twist[0] != target[0],
                                                            twist[1] != target[1]),
                                                twist[2] != target[2]))
    steer_out: list[ca.SX] = []
    if steering is not None:  # the modules' speeds and angles; the twist they drive
        speeds, angles, twist = steering.commands(twist, target, steer)
        steer_out = [angles]
    else:
        speeds = ca.DM(np.asarray(wheels.rows)) @ twist
    plan_out = ca.if_else(success, poses, ref_poses)
    plan_out = ca.if_else(_finite(ca.sum1(ca.sum2(plan_out))), plan_out,
                          ca.repmat(rollout[:, 0], 1, n + 1))
    stored = ca.if_else(success, twists, kept)
    memory_out = ca.vertcat(failures, ca.logic_or(success, have_plan > 0))
    return ca.Function(
        "mpc_tick_finish", [step, flag, carry, last, kept, memory, *([steer] if steer_out else [])],
        [status, twist, speeds, clamped, plan_out, stored, memory_out, *steer_out, *extra],
        ["step", "flag", "carry", "last", "plan", "memory", *(["steer"] if steer_out else [])],
        ["status", "twist", "wheel_speeds", "clamped", "poses", "next_plan", "next_memory",
         *(["steer_angles"] if steer_out else []), *(["feedforward"] if extra else [])],
        {"cse": True})


def _finite(value: ca.SX) -> ca.SX:
    """1 where ``value`` is finite, else 0 (NaN compares false)."""
    return ca.fabs(value) < math.inf


def _desaturated(wheels: ScalarWheels, twist: ca.SX) -> ca.SX:
    """:meth:`~mpc.robots.speed_checks.SpeedLimitChecks.desaturate`: ``twist`` scaled
    uniformly into the wheel speed limits (no failed wheel: every limit > 0)."""
    ratio = ca.mmax(ca.vertcat(*[ca.fabs(a * twist[0] + b * twist[1] + c * twist[2]) / limit
                                 for (a, b, c), limit in zip(wheels.rows, wheels.limits,
                                                             strict=True)]))
    return twist * ca.if_else(ratio > 1.0, 1.0 / ratio, 1.0)


def _clamped(wheels: ScalarWheels, target: ca.SX, last: ca.SX,
             dt: float) -> tuple[ca.SX, ca.SX]:
    """:func:`~mpc.control.clamp.clamp_command`'s scalar-wheel steps (``_clamp_scalar``):
    the speed scaling, then the acceleration step from ``last``; the twist and whether a
    step changed it."""
    tx, ty, tw = target[0], target[1], target[2]
    lx, ly, lw = last[0], last[1], last[2]
    scale = ca.SX(math.inf)
    for (a, b, c), limit, extra in zip(wheels.rows, wheels.limits, wheels.slack, strict=True):
        speed = ca.fabs(a * tx + b * ty + c * tw)
        scale = ca.if_else(speed - limit > extra, ca.fmin(scale, limit / speed), scale)
    over = scale < math.inf
    tx = ca.if_else(over, tx * scale * (1.0 - SPEED_SLACK), tx)
    ty = ca.if_else(over, ty * scale * (1.0 - SPEED_SLACK), ty)
    tw = ca.if_else(over, tw * scale * (1.0 - SPEED_SLACK), tw)
    changed = over
    if wheels.accel is not None:
        last_over = ca.SX(0)
        for (a, b, c), limit, extra in zip(wheels.rows, wheels.limits, wheels.slack,
                                           strict=True):
            last_over = ca.logic_or(last_over,
                                    ca.fabs(a * lx + b * ly + c * lw) - limit * (1 + 1e-9) > extra)
        sx, sy, sw = tx - lx, ty - ly, tw - lw
        ratio = ca.mmax(ca.vertcat(*[ca.fabs(a * sx + b * sy + c * sw) / (limit * dt)
                                     for (a, b, c), limit in zip(wheels.rows, wheels.accel,
                                                                 strict=True)]))
        limited = ca.logic_and(ca.logic_not(last_over), ratio > 1.0)
        keep = (1.0 - SPEED_SLACK) / ratio
        tx = ca.if_else(limited, lx + keep * sx, tx)
        ty = ca.if_else(limited, ly + keep * sy, ty)
        tw = ca.if_else(limited, lw + keep * sw, tw)
        changed = ca.logic_or(changed, limited)
    return ca.vertcat(tx, ty, tw), changed
