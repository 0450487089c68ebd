"""The 2 pi branch of a path's tangent angle: unwrapped on a dense grid over one period
(periodic paths; it then grows by the path's winding) or over the time span (finite
paths), so that :class:`~trajectories.heading.TangentHeading` is continuous in time
across separate calls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._validation import FloatArray
from .errors import TrajectoryError
from .path import TimedPath

TWO_PI = 2.0 * math.pi

MIN_TANGENT_SPEED = 1e-9  # [m/s] below this on the grid the tangent is undefined
_MAX_GRID_STEP = math.pi / 8.0  # [rad] largest tangent turn between grid points
_INITIAL_GRID_STEPS = 1024
_MAX_GRID_STEPS = _INITIAL_GRID_STEPS * 8**3


@dataclass(frozen=True)
class TangentBranch:
    """Unwrapped tangent angles on a dense grid: picks the 2*pi branch at any time."""

    start: float  # [s] grid origin
    times: FloatArray  # [s] grid, relative to start, from 0 to one period or the span
    angles: FloatArray  # [rad] unwrapped tangent angle on the grid
    period: float | None  # [s]
    winding: float  # [rad] growth of the tangent angle over one period

    def reference(self, t: FloatArray) -> FloatArray:
        """A continuous approximation of the tangent angle, within pi/8 of the exact one."""
        tau = t - self.start if self.start != 0.0 else t
        if self.period is None:
            return np.interp(tau, self.times, self.angles)
        turns, phase = np.divmod(tau, self.period)
        return np.interp(phase, self.times, self.angles) + turns * self.winding


def tangent_branch(trajectory: TimedPath) -> TangentBranch:
    """The tangent angle of ``trajectory`` unwrapped on a grid fine enough that it turns
    by at most pi/8 between points; raises where the path stops or reverses."""
    period = trajectory.period
    start = trajectory.start_time
    end = trajectory.end_time
    if period is not None:
        span = period
    elif end is not None:
        span = end - start
    else:
        raise TrajectoryError(
            "tangent heading needs a periodic or finite trajectory, got one with "
            "period None and end_time None"
        )
    steps = _INITIAL_GRID_STEPS
    while True:
        times = np.linspace(0.0, span, steps + 1)
        angles = _grid_tangent_angles(trajectory, start + times, periodic=period is not None)
        turns = np.abs(np.diff(angles))
        if turns.max() <= _MAX_GRID_STEP:
            break
        if steps >= _MAX_GRID_STEPS:
            k = int(np.argmax(turns))
            raise TrajectoryError(
                "tangent heading needs a path whose direction turns smoothly, but it turns "
                f"by {turns[k]:.3g} rad between t={start + times[k]:.9g} s and "
                f"t={start + times[k + 1]:.9g} s even on a grid of {steps} steps "
                "(the path stops or reverses there)"
            )
        steps *= 8
    winding = 0.0
    if period is not None:
        winding = TWO_PI * round((angles[-1] - angles[0]) / TWO_PI)
    times.flags.writeable = False
    angles.flags.writeable = False
    return TangentBranch(start, times, angles, period, winding)


def _grid_tangent_angles(trajectory: TimedPath, grid: FloatArray, periodic: bool) -> FloatArray:
    """Unwrapped direction of motion on ``grid`` [rad]; raises where the path stops."""
    path = trajectory.path(grid)
    direction = np.array(path.velocity)
    speed = np.hypot(direction[:, 0], direction[:, 1])
    if not periodic:
        # A finite path may start or end at rest; near the start v ~ a*tau (or
        # j*tau^2/2), near the end v ~ -a*tau (or j*tau^2/2): take that limit.
        for index, sign in ((0, 1.0), (-1, -1.0)):
            if speed[index] >= MIN_TANGENT_SPEED:
                continue
            a = path.acceleration[index]
            j = path.jerk[index]
            if np.hypot(a[0], a[1]) >= MIN_TANGENT_SPEED:
                direction[index] = sign * a
            elif np.hypot(j[0], j[1]) >= MIN_TANGENT_SPEED:
                direction[index] = j
            speed[index] = np.hypot(direction[index, 0], direction[index, 1])
    slow = np.flatnonzero(speed < MIN_TANGENT_SPEED)
    if slow.size:
        k = int(slow[0])
        raise TrajectoryError(
            "tangent heading needs a moving path, but the path speed is "
            f"{speed[k]:.3g} m/s < {MIN_TANGENT_SPEED:g} m/s at t={grid[k]:.9g} s"
        )
    return np.unwrap(np.arctan2(direction[:, 1], direction[:, 0]))
