"""Fast path: one sparse QP per tick solved by OSQP (real-time iteration).

Each tick linearises the CasADi model around the shifted previous plan (one
mapped call for all stages) and solves

    minimise    1/2 z' P(p) z + q(p)' z
    subject to  x_0 = x0,  x_{k+1} - A_k x_k - B_k u_k = c_k,
                |C u_k| <= speed bounds,  |C (u_k - u_{k-1})| <= accel bounds,

with ``z = (x_0..x_N, u_0..u_{N-1})``. ``P`` and ``q`` are the CasADi
cost's Hessian and its gradient at ``z = 0`` (the cost is quadratic in
``z``), evaluated each tick from the parameters ``p`` (the direction of
travel enters ``P``). OSQP is set up once; each tick updates only ``P``'s
values, ``q``, ``l``, ``u`` and the dynamics entries of ``A``, whose
sparsity patterns never change:
``A_k`` and ``B_k`` are stored as dense 3x3 blocks, structural zeros
included, and their positions in ``A.data`` are computed once.
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np
import osqp
import scipy.sparse as sp
from numpy.typing import ArrayLike

from mpc.limits import polygon_factor, polygon_rows
from mpc.model import BufferedFunction, TrackingModel
from mpc.robots.base import FloatArray, IntArray
from mpc.solution import SolveResult

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


class _Pattern:
    """Accumulates COO entries of ``A`` and remembers where each block went."""

    def __init__(self) -> None:
        self.rows: list[FloatArray] = []
        self.cols: list[FloatArray] = []
        self.values: list[FloatArray] = []
        self.count = 0

    def add(self, row: ArrayLike, col: ArrayLike, value: ArrayLike) -> IntArray:
        """Add entries; return their COO ids."""
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


class QpSolver:
    """OSQP real-time-iteration solver of a :class:`~mpc.model.TrackingModel`.

    Args:
        model: the tracking problem.
        polygon_sides: sides of the polygon inscribed in a swerve module's
            speed disk (even, >= 4).
        max_iter: OSQP iterations per tick at most.
        time_limit: OSQP time per tick at most [s]; 0 for none.
        tolerance: OSQP's absolute and relative tolerance.
    """

    name = "osqp"

    def __init__(
        self,
        model: TrackingModel,
        polygon_sides: int = 16,
        max_iter: int = 500,
        time_limit: float = 0.0,
        tolerance: float = 1e-4,
    ) -> None:
        self.model = model
        n = model.horizon
        robot = model.robot
        n_poses = model.n_poses

        # Cost: P(p) = Hessian (upper triangle, CasADi's CCS order = OSQP's CSC
        # order) and q(p) = gradient at z = 0, evaluated into buffers each tick.
        z, p, poses, twists = model.symbols()
        cost = model.cost(poses, twists, p)
        hessian = ca.triu(ca.hessian(cost, z)[0])
        gradient = ca.substitute(ca.gradient(cost, z), z, ca.DM.zeros(model.n_variables))
        cost_terms = ca.Function("qp_cost", [p], [hessian, gradient])
        sparsity = cost_terms.sparsity_out(0)
        self._params = np.zeros(model.n_parameters)
        self._p_data = np.zeros(sparsity.nnz())
        self._q = np.zeros(model.n_variables)
        self._evaluate_cost = BufferedFunction(cost_terms, [self._params], [self._p_data, self._q])
        colind, row = sparsity.get_ccs()
        self._evaluate_cost()
        hessian_matrix = sp.csc_matrix(
            (self._p_data.copy(), np.asarray(row), np.asarray(colind)),
            shape=(model.n_variables, model.n_variables),
        )

        # Constraints.
        rows, wheel = polygon_rows(robot, polygon_sides)
        factor = polygon_factor(robot, polygon_sides)
        speed_bound = robot.max_wheel_speed[wheel] * factor
        accel = robot.max_wheel_accel
        pattern = _Pattern()
        eye = np.eye(3)
        pattern.add(np.arange(3), np.arange(3), 1.0)
        stage = np.arange(n)[:, None, None]
        r3, c3 = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")  # r3[i, j] = i
        dyn_rows = 3 + 3 * stage + r3  # (N, 3, 3)
        pattern.add(dyn_rows, 3 * (stage + 1) + c3, eye)
        # Column-major ids so that they line up with CasADi's vec(A_k), vec(B_k).
        ids_a = pattern.add(dyn_rows, 3 * stage + c3, 0.0)
        ids_b = pattern.add(dyn_rows, n_poses + 3 * stage + c3, 0.0)
        ids_a, ids_b = (ids.transpose(0, 2, 1).reshape(n, 9) for ids in (ids_a, ids_b))
        m_rows = 3 * (n + 1)
        n_limit = rows.shape[0]
        limit_rows = m_rows + n_limit * stage[:, :, 0] + np.arange(n_limit)  # (N, m)
        for k in range(n):
            cols = n_poses + 3 * k + np.arange(3)
            pattern.add(limit_rows[k][:, None], cols[None, :], rows)
        lower = [np.zeros(m_rows), -np.tile(speed_bound, n)]
        upper = [np.zeros(m_rows), np.tile(speed_bound, n)]
        m_rows += n * n_limit
        self._accel_rows: FloatArray | None = None
        if accel is not None:
            self._accel_start = m_rows
            accel_bound = accel[wheel] * model.dt * factor
            for k in range(n):
                cols = n_poses + 3 * k + np.arange(3)
                row = m_rows + n_limit * k + np.arange(n_limit)
                pattern.add(row[:, None], cols[None, :], rows)
                if k > 0:
                    pattern.add(row[:, None], cols[None, :] - 3, -rows)
            lower.append(-np.tile(accel_bound, n))
            upper.append(np.tile(accel_bound, n))
            m_rows += n * n_limit
            self._accel_rows = rows
            self._accel_bound = accel_bound
        matrix, position = pattern.to_csc((m_rows, model.n_variables))
        self._a_data = matrix.data.copy()
        self._dynamics_slots = np.concatenate((position[ids_a], position[ids_b]), axis=1)
        self._lower = np.concatenate(lower)
        self._upper = np.concatenate(upper)
        self._n_limit = n_limit

        self._solver = osqp.OSQP()
        self._solver.setup(
            hessian_matrix,
            np.zeros(model.n_variables),
            matrix,
            self._lower,
            self._upper,
            verbose=False,
            warm_starting=True,
            polishing=False,
            max_iter=int(max_iter),
            time_limit=float(time_limit) if time_limit > 0 else 1e10,
            eps_abs=float(tolerance),
            eps_rel=float(tolerance),
            check_termination=5,
        )
        self._initial_rho = float(self._solver.settings.rho)
        self._dual: FloatArray | None = None
        self._zero_dual = np.zeros(m_rows)
        core = getattr(self._solver, "_solver", None)
        needed = ("update_data_vec", "update_data_mat", "warm_start", "solve", "info", "solution")
        self._core = core if all(hasattr(core, name) for name in needed) else None
        # Zero-copy evaluation of the mapped linearisation: CasADi reads the
        # (N, 3) C-ordered arrays as its 3 x N column-major inputs and writes
        # (N, 21) rows (c_k, vec A_k, vec B_k).
        self._lin_poses = np.zeros((n, 3))
        self._lin_twists = np.zeros((n, 3))
        self._lin_out = np.zeros((n, 21))
        self._linearize = BufferedFunction(
            model.linearization, [self._lin_poses, self._lin_twists], [self._lin_out])
        self._dual_shift = self._stage_shift(
            [(0, 3, 1), (3, 3, n), (3 * (n + 1), n_limit, n)]
            + ([(self._accel_start, n_limit, n)] if accel is not None else []),
            m_rows,
        )

    def _run_osqp(self, guess: FloatArray, dual: FloatArray) -> tuple[Any, FloatArray, FloatArray]:
        """Update, warm start and solve; returns (info, x, y).

        osqp-python's ``update`` and ``solve`` wrappers cost about 50 us a
        tick here (bound clipping, a derivative cache, a namespace built from
        every info field), a fifth of the whole tick. When the extension
        object behind them is there (osqp 1.x), call it directly with the
        same data; otherwise use the public API. Our bounds are always
        finite, so the wrapper's clipping to +-OSQP_INFTY is a no-op.
        """
        core = self._core
        if core is not None:
            core.update_data_vec(q=self._q, l=self._lower, u=self._upper)
            core.update_data_mat(P_x=self._p_data, P_i=None, A_x=self._a_data, A_i=None)
            core.warm_start(guess, dual)
            core.solve()
            return core.info, core.solution.x, core.solution.y
        solver = self._solver
        solver.update(q=self._q, l=self._lower, u=self._upper, Px=self._p_data, Ax=self._a_data)
        solver.warm_start(x=guess, y=dual)
        result = solver.solve(raise_error=False)
        return result.info, result.x, result.y

    @staticmethod
    def _stage_shift(blocks: list[tuple[int, int, int]], size: int) -> IntArray:
        """Index map moving each per-stage block one stage earlier (last repeated)."""
        index = np.arange(size)
        for start, width, stages in blocks:
            stage = np.minimum(np.arange(stages) + 1, stages - 1)
            index[start : start + width * stages] = (
                start + width * stage[:, None] + np.arange(width)
            ).ravel()
        return index

    def reset(self) -> None:
        """Forget the warm start and OSQP's adapted step size, so that a run repeats exactly."""
        self._dual = None
        self._solver.update_settings(rho=self._initial_rho)

    def solve(
        self,
        pose: FloatArray,
        poses_ref: FloatArray,
        twists_ref: FloatArray,
        directions: FloatArray,
        last_twist: FloatArray,
        guess_poses: FloatArray,
        guess_twists: FloatArray,
    ) -> SolveResult:
        """Solve one tick around the guess (N+1, 3) poses and (N, 3) twists."""
        model = self.model
        self._lin_poses[:] = guess_poses[:-1]
        self._lin_twists[:] = guess_twists
        self._linearize()
        stages = self._lin_out
        self._a_data[self._dynamics_slots] = -stages[:, 3:]
        lower, upper = self._lower, self._upper
        lower[:3] = pose
        lower[3 : model.n_poses] = stages[:, :3].ravel()
        upper[: model.n_poses] = lower[: model.n_poses]
        if self._accel_rows is not None:
            base = self._accel_rows @ last_twist
            start, stop = self._accel_start, self._accel_start + self._n_limit
            lower[start:stop] = base - self._accel_bound
            upper[start:stop] = base + self._accel_bound
        self._params[:] = model.pack_parameters(pose, poses_ref, twists_ref, directions,
                                                last_twist)
        self._evaluate_cost()
        guess = np.concatenate((guess_poses.ravel(), guess_twists.ravel()))
        dual = self._zero_dual if self._dual is None else self._dual[self._dual_shift]
        info, solution, multipliers = self._run_osqp(guess, dual)
        # A sum is non-finite if any entry is (or if it overflows: then too, distrust it).
        usable = info.status_val in _ACCEPTED or (
            info.status_val in _UNFINISHED
            and info.prim_res <= USABLE_PRIMAL_RESIDUAL
            and info.dual_res <= USABLE_DUAL_RESIDUAL)
        success = usable and math.isfinite(solution.sum())
        self._dual = multipliers.copy() if success else None
        poses, twists = model.split(solution)
        return SolveResult(
            success=success,
            status=str(info.status),
            poses=poses,
            twists=twists,
            # OSQP's own time: the KKT refactorisation done in update() plus the iterations.
            solve_time=float(info.update_time + info.solve_time),
            iterations=int(info.iter),
        )


