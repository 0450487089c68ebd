"""The fast path's QP, assembled once: a pure function of the model and the limit rows.

    minimise    1/2 z' P(p) z + q(p)' z
    subject to  x_0 = x0,  x_{k+1} - A_k x_k - B_k u_k = c_k,
                lower_k <= now_k u_k + before_k u_{k-1} <= upper_k   (the robot's limit rows,
                                                                      :mod:`mpc.robots.limits`)

and, in path mode, ``lower_k <= s_k <= upper_k`` (filled each tick: ``s_0``
fixed, a trust region around the sampled progress, never ahead of the
reference's own timing) and ``0 <= s_{k+1} - s_k <= max_progress_rate h_k``,
with ``z`` laid out as in :mod:`mpc.model.layout`. ``P`` and ``q`` are the
CasADi cost's Hessian (upper triangle; CasADi's CCS order is OSQP's CSC
order) and its gradient at ``z = 0`` (the cost is quadratic in ``z``),
evaluated each tick from ``p``. The constraint matrix keeps every entry of
``A_k`` and ``B_k`` as a dense 3x3 block, structural zeros included, so its
sparsity pattern never changes when the dynamics are re-linearised; where
each of those entries sits in the CSC data is computed here once.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, IntArray
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from mpc.robots.limits import StageLimits


@dataclass(frozen=True, eq=False)
class LimitSlots:
    """Where the stage limit rows sit: rows ``start .. start + N m``; ``slots`` (N, m, 6) the
    positions in the CSC data of each row's coefficients on ``u_k`` then on ``u_{k-1}``
    (-1 where stage 0 has no ``u_{-1}`` column: that part moves into the bounds)."""

    start: int
    slots: IntArray


@dataclass(frozen=True, eq=False)
class ProgressRows:
    """Path mode's rows: ``stages`` bound rows on ``s_k`` from ``start``, then rate rows."""

    start: int
    stages: int


@dataclass(frozen=True, eq=False)
class QpStructure:
    """Everything about the QP that is fixed for a controller's life.

    Attributes:
        cost_terms: CasADi ``p -> (P upper-triangle values, q)``.
        hessian: ``P`` with its final pattern (values at ``p = 0``).
        constraints: ``A`` with its final pattern (dynamics entries 0 until set).
        lower, upper: bounds with the per-tick entries still to fill.
        dynamics_slots: (N, 18) positions in ``constraints.data`` of
            ``-vec A_k, -vec B_k`` (column-major, as CasADi's linearisation gives them).
        limits: the robot's stage rows as set up (a robot may refill them each tick).
        limit_slots: where they sit in ``constraints``.
        progress: path mode's progress rows, or None in time mode.
        dual_shift: index map moving each per-stage block of the multipliers one stage
            earlier (the last stage repeated), for the warm start.
    """

    cost_terms: ca.Function
    hessian: sp.csc_matrix
    constraints: sp.csc_matrix
    lower: FloatArray
    upper: FloatArray
    dynamics_slots: IntArray
    limits: StageLimits
    limit_slots: LimitSlots
    progress: ProgressRows | None
    dual_shift: IntArray


class _Pattern:
    """Accumulates COO entries of ``A`` and remembers where each block went."""

    def __init__(self) -> None:
        self.rows: list[IntArray] = []
        self.cols: list[IntArray] = []
        self.values: list[FloatArray] = []
        self.count = 0

    def add(self, row: ArrayLike, col: ArrayLike, value: ArrayLike) -> IntArray:
        """Add entries; return their COO ids (in the broadcast shape)."""
        row, col, value = np.broadcast_arrays(row, col, value)
        ids = self.count + np.arange(row.size).reshape(row.shape)
        self.rows.append(row.ravel())
        self.cols.append(col.ravel())
        self.values.append(np.asarray(value, dtype=float).ravel())
        self.count += row.size
        return ids

    def to_csc(self, shape: tuple[int, int]) -> tuple[sp.csc_matrix, IntArray]:
        """CSC matrix with every entry kept, and ``position[id]`` in its data."""
        rows, cols = np.concatenate(self.rows), np.concatenate(self.cols)
        tagged = sp.coo_matrix((np.arange(1, self.count + 1, dtype=float), (rows, cols)),
                               shape=shape).tocsc()
        tagged.sort_indices()
        if tagged.nnz != self.count:
            raise RuntimeError("duplicate entries in the QP constraint pattern")
        position = np.empty(self.count, dtype=np.intp)
        position[tagged.data.astype(np.intp) - 1] = np.arange(self.count)
        matrix = tagged.copy()
        matrix.data[position] = np.concatenate(self.values)
        return matrix, position


def cost_terms(model: TrackingModel) -> tuple[ca.Function, sp.csc_matrix]:
    """CasADi ``p -> (triu(Hessian) values, gradient at z = 0)`` and ``P``'s pattern."""
    z, p = model.symbols()
    cost = model.cost(z, p)
    size = model.layouts.variables.size
    hessian = ca.triu(ca.hessian(cost, z)[0])
    gradient = ca.substitute(ca.gradient(cost, z), z, ca.DM.zeros(size))
    function = ca.Function("qp_cost", [p], [hessian, gradient])
    sparsity = function.sparsity_out(0)
    colind, row = sparsity.get_ccs()
    values = function(np.zeros(model.layouts.parameters.size))[0].nonzeros()
    pattern = sp.csc_matrix((np.asarray(values, dtype=float), np.asarray(row),
                             np.asarray(colind)), shape=(size, size))
    return function, pattern


def assemble_qp(model: TrackingModel, limits: StageLimits) -> QpStructure:
    """The QP of ``model`` with the robot's stage limit rows ``limits`` (module docstring)."""
    n = model.horizon
    variables = model.layouts.variables
    poses, twists = variables["poses"], variables["twists"]
    pattern = _Pattern()
    pattern.add(np.arange(3), np.arange(3), 1.0)  # x_0 = x0
    stage = np.arange(n)[:, None, None]
    r3, c3 = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")  # r3[i, j] = i
    dyn_rows = 3 + 3 * stage + r3  # (N, 3, 3)
    pattern.add(dyn_rows, poses.start + 3 * (stage + 1) + c3, np.eye(3))
    # Column-major ids so that they line up with CasADi's vec(A_k), vec(B_k).
    ids_a = pattern.add(dyn_rows, poses.start + 3 * stage + c3, 0.0)
    ids_b = pattern.add(dyn_rows, twists.start + 3 * stage + c3, 0.0)
    ids_a, ids_b = (ids.transpose(0, 2, 1).reshape(n, 9) for ids in (ids_a, ids_b))
    m_rows = 3 * (n + 1)
    lower: list[FloatArray] = [np.zeros(m_rows)]
    upper: list[FloatArray] = [np.zeros(m_rows)]
    m = limits.rows
    rows = m_rows + m * stage[:, :, 0] + np.arange(m)  # (N, m)
    now_ids = pattern.add(rows[:, :, None], twists.start + 3 * stage + np.arange(3), limits.now)
    before_ids = np.full((n, m, 3), -1, dtype=np.intp)
    if n > 1:
        before_ids[1:] = pattern.add(rows[1:, :, None],
                                     twists.start + 3 * stage[:-1] + np.arange(3),
                                     limits.before[1:])
    lower.append(limits.lower.ravel())
    upper.append(limits.upper.ravel())
    limit_start = m_rows
    m_rows += n * m
    blocks = [(0, 3, 1), (3, 3, n), (limit_start, m, n)]
    progress: ProgressRows | None = None
    if model.path:
        progress = ProgressRows(m_rows, n + 1)
        column = variables["progress"].start + np.arange(n + 1)
        pattern.add(m_rows + np.arange(n + 1), column, 1.0)
        rate_rows = m_rows + n + 1 + np.arange(n)
        pattern.add(rate_rows, column[1:], 1.0)
        pattern.add(rate_rows, column[:-1], -1.0)
        lower += [np.zeros(n + 1), np.zeros(n)]
        upper += [np.zeros(n + 1), model.max_progress_rate * model.durations]
        blocks += [(m_rows, 1, n + 1), (m_rows + n + 1, 1, n)]
        m_rows += 2 * n + 1
    matrix, position = pattern.to_csc((m_rows, variables.size))
    slots = np.concatenate((position[now_ids],
                            np.where(before_ids >= 0, position[np.maximum(before_ids, 0)], -1)),
                           axis=2)
    function, hessian = cost_terms(model)
    return QpStructure(
        cost_terms=function, hessian=hessian, constraints=matrix,
        lower=np.concatenate(lower), upper=np.concatenate(upper),
        dynamics_slots=np.concatenate((position[ids_a], position[ids_b]), axis=1),
        limits=limits, limit_slots=LimitSlots(limit_start, slots), progress=progress,
        dual_shift=stage_shift(blocks, m_rows))


def stage_shift(blocks: list[tuple[int, int, int]], size: int) -> IntArray:
    """Index map moving each ``(start, width, stages)`` block one stage earlier (last
    repeated); entries outside every block map to themselves."""
    index = np.arange(size)
    for start, width, stages in blocks:
        stage = np.minimum(np.arange(stages) + 1, stages - 1)
        index[start : start + width * stages] = (
            start + width * stage[:, None] + np.arange(width)).ravel()
    return index


def fill_inequality_bounds(structure: QpStructure, tick: TickInput, lower: FloatArray,
                           upper: FloatArray) -> None:
    """Write this tick's bounds of the rows on the inputs and the progress: the limit rows'
    (stage 0's part on the last command moved into its bounds), the progress rows'."""
    limits, start = structure.limits, structure.limit_slots.start
    stop = start + limits.lower.size
    lower[start:stop] = limits.lower.ravel()
    upper[start:stop] = limits.upper.ravel()
    shift = limits.before[0] @ tick.last_twist
    m = limits.rows
    lower[start:start + m] -= shift
    upper[start:start + m] -= shift
    rows, path = structure.progress, tick.path
    if rows is not None and path is not None:
        lower[rows.start:rows.start + rows.stages] = path.lower
        upper[rows.start:rows.start + rows.stages] = path.upper


def fill_limit_values(structure: QpStructure, data: FloatArray) -> None:
    """Write the limit rows' coefficients into the constraint matrix's CSC ``data``."""
    limits, slots = structure.limits, structure.limit_slots.slots
    data[slots[:, :, :3]] = limits.now
    data[slots[1:, :, 3:]] = limits.before[1:]
