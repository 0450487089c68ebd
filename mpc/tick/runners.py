"""The two ways to run the tick's graphs, behind one interface: the compiled library
(:class:`NativeTick`: ``tick.c`` and the generated graphs, daqp's C workspace kept) and
CasADi's virtual machine (:class:`VirtualTick`: the same graphs evaluated by CasADi, the
QP by the daqp Python module with the same rows, kept between ticks the same way).

Both write one output array a tick: status code, daqp's exit flag, iterations, solve
time [s], clamped (0/1), failures in a row, Hessians built this tick, the twist (3), the
wheel speeds (w), the plan's poses (3 (N+1), a stage's three numbers together), for
swerve the steer angles (n), in path mode the planned progress (N+1) [s], for a motor-aware
robot the feedforward (:func:`mpc.tick.motors.motor_feedforward`, 5 w). Both keep the
Hessian across ticks by the same rule (:mod:`mpc.tick.reuse`); swerve's and a motor
model's rows move every tick (whitened every tick, daqp given them every tick) and swerve's
steer angles are state (the last commanded, or set).
"""

from __future__ import annotations

import ctypes
import math
from pathlib import Path
from typing import Protocol

import daqp
import numpy as np
from scipy.linalg import lapack

from mpc.arrays import FloatArray
from mpc.buffered import BufferedFunction
from mpc.tick.graphs import COLD, HOLD, SOLVED, UNPLANNED, WARM, TickGraphs
from mpc.tick.path import AGAIN
from mpc.tick.reuse import must_rebuild

#: The output array's leading fields (then the twist, the wheel speeds, the poses).
STATUS, FLAG, ITERATIONS, SOLVE_TIME, CLAMPED, FAILURES, REBUILT, TWIST = range(8)

#: daqp's constraint flag of an equality row (active and immutable).
_EQUALITY = 5


def output_size(graphs: TickGraphs) -> int:
    """Numbers in a tick's output array."""
    return (TWIST + 3 + graphs.wheels + 3 * (graphs.horizon + 1) + graphs.steer
            + _progress(graphs) + graphs.feedforward)


def _progress(graphs: TickGraphs) -> int:
    """Progress values a plan has: N+1 in path mode (:mod:`mpc.tick.path`), else 0."""
    return int(getattr(graphs, "progress", 0))


class TickRunner(Protocol):
    """One implementation of the tick: :attr:`path` names it."""

    path: str

    def reset(self, last: FloatArray) -> None:
        """Forget the plan, failures and active set; ``last`` (3,) the twist executing."""

    def set_steer(self, angles: FloatArray) -> None:
        """The modules' steer angles now [rad] (swerve: the state the next tick starts
        from; each tick leaves its commanded angles there)."""

    def step(self, pose: FloatArray, ref_poses: FloatArray,
             ref_velocities: FloatArray) -> FloatArray:
        """One tick (pose (3,), the window's poses and world velocities (N+1, 3); path
        mode: the parameter vector and the progress bounds (N+1, 2)): the output array
        (the runner's own, rewritten next tick)."""

    def again(self) -> None:
        """Path mode's warm-up: the next step solves the last one again (``tick.c``'s
        ``mpc_tick_again``)."""


class NativeTick:
    """The compiled library (:func:`~mpc.tick.build.compiled_library`), through ctypes."""

    path = "compiled"

    def __init__(self, library: Path, graphs: TickGraphs, max_iter: int,
                 budgeted: bool, rebuild_drift: float) -> None:
        lib = ctypes.CDLL(str(library))
        lib.mpc_tick_init.restype = ctypes.c_void_p
        lib.mpc_tick_init.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_double]
        lib.mpc_tick_free.argtypes = [ctypes.c_void_p]
        lib.mpc_tick_reset.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        lib.mpc_tick_step.argtypes = [ctypes.c_void_p] + [ctypes.c_void_p] * 4
        lib.mpc_tick_step.restype = ctypes.c_int
        if graphs.steer:
            lib.mpc_tick_set_steer_angles.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        lib.mpc_tick_again.argtypes = [ctypes.c_void_p]
        if lib.mpc_tick_output_size() != output_size(graphs):
            raise RuntimeError("the compiled tick's output layout differs from the graphs'")
        handle = lib.mpc_tick_init(int(max_iter), int(budgeted), float(rebuild_drift))
        if not handle:
            raise RuntimeError("the compiled tick could not set daqp up")
        self._lib, self._handle = lib, handle
        self._out = np.zeros(output_size(graphs))
        self._pose = np.zeros(3)
        self._step = lib.mpc_tick_step
        self._out_pointer = self._out.ctypes.data
        self._pose_pointer = self._pose.ctypes.data

    def __del__(self) -> None:
        handle, self._handle = getattr(self, "_handle", None), None
        if handle:
            self._lib.mpc_tick_free(handle)

    def reset(self, last: FloatArray) -> None:
        twist = np.ascontiguousarray(last, dtype=float)
        self._lib.mpc_tick_reset(self._handle, twist.ctypes.data)

    def set_steer(self, angles: FloatArray) -> None:
        values = np.ascontiguousarray(angles, dtype=float)
        self._lib.mpc_tick_set_steer_angles(self._handle, values.ctypes.data)

    def again(self) -> None:
        self._lib.mpc_tick_again(self._handle)

    def step(self, pose: FloatArray, ref_poses: FloatArray,
             ref_velocities: FloatArray) -> FloatArray:
        self._pose[:] = pose
        poses = np.ascontiguousarray(ref_poses, dtype=float)
        velocities = np.ascontiguousarray(ref_velocities, dtype=float)
        self._step(self._handle, self._pose_pointer, poses.ctypes.data,
                   velocities.ctypes.data, self._out_pointer)
        return self._out


def inverse_factor(hessian: FloatArray) -> FloatArray:
    """``L^{-1}`` (lower) of ``L`` with ``H = L L'``, by LAPACK; a Hessian that is not
    positive definite is regularised first, as :mod:`mpc.solvers.dense` does (``tick.c``'s
    loops do the same), and NaN if that fails too."""
    factor, info = lapack.dpotrf(hessian, lower=1, clean=1)
    if info != 0:
        factor, info = lapack.dpotrf(hessian + 1e-9 * np.trace(hessian)
                                     * np.eye(hessian.shape[0]), lower=1, clean=1)
        if info != 0:
            return np.full_like(hessian, math.nan)
    inverse, _ = lapack.dtrtri(factor, lower=1, overwrite_c=1)
    return inverse


class VirtualTick:
    """The graphs in CasADi's virtual machine, the Cholesky factor by LAPACK, daqp's Python
    module for the QP (the same rows; its model kept between ticks: its active set is the
    warm start)."""

    path = "virtual-machine"

    def __init__(self, graphs: TickGraphs, max_iter: int, budgeted: bool,
                 rebuild_drift: float) -> None:
        n, nv, m = graphs.horizon, graphs.variables, graphs.rows
        self._graphs, self._budgeted = graphs, budgeted
        self._rebuild_drift = rebuild_drift
        self._kept = self._rebuilt = False  # a Hessian is kept; this tick rebuilt it
        self._kept_terms, self._terms = np.zeros(graphs.terms), np.zeros(graphs.terms)
        self._drift = np.zeros(1)
        self._settings = {"iter_limit": int(max_iter)}
        self._last, self._plan = np.zeros(3), np.zeros((n, 3))
        self._memory, self._warm = np.zeros(2), False
        # (the window's poses and velocities, (N+1, 3); path mode: the parameter vector
        # and the progress bounds, (N+1, 2))
        self._pose, self._poses, self._velocities = (
            np.zeros(3), np.zeros(graphs.prepare.size_in(1)[::-1]),
            np.zeros(graphs.prepare.size_in(2)[::-1]))
        self._again, self._before = False, np.zeros(5)  # path mode's warm-up (again)
        self._progress = np.zeros(_progress(graphs))
        self._mode = np.zeros(1)
        self._moving = graphs.moving_rows > 0  # rows every tick (swerve: with a state)
        self._steer, self._next_steer = np.zeros(graphs.steer), np.zeros(graphs.steer)
        self._state = np.array(graphs.row_state, dtype=float)
        self._next_state = np.zeros(len(graphs.row_state))
        self._row_values = np.zeros(graphs.moving_rows)
        extra_in = [self._steer, self._state] if self._moving else []
        extra_out = [self._row_values, self._next_state] if self._moving else []
        self._hessian, self._gradient = np.zeros((nv, nv)), np.zeros(nv)
        self._inverse = np.zeros(nv * (nv + 1) // 2)  # L^{-1}'s lower triangle, packed
        self._packed = np.triu_indices(nv)  # of X' in C order: X's lower, column by column
        self._f, self._rows = np.zeros(nv), np.zeros((m, nv))
        self._lower, self._upper = np.zeros(m), np.zeros(m)
        self._carry = np.zeros(graphs.carry)
        self._prepare_graph = BufferedFunction(
            graphs.prepare, [self._pose, self._poses, self._velocities, self._last,
                             self._plan, self._mode, self._kept_terms, *extra_in],
            [self._gradient, self._lower, self._upper, self._carry, self._terms,
             self._drift, *extra_out])
        self._hessian_graph = BufferedFunction(graphs.hessian, [self._carry],
                                               [self._hessian])
        self._whiten = BufferedFunction(graphs.whiten, [self._inverse, self._gradient],
                                        [self._f])
        self._whiten_rows = BufferedFunction(
            graphs.whiten_rows, [self._inverse, *([self._row_values] if self._moving else [])],
            [self._rows])
        self._y, self._flag, self._step = np.zeros(nv), np.zeros(1), np.zeros(nv)
        self._unwhiten = BufferedFunction(graphs.unwhiten, [self._inverse, self._y],
                                          [self._step])
        self._status, self._twist = np.zeros(1), np.zeros(3)
        self._speeds, self._clamped = np.zeros(graphs.wheels), np.zeros(1)
        self._plan_poses, self._next_plan = np.zeros((n + 1, 3)), np.zeros((n, 3))
        self._next_memory = np.zeros(2)
        self._feedforward = np.zeros(graphs.feedforward)  # a motor model's
        self._finish = BufferedFunction(
            graphs.finish, [self._step, self._flag, self._carry, self._last, self._plan,
                            self._memory, *([self._steer] if graphs.steer else [])],
            [self._status, self._twist, self._speeds, self._clamped, self._plan_poses,
             self._next_plan, self._next_memory,
             *([self._next_steer] if graphs.steer else []),
             *([self._progress] if self._progress.size else []),
             *([self._feedforward] if self._feedforward.size else [])])
        self._solver: daqp.Model | None = None
        self._out = np.zeros(output_size(graphs))

    def reset(self, last: FloatArray) -> None:
        self._last[:] = last
        self._plan[:] = 0.0
        self._memory[:] = 0.0
        self._warm = self._again = False
        self._forget()

    def set_steer(self, angles: FloatArray) -> None:
        self._steer[:] = angles

    def again(self) -> None:
        self._last[:], self._memory[:] = self._before[:3], self._before[3:]
        self._forget()
        self._again = True

    def _forget(self) -> None:
        """daqp's model and the kept Hessian dropped (``tick.c``'s ``forget``)."""
        self._solver = None
        self._kept = False

    def _prepare(self, planned: bool) -> None:
        """``prepare``; the Hessian, its factor and the whitened rows rebuilt if the rule
        says so (:func:`~mpc.tick.reuse.must_rebuild`; not on an unplanned tick);
        ``whiten``: the whitened QP in ``_f``, ``_rows``, ``_lower``, ``_upper``."""
        self._prepare_graph()
        if planned:  # (swerve: the faces' directions turned; no solve, no turn)
            self._state[:] = self._next_state
        self._rebuilt = planned and must_rebuild(self._kept, float(self._drift[0]),
                                                 self._rebuild_drift)
        if self._rebuilt:
            self._hessian_graph()
            # (H is symmetric: its C-ordered buffer is H either way)
            self._inverse[:] = inverse_factor(self._hessian).T[self._packed]
            self._kept_terms[:] = self._terms
            self._kept = True
        if self._rebuilt or (self._moving and planned):  # moving rows: every tick
            self._whiten_rows()
        self._whiten()

    def _solve(self) -> tuple[int, int, float]:
        """daqp on the rows prepare wrote (into ``_y``): exit flag, iterations, time [s]."""
        solver = self._solver
        if solver is None:
            sense = np.zeros(self._upper.size, dtype=np.intc)
            sense[self._lower == self._upper] = _EQUALITY
            solver = daqp.Model()
            flag, _ = solver.setup(np.eye(self._f.size), self._f, self._rows, self._upper,
                                   self._lower, sense)
            if flag < 0:
                self._y[:] = math.nan
                return int(flag), 0, 0.0
            settings = solver.settings
            settings.update(self._settings)
            solver.settings = settings
            self._solver = solver
        elif self._rebuilt or self._moving:
            solver.update(f=self._f, bupper=self._upper, blower=self._lower, A=self._rows)
        else:  # the kept Hessian: daqp keeps its rows
            solver.update(f=self._f, bupper=self._upper, blower=self._lower)
        step, _, flag, info = solver.solve()
        self._y[:] = step
        return int(flag), int(info["iterations"]), float(info["solve_time"]) + float(
            info["setup_time"])

    def step(self, pose: FloatArray, ref_poses: FloatArray,
             ref_velocities: FloatArray) -> FloatArray:
        self._pose[:] = pose
        self._poses[:] = ref_poses
        self._velocities[:] = ref_velocities
        cold = not self._warm and not self._again
        self._mode[0] = AGAIN if self._again else COLD if cold else WARM
        self._again = False
        self._before[:3], self._before[3:] = self._last, self._memory
        planned = (math.isfinite(float(self._poses.sum()))
                   and math.isfinite(float(self._velocities.sum())))
        self._prepare(planned)
        rebuilt = int(self._rebuilt)
        iterations, seconds = 0, 0.0
        if not planned:
            flag = int(UNPLANNED)
            self._y[:] = math.nan
        else:
            flag, iterations, seconds = self._solve()
            if not (flag > 0 and math.isfinite(float(self._y.sum()))) and cold \
                    and not self._budgeted:
                self._forget()  # solve again from the last command held
                self._mode[0] = HOLD
                self._prepare(planned)
                rebuilt += int(self._rebuilt)
                flag, more, extra = self._solve()
                iterations, seconds = iterations + more, seconds + extra
        self._flag[0] = flag
        self._unwhiten()
        self._finish()
        self._warm = self._status[0] == SOLVED
        if not self._warm:
            self._forget()
        self._last[:] = self._twist
        self._plan[:] = self._next_plan
        self._memory[:] = self._next_memory
        self._steer[:] = self._next_steer
        out = self._out
        out[STATUS], out[FLAG], out[CLAMPED] = self._status[0], flag, self._clamped[0]
        out[ITERATIONS], out[SOLVE_TIME] = iterations, seconds
        out[FAILURES], out[REBUILT] = self._memory[0], rebuilt
        speeds = TWIST + 3
        out[TWIST:speeds] = self._twist
        out[speeds:speeds + self._speeds.size] = self._speeds
        poses = speeds + self._speeds.size
        out[poses:poses + self._plan_poses.size] = self._plan_poses.ravel()
        tail = poses + self._plan_poses.size
        out[tail:tail + self._steer.size] = self._steer
        tail += self._steer.size
        out[tail:tail + self._progress.size] = self._progress
        out[tail + self._progress.size:] = self._feedforward
        return out
