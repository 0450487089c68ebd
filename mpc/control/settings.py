"""The :class:`~mpc.control.Controller`'s settings, checked once at construction.

The mode, the stage length, the progress rate, the trajectory's type, and the
solver a ``solver=`` name chooses (with its iteration, time and polygon options).
"""

from __future__ import annotations

import warnings

import numpy as np

from mpc.errors import ControllerError
from mpc.model.tracking import TrackingModel
from mpc.robots.base import Robot
from mpc.solvers import DenseSolver, NlpSolver, QpSolver, TrackingSolver
from mpc.validation import (
    MAX_DENSE_ENTRIES,
    MAX_DENSE_HORIZON,
    MAX_ITERATIONS,
    MAX_PLAN_ROWS,
    MAX_POLYGON_SIDES,
    MAX_STEP,
    flag,
    integer_in,
    is_integer,
    non_negative,
    positive,
    shown,
)
from trajectories import Trajectory

#: Valid ``solver=`` names: the fast paths (daqp on the condensed QP, OSQP on the sparse
#: QP) and the exact IPOPT path.
SOLVERS: tuple[str, ...] = ("daqp", "osqp", "ipopt")

#: Valid ``mode=`` names: track the reference in time, or follow its path.
MODES: tuple[str, ...] = ("time", "path")



def check_mode(mode: object, time_scaling: object) -> str:
    if time_scaling is not None:
        scaling = flag("time_scaling", time_scaling, ControllerError)
        warnings.warn("time_scaling is deprecated: use mode='path' (path following, which "
                      "replaces time scaling) or mode='time'", DeprecationWarning, stacklevel=3)
        if scaling and mode == "time":
            mode = "path"
    if mode not in MODES:
        raise ControllerError(f"unknown mode {shown(mode)}; expected one of {list(MODES)}")
    return str(mode)


def check_step(name: str, value: object) -> float:
    """A tick or stage length [s] (``dt``, ``stage_dt``): > 0 and at most :data:`MAX_STEP`."""
    step = positive(f"{name} [s]", value, ControllerError)
    if step > MAX_STEP:
        raise ControllerError(f"{name} must be at most {MAX_STEP:g} s (a bound of this "
                              f"library), got {shown(value)}")
    return step


def check_stage_dt(stage_dt: object, dt: float, mode: str) -> float:
    """``stage_dt`` [s] (if None: ``2 dt`` in time mode, at most :data:`MAX_STEP` unless
    ``dt`` is longer; ``dt`` in path mode), >= ``dt``."""
    if stage_dt is None:
        return max(dt, min(2.0 * dt, MAX_STEP)) if mode == "time" else dt
    stage = check_step("stage_dt", stage_dt)
    if stage < dt:
        raise ControllerError(f"stage_dt must be >= dt = {shown(dt)} s (a stage is at least one "
                              f"tick), got {shown(stage_dt)}")
    return stage


def check_progress_rate(max_progress_rate: object) -> float:
    """``max_progress_rate``, >= 1 (the reference's own pace)."""
    rate = positive("max_progress_rate", max_progress_rate, ControllerError)
    if rate < 1.0:
        raise ControllerError(f"max_progress_rate must be >= 1 (the reference's own pace), "
                              f"got {shown(max_progress_rate)}")
    return rate


def check_trajectory(trajectory: object) -> None:
    if not isinstance(trajectory, Trajectory):
        raise ControllerError(
            f"trajectory must be a trajectories.Trajectory, got {type(trajectory).__name__}")


def check_plan_size(robot: Robot, horizon: int, solver: str, polygon_sides: int | None) -> None:
    """The QP paths' plan within :data:`MAX_PLAN_ROWS` limit rows; ``daqp``'s within
    :data:`MAX_DENSE_HORIZON` stages and :data:`MAX_DENSE_ENTRIES` dense entries (its work
    grows as the horizon cubed): each a ControllerError naming the bound and the way out."""
    per_stage = robot.stage_limits(np.ones(1), polygon_sides).now.shape[1]
    sides = "default" if polygon_sides is None else polygon_sides
    rows = horizon * per_stage
    if rows > MAX_PLAN_ROWS:
        raise ControllerError(
            f"horizon {horizon} x {per_stage} limit rows a stage (polygon_sides "
            f"{sides}) is {rows} rows; a QP plan has at most {MAX_PLAN_ROWS} (a bound "
            "of this library): shorten the horizon or use fewer polygon_sides")
    if solver != "daqp":
        return
    if horizon > MAX_DENSE_HORIZON:
        raise ControllerError(
            f"horizon must be at most {MAX_DENSE_HORIZON} with solver='daqp' (its dense QP "
            f"grows as the horizon cubed; a bound of this library), got {horizon}: use "
            "solver='osqp' or 'ipopt' for longer horizons")
    if rows * 3 * horizon > MAX_DENSE_ENTRIES:
        raise ControllerError(
            f"horizon {horizon} x {per_stage} limit rows a stage (polygon_sides "
            f"{sides}) makes a dense QP of {rows * 3 * horizon} entries; "
            f"solver='daqp' takes at most {MAX_DENSE_ENTRIES} (a bound of this library): "
            "shorten the horizon, use fewer polygon_sides or solver='osqp'")


def check_jit(jit: object, solver: object) -> bool:
    """Whether to compile the tick's terms for ``jit`` (True, False or ``"auto"``: where a
    compiler works, which the caller finds out) with ``solver`` (one of :data:`SOLVERS`):
    only daqp's are compiled."""
    if solver not in SOLVERS:
        raise ControllerError(f"unknown solver {solver!r}; expected one of {list(SOLVERS)}")
    if not (isinstance(jit, bool) or (isinstance(jit, str) and jit == "auto")):
        raise ControllerError(f"jit must be True, False or 'auto', got {shown(jit)}")
    if jit is True and solver != "daqp":
        raise ControllerError(f"jit=True compiles the daqp fast path's terms; solver "
                              f"{shown(solver)} does not use them")
    return bool(jit) and solver == "daqp"


def make_solver(model: TrackingModel, name: object, polygon_sides: int | None,
                max_iter: int | None, time_limit: float, jit: bool = False) -> TrackingSolver:
    """The solver ``name`` (one of :data:`SOLVERS`) for ``model``, with its options checked
    (``jit``: daqp's terms compiled to C, checked by :func:`check_jit`;
    :class:`~mpc.model.jit.JitError` if they cannot be)."""
    check_jit(jit, name)
    iterations = None if max_iter is None else integer_in("max_iter", max_iter, 1,
                                                          MAX_ITERATIONS, ControllerError)
    limit = non_negative("time_limit [s]", time_limit, ControllerError)
    if name == "ipopt":
        if polygon_sides is not None:
            raise ControllerError("polygon_sides applies to the QP paths only; IPOPT uses "
                                  "each swerve module's exact speed disk")
        return NlpSolver(model, max_iter=iterations or 100, time_limit=limit)
    sides = None
    if polygon_sides is not None:
        if not is_integer(polygon_sides) or polygon_sides < 4 or polygon_sides % 2:
            raise ControllerError(
                f"polygon_sides must be an even integer >= 4, got {shown(polygon_sides)}")
        sides = integer_in("polygon_sides", polygon_sides, 4, MAX_POLYGON_SIDES,
                           ControllerError)
    check_plan_size(model.robot, model.horizon, str(name), sides)
    if name == "daqp":
        return DenseSolver(model, polygon_sides=sides, max_iter=iterations or 1000,
                           time_limit=limit, jit=jit)
    return QpSolver(model, polygon_sides=sides, max_iter=iterations or 500, time_limit=limit)
