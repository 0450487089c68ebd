"""The fast path's QP condensed onto the inputs (and, in path mode, the progress).

The states are eliminated with the model linearised around the guess twists
``ubar``: ``dx_{k+1} = A_k dx_k + B_k du_k`` along the exact rollout ``xbar`` of
``ubar`` from the measured pose, where ``B_k = df/du`` and ``A_k = I + E_k``,
``E_k`` turning stage ``k``'s displacement ``D_k = xbar_{k+1} - xbar_k`` with
the heading (``E_k dx = (-D_ky, D_kx, 0) dtheta``). The QP is posed in the step
``d = y - ybar`` from the guess ``ybar`` (``y = (u, s)``)::

    minimise 1/2 d' H d + g' d,   H = S' P_xx S + (input and progress terms),

with ``g`` the cost's exact gradient at the guess (:func:`tick_terms`) and
``S`` the exact state sensitivities,
``S_kj = B_j + (sum_{m=j+1}^{k-1} E_m) B_j``: the lever arm of a heading
change on every later step (Gauss-Newton). A plan is a fixed point of the
iteration iff the exact gradient meets the optimality conditions, so a
Hessian kept from a nearby tick changes how fast the iteration converges,
not where.

``P`` and ``q`` are the sparse QP's cost terms (:mod:`.qp_structure`). Every
inequality of the sparse QP is on the inputs and the progress only, so the
constraint matrix carries over unchanged.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray, IntArray
from mpc.model.tracking import TrackingModel
from mpc.solvers.qp_structure import QpStructure


def tick_terms(model: TrackingModel, cost_terms: ca.Function) -> ca.Function:
    """One CasADi call for a tick's terms: ``(p, u (3 x N)[, s (N+1)]) -> (P upper-triangle
    values, the rollout x (3 x N+1), vec B_k (9 x N), the exact gradient in y = (u, s),
    the rollout's planar steps D (2 x N))``.

    The gradient is the cost's along the rollout, ``d/dy J(x(u), u, s; p)``: the cost's
    partial derivatives at the rollout carried back through it by the adjoint recursion
    ``lambda_k = dJ/dx_k + A_k' lambda_{k+1}``, ``dJ/du_k = dJ/du_k (partial) +
    B_k' lambda_{k+1}``, with the exact ``A_k = I + E_k`` (see the module) and the ``B_k``
    the call returns anyway: the same numbers as CasADi's reverse mode through the
    rollout (to rounding; tested) in fewer instructions, as it does not differentiate the
    SE(2) step a second time (docs/design/tick-costs.md)."""
    variables, parameters = model.layouts
    n = model.horizon
    p = ca.SX.sym("p", parameters.size)
    twists = ca.SX.sym("u", 3, n)
    poses, sensitivities = model.rollout(parameters.symbol(p, "x0"), twists)
    z = ca.SX.zeros(variables.size)
    inputs = [p, twists]
    for name, value in (("poses", ca.vec(poses)), ("twists", ca.vec(twists))):
        field = variables[name]
        z[field.start:field.start + field.size] = value
    progress = None
    if model.path:
        field = variables["progress"]
        progress = ca.SX.sym("s", field.size)
        z[field.start:field.start + field.size] = progress
        inputs.append(progress)
    point = ca.SX.sym("z", variables.size)
    partial = ca.Function("cost_gradient", [point, p],
                          [ca.gradient(model.cost(point, p), point)])(z, p)
    along_poses = variables.symbol(partial, "poses")  # 3 x N+1
    along_twists = variables.symbol(partial, "twists")  # 3 x N
    adjoint = along_poses[:, n]
    columns: list[ca.SX] = [ca.SX()] * n
    for k in range(n - 1, -1, -1):
        columns[k] = along_twists[:, k] + ca.reshape(sensitivities[:, k], 3, 3).T @ adjoint
        if k:  # A_k' adjoint: the heading's entry gathers the lever arm of stage k's step
            step = poses[:2, k + 1] - poses[:2, k]
            adjoint = along_poses[:, k] + adjoint + ca.vertcat(
                0, 0, step[0] * adjoint[1] - step[1] * adjoint[0])
    gradient = [ca.vec(ca.horzcat(*columns))]
    if progress is not None:
        gradient.append(ca.vec(variables.symbol(partial, "progress")))
    hessian, _ = cost_terms(p)
    steps = poses[:2, 1:] - poses[:2, :-1]
    # Common subexpressions merged (a fifth fewer instructions, the same numbers).
    return ca.Function("tick_terms", inputs, [hessian, poses, sensitivities,
                                              ca.vertcat(*gradient), steps], {"cse": True})


def plan_poses(horizon: int) -> ca.Function:
    """``(x (3 x N+1), vec B_k (9 x N), d (3 x N), D (2 x N)) -> poses (3 x N+1)``: the
    predicted poses after the twist step ``d`` from the guess whose rollout is ``x`` (its
    planar steps ``D``), through the linearised dynamics: ``x_k`` plus the sum over
    ``j < k`` of ``B_j d_j + E_j`` (heading change before stage ``j``), the lever arm
    ``E_j = (-D_jy, D_jx, 0)`` times it (``S d`` without ``S``: one small CasADi call
    instead of a handful of NumPy products)."""
    rollout = ca.SX.sym("x", 3, horizon + 1)
    sensitivities = ca.SX.sym("B", 9, horizon)
    step, steps = ca.SX.sym("d", 3, horizon), ca.SX.sym("D", 2, horizon)
    moved, turned = ca.SX.zeros(3), ca.SX(0)
    poses = [rollout[:, 0]]
    for k in range(horizon):
        move = ca.reshape(sensitivities[:, k], 3, 3) @ step[:, k]
        moved = moved + ca.vertcat(move[0] - steps[1, k] * turned,
                                   move[1] + steps[0, k] * turned, move[2])
        turned = turned + move[2]
        poses.append(rollout[:, k + 1] + moved)
    return ca.Function("plan_poses", [rollout, sensitivities, step, steps],
                       [ca.horzcat(*poses)], {"cse": True})


class Condenser:
    """Index maps (built once) and the per-tick condensing arithmetic.

    Args:
        model: the tracking problem.
        structure: its sparse QP (cost pattern and inequality rows).
    """

    def __init__(self, model: TrackingModel, structure: QpStructure) -> None:
        n = model.horizon
        variables = model.layouts.variables
        self.horizon = n
        self.n_inputs = 3 * n
        poses, twists = variables["poses"], variables["twists"]
        progress = variables.fields.get("progress")
        self.size = self.n_inputs + (progress.size if progress is not None else 0)
        coo = structure.hessian.tocoo()  # same entry order as the CSC data
        self._rows, self._cols = coo.row.astype(np.intp), coo.col.astype(np.intp)
        self.dense = np.zeros((variables.size, variables.size))  # symmetric P
        stage = np.arange(n + 1)[:, None, None]
        a, b = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
        self._xx = (poses.start + 3 * stage + a, poses.start + 3 * stage + b)  # (N+1, 3, 3)
        self._x = slice(poses.start, poses.start + poses.size)
        self._u = slice(twists.start, twists.start + twists.size)
        self._s = None if progress is None else slice(progress.start,
                                                      progress.start + progress.size)
        # later[j] = sum over stages k > j of a per-stage quantity: one small matrix product.
        self._after = (np.arange(n + 1)[None, :] > np.arange(n)[:, None]).astype(float)
        # S's nonzero blocks (k, j), j < k: their entries' flat places in S (N+1, 3, N, 3)
        # and in B (N, 3, 3), and each pair's place in an (N+1) x N grid
        later, earlier = np.nonzero(self._after.T)
        row, column = np.arange(3)[None, :, None], np.arange(3)[None, None, :]
        k, j = later[:, None, None], earlier[:, None, None]
        self._block_target = (((k * 3 + row) * n + j) * 3 + column).ravel()
        self._block_source = ((j * 3 + row) * 3 + column).ravel()
        self._pair_index = later * n + earlier
        self._states = np.zeros((n + 1, 3, n, 3))  # S, stage by stage (N+1, 3, N, 3)
        self._summed_steps = np.zeros((n + 1, 2))  # the rollout's planar steps summed
        self._check_structure(structure)
        rows = structure.constraints[3 * (n + 1):, :]
        self.columns: IntArray = (np.r_[self._u, self._s] if self._s is not None
                                  else np.r_[self._u])  # y's entries in z
        self.constraints = rows[:, self.columns].toarray()  # rows on y
        self.first_row = 3 * (n + 1)

    def _check_structure(self, structure: QpStructure) -> None:
        """The condensing relies on the cost's pattern: no state-input coupling, stage-wise
        state blocks, and inequality rows that do not touch the states."""
        self.scatter(np.arange(1.0, structure.hessian.nnz + 1))
        dense = self.dense
        x, u = self._x, self._u
        stagewise = np.zeros_like(dense[x, x], dtype=bool)
        stagewise[self._xx[0] - x.start, self._xx[1] - x.start] = True
        if dense[x, u].any() or (dense[x, x] * ~stagewise).any():
            raise RuntimeError("condensing needs a cost without state-input or cross-stage "
                               "state coupling")
        if structure.constraints[3 * (self.horizon + 1):, x].nnz:
            raise RuntimeError("condensing needs inequality rows free of the states")

    def scatter(self, p_data: FloatArray) -> None:
        """Write the upper-triangle values of ``P`` into the dense symmetric ``P``."""
        self.dense[self._rows, self._cols] = p_data
        self.dense[self._cols, self._rows] = p_data

    def isotropic(self) -> bool:
        """Whether the scattered cost weighs every stage's position error alike in all
        directions and has no position-progress coupling: then ``H`` is unchanged when the
        whole plan turns (``B_k -> R B_k`` for one rotation ``R``)."""
        if self._s is not None and self.dense[self._x, self._s].any():
            return False  # path mode's contouring couples positions and progress
        stages = self.dense[self._xx]
        planar = stages[:, :2, :2]
        # np.allclose's tolerances (1e-8 absolute, 1e-5 relative), without its overhead
        # (this runs on every tick whose cost terms changed: path mode's do, every tick).
        xx, yy = planar[:, 0, 0], planar[:, 1, 1]
        return bool(np.abs(planar[:, 0, 1]).max() <= 1e-8
                    and (np.abs(xx - yy) <= 1e-8 + 1e-5 * np.abs(yy)).all()
                    and np.abs(stages[:, :2, 2]).max() <= 1e-8)

    def state_sensitivities(self, sensitivity: FloatArray,
                            displacement: FloatArray) -> FloatArray:
        """``S`` as (N+1, 3, 3N): stage ``k``'s pose against every input (Gauss-Newton).

        Written into one buffer kept between calls (the caller uses it before the next):
        only its blocks ``j < k`` (the rest stay zero), gathered and written by flat
        indices built once (quicker than masked products: docs/design/tick-costs.md)."""
        n = self.horizon
        # S[k, :, j, :] = B_j for every input j acting before stage k (j < k).
        blocks = sensitivity.reshape(-1)[self._block_source].reshape(-1, 3, 3)
        # The heading row of B_j is (0, 0, dt_j): a heading change of omega_j dt turns the
        # steps of stages j+1 .. k-1, which moves x_k by the sum of (-D_y, D_x) of those.
        summed = self._summed_steps
        np.cumsum(displacement, axis=0, out=summed[1:])
        between = (summed[:, None, :] - summed[None, 1:, :]).reshape(-1, 2)[self._pair_index]
        between *= blocks[:, 2, 2, None]
        blocks[:, 0, 2] -= between[:, 1]
        blocks[:, 1, 2] += between[:, 0]
        states = self._states
        states.reshape(-1)[self._block_target] = blocks.reshape(-1)
        return states.reshape(n + 1, 3, 3 * n)

    def last_states(self) -> FloatArray:
        """``S`` as the last :meth:`state_sensitivities` call wrote it (N+1, 3, 3N)."""
        n = self.horizon
        return self._states.reshape(n + 1, 3, 3 * n)

    def hessian(self, states: FloatArray) -> FloatArray:
        """``H`` for the state sensitivities ``S`` (N+1, 3, 3N), from the scattered ``P``."""
        dense, n3 = self.dense, self.n_inputs
        stages = dense[self._xx]  # (N+1, 3, 3): P_xx of each stage
        flat = states.reshape(-1, n3)
        weighted = np.matmul(stages, states).reshape(-1, n3)  # P_xx S, stage by stage
        hessian = np.empty((self.size, self.size))
        hessian[:n3, :n3] = flat.T @ weighted + dense[self._u, self._u]
        if self._s is not None:
            coupling = dense[self._x, self._s].reshape(self.horizon + 1, 3, -1)
            # P_xs couples x_k with s_k only: column k is stage k's 3-vector.
            stages_k = np.arange(self.horizon + 1)
            columns = coupling[stages_k, :, stages_k]  # (N+1, 3)
            us = np.matmul(columns[:, None, :], states)[:, 0, :].T + dense[self._u, self._s]
            hessian[:n3, n3:] = us
            hessian[n3:, :n3] = us.T
            hessian[n3:, n3:] = dense[self._s, self._s]
        return hessian
