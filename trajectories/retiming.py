"""Time-optimal retiming: drive a path as fast as the wheels physically allow.

The geometry of a :class:`~trajectories.Trajectory` is its pose q(s) = (x, y, theta)
as a function of its own time s [s], over one period (periodic) or its span
(finite); the path parameter s keeps that unit. Driving it with sdot = ds/dt
gives the body twist and its rate

    u = g(s) sdot,   du/dt = h(s) sdot^2 + g(s) sddot,
    g = R(theta)^T dq/ds,   h = dg/ds,

and the limits of wheel i (its velocity map W_i, shape (d, 3): d = 1 a signed
Swedish wheel speed, d = 2 a swerve module's velocity, whose norm is the speed)

    ||W_i u|| <= max_wheel_speed_i [rad/s],   ||W_i du/dt|| <= max_wheel_accel_i [rad/s^2],

plus optional caps |dxy/dt| <= max_speed [m/s] and |thetadot| <= max_heading_rate
[rad/s]. With b = sdot^2 and a = sddot (db/ds = 2 a) every speed limit is an
upper bound on b and every acceleration limit is a linear pair of rows
(Swedish) or a second-order cone (swerve) in (b, a). On a uniform grid
s_0 < ... < s_N with a_k constant in cell k (so b is linear in s there),

    minimise  sum_k 2 ds / (c_k + c_{k+1})  over b, a, c with  c_k^2 <= b_k,
              b_{k+1} - b_k = 2 ds a_k,  b_k <= speed bound(s_k),
              acceleration limits at s_k and s_{k+1} with a_k,
              b_N = b_0 (steady laps) or b_0 = b_N = 0 (rest to rest),

a convex second-order cone program (Verscheure et al., IEEE TAC 2009) whose
objective is exactly the lap time of the piecewise-constant-sddot timing;
:mod:`trajectories.retiming_problem` solves it with clarabel. Between grid
points the limits are then measured on a grid ``REFINEMENT`` times finer (at
least ``MIN_CHECK_POINTS`` points a lap; a sampled path without accelerations also at
each knot, from both sides). A cell asked for more than ``REPAIR_ABOVE`` times a limit
there (a knot where the path's curvature jumps, inside a cell) gets its ends' b bounded
to what brings it within, and the program is solved again (at most ``MAX_REPAIRS``
times); then b and a are scaled by one factor lambda (time stretched by
1 / sqrt(lambda)) so that every limit holds, less a relative margin ``MARGIN``.

In cell k, from its start time t_k: sddot = a_k, sdot = sqrt(b_k) + a_k tau and
s = s_k + sqrt(b_k) tau + a_k tau^2 / 2 (tau = t - t_k), and the cell lasts
2 ds / (sqrt(b_k) + sqrt(b_{k+1})) [s]. The retimed trajectory's velocity is
dq/ds sdot and its acceleration d2q/ds2 sdot^2 + dq/ds sddot, from the source
sampled at s: exact between grid points, heading included
(:class:`~trajectories.retiming_trajectory.RetimedTrajectory`).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from ._validation import FloatArray, positive_number, samples_in, shown
from .base import Trajectory
from .errors import TrajectoryError
from .retiming_problem import (
    Limits,
    PathGeometry,
    cell_demands,
    lap_time,
    path_geometry,
    solve_lap,
    speed_bound,
)
from .retiming_trajectory import PhaseGrid, RetimedTrajectory, RetimingInfo
from .sampled import SampledTrajectory

__all__ = [
    "DEFAULT_SAMPLES",
    "MARGIN",
    "MIN_CHECK_POINTS",
    "MIN_SAMPLES",
    "REFINEMENT",
    "PhaseGrid",
    "RetimedTrajectory",
    "RetimingInfo",
    "RetimingRobot",
    "time_optimal",
]

#: Fewest grid cells accepted by :func:`time_optimal`.
MIN_SAMPLES = 16
#: Grid cells along the path unless asked otherwise.
DEFAULT_SAMPLES = 1000
#: Most grid cells :func:`time_optimal` takes: a solve of about 5 s (16 points a cell are
#: checked, so a billion would allocate over 100 GiB).
MAX_SAMPLES = 20_000
#: The limits are checked on a grid this many times finer than the solve grid.
REFINEMENT = 16
#: ... and has at least this many points per lap.
MIN_CHECK_POINTS = 16384
#: Relative margin left below every limit on the check grid (rounding, and the
#: second-order excess between its points).
MARGIN = 1e-7
#: A cell whose demand between grid points exceeds this (a knot of a piecewise path, where
#: its curvature jumps, inside a cell) has its ends' speeds bounded to bring it within
#: the limits and the cone program solved again (``max_repairs`` times at most, default
#: ``MAX_REPAIRS``, each as long as the first solve); what is left over is taken off the
#: whole lap by one factor.
REPAIR_ABOVE = 1.01
MAX_REPAIRS = 4
#: Most repairs :func:`time_optimal` takes (a bound of this library).
REPAIR_BOUND = 20
#: A sampled path's knots are also checked this far (relative to its span; at least four
#: units in the last place of the knot's time) to each side.
KNOT_SIDE = 1e-9
_STILL_TWIST = 1e-12  # [m per s of the source] below this the path does not move


class RetimingRobot(Protocol):
    """What :func:`time_optimal` needs from a robot (an :class:`mpc.robots.Robot` has it)."""

    @property
    def wheel_blocks(self) -> npt.ArrayLike:
        """Wheel velocity maps W_i, shape (n, d, 3) [rad/s per twist unit]."""
        ...

    @property
    def max_wheel_speed(self) -> npt.ArrayLike:
        """Speed limits, shape (n,) [rad/s], >= 0 (0: a failed wheel held at rest)."""
        ...

    @property
    def max_wheel_accel(self) -> npt.ArrayLike | None:
        """Acceleration limits, shape (n,) [rad/s^2], > 0, or None (unlimited)."""
        ...

    # Optional: ``max_steer_rates`` (n,) [rad/s] or None, the steering limits of modules
    # with a velocity vector (d = 2: swerve, casters); see :mod:`trajectories.steering`.


def time_optimal(
    path: Trajectory,
    robot: RetimingRobot,
    *,
    periodic: bool | None = None,
    max_speed: float | None = None,
    max_heading_rate: float | None = None,
    samples: int = DEFAULT_SAMPLES,
    start_speed: float = 0.0,
    max_repairs: int = MAX_REPAIRS,
) -> RetimedTrajectory:
    """The fastest timing of the geometry of ``path`` within the robot's exact wheel limits
    and, for steered modules (swerve, casters), their steering rate
    (:mod:`trajectories.steering`: a module turns with its velocity's direction; one slower
    than 2 % of its speed limit may lag it).

    Args:
        path: a periodic or finite trajectory; its pose over its own time
            (one period, or its span) is the path, heading included.
        robot: ``wheel_blocks`` (n, d, 3), ``max_wheel_speed`` (n,) [rad/s] and
            ``max_wheel_accel`` (n,) [rad/s^2] or None, e.g. an :class:`mpc.robots.Robot`;
            with ``max_steer_rates`` (n,) [rad/s] (not None) and d = 2, the steering
            limits too.
        periodic: steady laps (sdot the same at the start and end of a lap;
            the default for a periodic path) or rest to rest (False; the
            default for a finite path).
        max_speed: optional cap on the path speed |dxy/dt| [m/s].
        max_heading_rate: optional cap on |dtheta/dt| [rad/s].
        samples: grid cells along the path (>= ``MIN_SAMPLES``); the lap time
            converges as the grid is refined (the cost grows about linearly).
        start_speed: one pass only: the path speed [m/s] the robot has at the start (a
            new plan for a robot under way); the timing starts at most that fast (slower
            where the limits or a path too short to stop in ask it). 0: from rest.
        max_repairs: how often at most the cone program is solved again with the speeds
            of cells found over a limit between grid points bounded (0 to 20; 0: the whole
            lap is slowed for them instead). Each costs as long as the first solve; a
            path snapped to a 5 cm grid took 1.3-1.5x its first solution's lap with one,
            2.0-2.6x with none (``python -m benchmarks.retiming_cases``).

    Returns:
        A :class:`RetimedTrajectory` within every limit between grid points
        too (see the module docstring), with its :class:`RetimingInfo`.

    Raises:
        TrajectoryError: bad arguments, a path that neither moves nor turns, a
            path the limits cannot drive at all, or a failed solve (naming
            clarabel's status).
    """
    source, steady, start, span = _checked_path(path, periodic)
    limits = _checked_limits(robot, max_speed, max_heading_rate)
    cells = _checked_samples(samples)
    most_repairs = _checked_repairs(max_repairs)
    refine = max(REFINEMENT, -(-MIN_CHECK_POINTS // cells))
    try:
        fine = path_geometry(source, start + span * np.linspace(0.0, 1.0, cells * refine + 1))
    except TrajectoryError as error:  # e.g. a path beyond the coordinate bound
        raise TrajectoryError(f"path cannot be retimed: {error}") from None
    if float(np.abs(fine.twist).max()) < _STILL_TWIST:
        raise TrajectoryError(
            f"path must move or turn, but its pose is constant for s in [{shown(start)}, "
            f"{start + span!r}] s: a path of zero length has no time-optimal timing"
        )
    coarse = PathGeometry(*(array[::refine] for array in fine))
    knots = _knot_points(source, start, span)
    bound = speed_bound(limits, coarse)
    start_b = _start_b(start_speed, steady, coarse)
    solution = solve_lap(coarse, limits, bound, steady, start_b)
    b = _exact_ends(solution.b, steady, start_b)
    solver_lap = lap_time(coarse.s, b)
    iterations, solve_time, build_time = (solution.iterations, solution.solve_time,
                                          solution.build_time)
    repairs = 0
    while True:
        speed, accel, steer = cell_demands(fine, limits, b, knots)
        # all scale with b: speed and steering with sqrt(b), acceleration with b
        cells_demand = np.maximum(np.maximum(speed * speed, accel), steer * steer)
        over = np.flatnonzero(cells_demand > REPAIR_ABOVE)
        if over.size == 0 or repairs == most_repairs or not np.isfinite(cells_demand).all():
            break
        # the cells over their limits between grid points (a curvature that jumps inside a
        # cell): their ends' b bounded by what would bring them to the limit, solved again
        bound = bound.copy()
        np.minimum.at(bound, over, b[over] / cells_demand[over])
        np.minimum.at(bound, over + 1, b[over + 1] / cells_demand[over])
        solution = solve_lap(coarse, limits, bound, steady, start_b)
        b = _exact_ends(solution.b, steady, start_b)
        iterations += solution.iterations
        solve_time += solution.solve_time
        build_time += solution.build_time
        repairs += 1
    peak_speed, peak_accel, peak_steer = (float(speed.max()), float(accel.max()),
                                          float(steer.max()))
    demand = max(peak_speed * peak_speed, peak_accel, peak_steer * peak_steer)
    if not (demand > 0.0 and math.isfinite(demand)):
        raise TrajectoryError(f"the retiming cone program returned an unusable timing (peak "
                              f"speed demand {shown(peak_speed)}, acceleration demand "
                              f"{shown(peak_accel)}, steering demand {shown(peak_steer)})")
    factor = (1.0 - MARGIN) / demand
    b *= factor
    info = RetimingInfo(
        status=solution.status,
        iterations=iterations,
        solve_time=solve_time,
        build_time=build_time,
        solver_lap_time=solver_lap,
        stretch=lap_time(coarse.s, b) / solver_lap,
        speed_demand=peak_speed * math.sqrt(factor),
        accel_demand=peak_accel * factor,
        steer_demand=peak_steer * math.sqrt(factor),
        repairs=repairs,
    )
    return RetimedTrajectory(source, coarse.s, np.sqrt(b), periodic=steady, info=info)


def _knot_points(source: Trajectory, start: float, span: float) -> PathGeometry | None:
    """The geometry just before and just after each knot inside the path of a sampled
    trajectory without accelerations (cubic Hermite pieces: C1, its acceleration jumps at
    the samples, which the uniform check grid would straddle), or None."""
    if not isinstance(source, SampledTrajectory) or source.accelerations is not None:
        return None
    knots = source.times[(source.times > start) & (source.times < start + span)]
    if knots.size == 0:
        return None
    side = np.maximum(KNOT_SIDE * span, 4.0 * np.spacing(np.abs(knots)))  # epoch-like times
    both = np.concatenate([knots - side, knots + side])
    return path_geometry(source, np.sort(np.clip(both, start, start + span)))


def _exact_ends(b: FloatArray, steady: bool, start_b: float) -> FloatArray:
    """``b`` with its ends exact (the solver meets its equality rows to its tolerance):
    steady laps the same at both ends, one pass at most ``start_b`` and at rest at its end."""
    if steady:
        b[0] = b[-1] = min(b[0], b[-1])
    else:
        b[0], b[-1] = min(b[0], start_b), 0.0
    return b


def _checked_path(path: Any, periodic: Any) -> tuple[Trajectory, bool, float, float]:
    """(path, steady laps?, start s, span of s) or TrajectoryError."""
    if not isinstance(path, Trajectory):
        raise TrajectoryError(
            "path must be a trajectories.Trajectory (its pose over its own time is the path), "
            f"got {shown(path)} of type {type(path).__name__}"
        )
    if periodic is not None and not isinstance(periodic, bool):
        raise TrajectoryError(f"periodic must be None, True or False, got {shown(periodic)}")
    if path.period is None and path.end_time is None:
        raise TrajectoryError("path must be periodic or finite (a period or an end_time), "
                              f"got {path!r} with neither")
    steady = path.period is not None if periodic is None else periodic
    if steady and path.period is None:
        raise TrajectoryError(
            f"periodic=True needs a periodic path (period not None), got {path!r}; use "
            "periodic=False to drive a finite path from rest to rest"
        )
    span = path.period if path.period is not None else path.duration
    if span is None or not span > 0.0:
        raise TrajectoryError(f"path must last a positive time, got {shown(span)} s for {path!r}")
    return path, steady, path.start_time, float(span)


def _start_b(start_speed: Any, steady: bool, coarse: PathGeometry) -> float:
    """b_0 = sdot^2 at which the path's first point is passed at ``start_speed`` [m/s] (0:
    from rest; also where the path starts by turning in place, without a speed)."""
    if isinstance(start_speed, bool) or not (
            isinstance(start_speed, (int, float, np.floating, np.integer))
            and math.isfinite(start_speed) and start_speed >= 0.0):
        raise TrajectoryError(f"start_speed must be a finite number >= 0 [m/s], got "
                              f"{shown(start_speed)}")
    if start_speed == 0.0:
        return 0.0
    if steady:
        raise TrajectoryError("start_speed applies to one pass (periodic=False): steady laps "
                              "start at their own lap speed")
    planar = math.hypot(float(coarse.twist[0, 0]), float(coarse.twist[0, 1]))
    return (float(start_speed) / planar) ** 2 if planar > _STILL_TWIST else 0.0


def _checked_samples(samples: Any) -> int:
    return samples_in(samples, MIN_SAMPLES, MAX_SAMPLES, "grid cells along the path")


def _checked_repairs(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not (
            0 <= value <= REPAIR_BOUND):
        raise TrajectoryError(f"max_repairs must be an integer from 0 to {REPAIR_BOUND} (a "
                              f"bound of this library), got {shown(value)}")
    return int(value)


#: Smallest path speed [m/s] or heading rate [rad/s] cap of :func:`time_optimal`.
MIN_CAP = 1e-6


def _checked_limits(robot: Any, max_speed: Any, max_heading_rate: Any) -> Limits:
    """The robot's wheel maps and limits, and the caps, checked."""
    expected = ("robot must have wheel_blocks (n, d, 3), max_wheel_speed (n,) [rad/s] and "
                "max_wheel_accel (n,) [rad/s^2] or None, like an mpc.robots.Robot")
    try:
        blocks = np.array(robot.wheel_blocks, dtype=np.float64)
        speed = np.array(robot.max_wheel_speed, dtype=np.float64)
        raw_accel = robot.max_wheel_accel
        accel = None if raw_accel is None else np.array(raw_accel, dtype=np.float64)
    except (AttributeError, TypeError, ValueError) as error:
        raise TrajectoryError(f"{expected}; got {shown(robot)}: {error}") from None
    if blocks.ndim != 3 or blocks.shape[0] < 1 or blocks.shape[1] < 1 or blocks.shape[2] != 3:
        raise TrajectoryError(f"{expected}; got wheel_blocks of shape {blocks.shape}")
    n = blocks.shape[0]
    if speed.ndim == 0:
        speed = np.full(n, float(speed))
    if not np.isfinite(blocks).all():
        raise TrajectoryError(f"{expected}; got wheel_blocks that are not all finite")
    if speed.shape != (n,) or not (np.isfinite(speed) & (speed >= 0.0)).all():
        raise TrajectoryError(f"{expected}; got max_wheel_speed {shown(speed)} for {n} wheels "
                              "(each finite and >= 0)")
    if accel is not None and (
        accel.shape != (n,) or not (np.isfinite(accel) & (accel > 0.0)).all()
    ):
        raise TrajectoryError(f"{expected}; got max_wheel_accel {shown(accel)} for {n} wheels "
                              "(each finite and > 0)")
    steer = _checked_steer_rates(robot, blocks)
    caps = []
    for name, value in (("max_speed [m/s]", max_speed),
                        ("max_heading_rate [rad/s]", max_heading_rate)):
        cap = None if value is None else positive_number(name, value)
        if cap is not None and cap < MIN_CAP:
            raise TrajectoryError(f"{name} must be at least {MIN_CAP:g} (a bound of this "
                                  f"library: slower, the lap time overflows), got {cap!r}")
        caps.append(cap)
    return Limits(blocks, speed, accel, caps[0], caps[1], steer)


def _checked_steer_rates(robot: Any, blocks: FloatArray) -> FloatArray | None:
    """The steering limits [rad/s] (n,) of a robot with steered modules (``max_steer_rates``
    not None, modules with a velocity vector: ``d = 2``), else None."""
    raw = getattr(robot, "max_steer_rates", None)
    if raw is None or blocks.shape[1] != 2:
        return None
    try:
        rates = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TrajectoryError(f"robot.max_steer_rates must be {blocks.shape[0]} numbers "
                              f"[rad/s] or None, got {shown(raw)}: {error}") from None
    if rates.ndim == 0:
        rates = np.full(blocks.shape[0], float(rates))
    if rates.shape != (blocks.shape[0],) or not (np.isfinite(rates) & (rates > 0.0)).all():
        raise TrajectoryError(f"robot.max_steer_rates must be {blocks.shape[0]} finite "
                              f"numbers > 0 [rad/s] or None, got {shown(raw)}")
    return rates
