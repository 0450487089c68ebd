"""The retimed trajectory: a path driven with a timing s(t) given on a grid.

See :mod:`trajectories.retiming` for the math and :func:`~trajectories.time_optimal`,
which builds one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from ._validation import FloatArray, as_times, shown
from .base import Trajectory, TrajectorySample
from .errors import TrajectoryError
from .heading import HeadingDerivatives, HeadingProfile
from .path import PathDerivatives


class PhaseGrid(NamedTuple):
    """The timing on its grid: path parameter, its rates and the times reached.

    ``s`` (m,) [s of the source], ``sdot`` (m,) [-], ``sddot`` (m - 1,) per
    cell [1/s], ``t`` (m,) [s] the time each grid point is reached.
    """

    s: FloatArray
    sdot: FloatArray
    sddot: FloatArray
    t: FloatArray


@dataclass(frozen=True)
class RetimingInfo:
    """How :func:`time_optimal` found its timing.

    ``status`` and ``iterations`` are clarabel's; ``solve_time`` [s] its own
    timer, ``build_time`` [s] assembling the problem; ``solver_lap_time`` [s]
    the cone program's lap (its first solve); ``stretch`` = lap time / solver lap time
    (>= 1 when the check between grid points slowed the timing down); ``repairs``: how
    often the cone program was solved again with its speeds bounded in cells the check
    found over their limits (``iterations``, ``solve_time`` and ``build_time`` count
    every solve); ``speed_demand``, ``accel_demand`` and ``steer_demand`` (steered
    modules' turn rate, :mod:`trajectories.steering`; 0 without) the peaks (1 = at a
    limit) on the check grid after it.
    """

    status: str
    iterations: int
    solve_time: float
    build_time: float
    solver_lap_time: float
    stretch: float
    speed_demand: float
    accel_demand: float
    steer_demand: float = 0.0
    repairs: int = 0


class _PhaseTiming:
    """s(t), sdot(t) and sddot(t) from sdot on a grid, sddot constant in each cell."""

    def __init__(self, s: FloatArray, sdot: FloatArray, start_time: float, periodic: bool) -> None:
        steps = np.diff(s)
        self.s = s
        self.sdot = sdot
        self.sddot = (sdot[1:] - sdot[:-1]) * (sdot[1:] + sdot[:-1]) / (2.0 * steps)
        elapsed = np.concatenate([[0.0], np.cumsum(2.0 * steps / (sdot[:-1] + sdot[1:]))])
        self.elapsed = elapsed  # [s] from the start to each grid point
        self.start_time = start_time
        self.lap_time = float(elapsed[-1])
        self.periodic = periodic
        self.span = float(s[-1] - s[0])

    def evaluate(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(s, sdot, sddot) at times ``t`` [s] (finite timings: already within the span)."""
        offset = t - self.start_time
        turns = None
        if self.periodic:
            turns = np.floor(offset / self.lap_time)
            offset = offset - turns * self.lap_time
        cell = np.searchsorted(self.elapsed, offset, side="right") - 1
        cell = np.clip(cell, 0, self.sddot.size - 1)
        tau = offset - self.elapsed[cell]
        start_rate = self.sdot[cell]
        accel = self.sddot[cell]
        s = self.s[cell] + (start_rate + 0.5 * accel * tau) * tau
        if turns is not None:
            s = s + turns * self.span
        return s, start_rate + accel * tau, accel


@dataclass(frozen=True, repr=False)
class _RetimedHeading(HeadingProfile):
    """The source's heading theta(s) along the retimed s(t): thetadot = theta' sdot, ..."""

    timing: _PhaseTiming
    source: Trajectory

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """theta(s(t)), theta'(s) sdot and theta''(s) sdot^2 + theta'(s) sddot."""
        s, rate, accel = self.timing.evaluate(t)
        sample = self.source.sample(s)
        slope = sample.velocity[..., 2]
        return HeadingDerivatives(
            sample.pose[..., 2], slope * rate, sample.acceleration[..., 2] * rate**2 + slope * accel
        )

    def __repr__(self) -> str:
        return f"RetimedHeading({self.source.heading!r})"


class RetimedTrajectory(Trajectory):
    """The geometry of ``source`` driven with a new timing s(t), given as sdot on a grid of s.

    Between grid points sddot is constant, so s(t) and sdot(t) are exact
    quadratics and lines in t (see the module docstring); pose, velocity and
    acceleration come from the source's exact derivatives at s(t), heading
    included. Periodic (``period`` = lap time, one lap per source period) or
    finite (``end_time`` = start + lap time, the end pose held after it); it
    starts at the source's ``start_time``. Built by :func:`time_optimal`.

    Args:
        source: the trajectory whose pose over its own time is the path.
        s: grid of path parameters (m,) [s of the source], strictly increasing;
            periodic: exactly one source period long.
        sdot: ds/dt at the grid points (m,) [-], >= 0, never 0 at two neighbours;
            periodic: the same at both ends.
        periodic: steady laps (True) or one pass (False).
        info: how the timing was found, if it was (:class:`RetimingInfo`).
    """

    def __init__(self, source: Trajectory, s: npt.ArrayLike, sdot: npt.ArrayLike, *,
                 periodic: bool, info: RetimingInfo | None = None) -> None:
        if not isinstance(source, Trajectory):
            raise TrajectoryError(f"source must be a Trajectory, got {shown(source)}")
        if not isinstance(periodic, bool):
            raise TrajectoryError(f"periodic must be True or False, got {shown(periodic)}")
        grid, rates = _checked_grid(s, sdot)
        if periodic:
            _check_periodic_grid(source, grid, rates)
        grid.flags.writeable = False
        rates.flags.writeable = False
        self._source = source
        self._info = info
        self._timing = _PhaseTiming(grid, rates, source.start_time, periodic)
        self._timing.sddot.flags.writeable = False
        self._timing.elapsed.flags.writeable = False
        super().__init__(_RetimedHeading(self._timing, source))

    @property
    def source(self) -> Trajectory:
        """The trajectory whose geometry is driven."""
        return self._source

    @property
    def info(self) -> RetimingInfo | None:
        """How :func:`time_optimal` found the timing (None if built directly)."""
        return self._info

    @property
    def grid(self) -> PhaseGrid:
        """The timing on its grid: s, sdot, sddot per cell, and times t [s] (read-only)."""
        timing = self._timing
        times = timing.start_time + timing.elapsed
        times.flags.writeable = False
        return PhaseGrid(timing.s, timing.sdot, timing.sddot, times)

    @property
    def lap_time(self) -> float:
        """Time for one lap (periodic) or the whole path (finite) [s]."""
        return self._timing.lap_time

    @property
    def period(self) -> float | None:
        """The lap time [s] for steady laps, else None."""
        return self._timing.lap_time if self._timing.periodic else None

    @property
    def start_time(self) -> float:
        """The source's start time [s]: the first grid point is reached then."""
        return self._timing.start_time

    @property
    def end_time(self) -> float | None:
        """start_time + lap time [s] for one pass, None for steady laps."""
        if self._timing.periodic:
            return None
        return self._timing.start_time + self._timing.lap_time

    def path_parameter(self, t: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(s, sdot, sddot) at times t [s]: [s of the source], [-], [1/s], each of t's shape."""
        return self._timing.evaluate(self._clamped(as_times(t)))

    def sample(self, t: npt.ArrayLike) -> TrajectorySample:
        """Pose, velocity dq/ds sdot and acceleration d2q/ds2 sdot^2 + dq/ds sddot at t [s].

        One pass over the source (the base class would sample it twice); after
        the end of a finite timing the end pose is held at rest.
        """
        times = as_times(t)
        inside = self._clamped(times)
        s, rate, accel = self._timing.evaluate(inside)
        source = self._source.sample(s)
        velocity = source.velocity * rate[..., np.newaxis]
        acceleration = source.acceleration * (rate * rate)[..., np.newaxis]
        acceleration += source.velocity * accel[..., np.newaxis]
        if inside is not times:
            still = (inside != times)[..., np.newaxis]
            velocity = np.where(still, 0.0, velocity)
            acceleration = np.where(still, 0.0, acceleration)
        return TrajectorySample(source.pose, velocity, acceleration)

    def _clamped(self, times: FloatArray) -> FloatArray:
        end = self.end_time
        if end is None:
            return times
        clamped = np.clip(times, self.start_time, end)
        return times if np.array_equal(clamped, times) else clamped

    def _path(self, t: FloatArray) -> PathDerivatives:
        s, rate, accel = self._timing.evaluate(t)
        path = self._source.path(s)
        rate_ = rate[..., np.newaxis]
        accel_ = accel[..., np.newaxis]
        return PathDerivatives(
            path.position,
            path.velocity * rate_,
            path.acceleration * rate_**2 + path.velocity * accel_,
            path.jerk * rate_**3 + 3.0 * path.acceleration * rate_ * accel_,
        )

    def __repr__(self) -> str:
        kind = "steady laps" if self._timing.periodic else "one pass"
        return (f"RetimedTrajectory(<lap {self.lap_time:.6g} s, {kind}, "
                f"{self._timing.s.size - 1} cells>, source={self._source!r})")


def _checked_grid(s: npt.ArrayLike, sdot: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    try:
        grid = np.array(s, dtype=np.float64)
        rates = np.array(sdot, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TrajectoryError(
            f"s and sdot must be 1-D arrays of finite numbers, got {shown(s)} and {shown(sdot)}"
        ) from error
    if grid.ndim != 1 or grid.size < 2 or rates.shape != grid.shape:
        raise TrajectoryError(
            f"s and sdot must be 1-D arrays of the same length >= 2, got shapes {grid.shape} "
            f"and {rates.shape}"
        )
    if not (np.isfinite(grid).all() and np.isfinite(rates).all()):
        raise TrajectoryError("s and sdot must be finite")
    if not (np.diff(grid) > 0.0).all():
        raise TrajectoryError("s must be strictly increasing")
    if (rates < 0.0).any():
        raise TrajectoryError(f"sdot must be >= 0, got min {float(rates.min())!r}")
    stopped = np.flatnonzero((rates[:-1] == 0.0) & (rates[1:] == 0.0))
    if stopped.size:
        k = int(stopped[0])
        raise TrajectoryError(
            f"sdot must not be 0 at two neighbouring grid points (the timing would never "
            f"move on), got sdot = 0 at s={grid[k]!r} and s={grid[k + 1]!r}"
        )
    return grid, rates


def _check_periodic_grid(source: Trajectory, grid: FloatArray, rates: FloatArray) -> None:
    period = source.period
    if period is None:
        raise TrajectoryError("periodic=True needs a periodic source (period not None), got "
                              f"{source!r}")
    span = float(grid[-1] - grid[0])
    if not math.isclose(span, period, rel_tol=1e-9):
        raise TrajectoryError(f"a periodic timing must cover one source period {shown(period)} s, "
                              f"got s from {grid[0]!r} to {grid[-1]!r}")
    if not math.isclose(rates[0], rates[-1], rel_tol=1e-9, abs_tol=1e-12):
        raise TrajectoryError(f"a periodic timing needs the same sdot at both ends, got "
                              f"{rates[0]!r} and {rates[-1]!r}")
