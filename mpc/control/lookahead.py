"""The reference sampled ahead on the control tick's grid, for time mode's windows.

Time mode samples the reference at ``t + offsets`` every tick. When ``t``
advances by whole ticks (a simulation, a fixed-rate loop that counts its
ticks) and the stage starts are whole ticks too, one tick's window is the
last one moved by one grid point: :class:`Lookahead` samples two windows'
worth of grid points at once (the second sharing the first's last point) and
hands out views of them, so that most ticks sample nothing (a sample of the
N = 20 window costs ~20-35 us, about a fifth of a tick; two windows' worth
costs little more than one). A clock off the grid (a measured time with
jitter) gets exactly the window it asks for, as before, at the same cost.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray, IntArray
from trajectories import Trajectory, TrajectoryError

#: How far a time may be from the grid and still read it [s] (rounding of ``k * dt``;
#: the reference moves by its speed times this at most: nanometres).
ON_GRID = 1e-9


class Lookahead:
    """Windows of ``trajectory`` at ``time + offsets`` [s], read from a grid of step ``tick``.

    Args:
        trajectory: the reference.
        offsets: each stage's start from the window's start (N+1,) [s].
        tick: the control tick [s], the grid's step.
    """

    def __init__(self, trajectory: Trajectory, offsets: FloatArray, tick: float) -> None:
        self.trajectory = trajectory
        self.tick = float(tick)
        self._offsets = np.asarray(offsets, dtype=float)
        steps = self._offsets / self.tick
        index = np.rint(steps)
        #: Whether the stage starts lie on the grid (else every window is sampled as asked).
        self.gridded = bool(np.abs(steps - index).max() * self.tick <= ON_GRID)
        self._index: IntArray = index.astype(np.intp)
        self._span = int(self._index[-1]) + 1  # grid points one window covers
        #: Whether the stages are consecutive grid points (then the grid's consecutive
        #: pairs are the stages' too: their terms can be evaluated on the grid at once).
        self.contiguous = bool((self._index == np.arange(self._index.size)).all())
        self._start = math.nan  # time of the grid's first point [s]
        self._points = 0  # grid points sampled
        #: The grid's reference pose and velocity (points, 3), replaced at each fill.
        self.pose = self.velocity = np.zeros((0, 3))
        #: Where the last window starts on the grid (None: it was sampled on its own).
        self.first: int | None = None
        self.fills = 0  # grid fills so far (each replaces ``pose`` and ``velocity``)
        self.samples = 0  # trajectory samples taken (for tests and benchmarks)

    def window(self, time: float) -> tuple[FloatArray, FloatArray]:
        """The reference pose and velocity (N+1, 3) at ``time + offsets``: views of the
        grid (valid until the next call) or a sample of just this window."""
        if self.gridded:
            shift = (time - self._start) / self.tick
            first = round(shift) if math.isfinite(shift) else -1
            on_grid = first >= 0 and abs(time - (self._start + first * self.tick)) <= ON_GRID
            if on_grid and first + self._span <= self._points:
                return self._view(first)
            # Past the grid's end on a regular clock: sample two windows' worth (the next
            # window's points included); off the grid (or the first time), this window.
            self._start, self._points = time, 0
            if on_grid and self._fill(time):
                return self._view(0)
        self.first = None
        self.samples += 1
        sample = self.trajectory.sample(time + self._offsets)
        return sample.pose, sample.velocity

    def _view(self, first: int) -> tuple[FloatArray, FloatArray]:
        self.first = first
        if self.contiguous:
            stop = first + self._span
            return self.pose[first:stop], self.velocity[first:stop]
        rows = first + self._index
        return self.pose[rows], self.velocity[rows]

    def _fill(self, start: float) -> bool:
        """Sample the grid from ``start``; False (nothing kept) if the reference fails
        somewhere on it (its numbers overflow further on: the window alone is sampled
        then, which raises only if the window itself fails)."""
        points = 2 * self._span - 1
        self.samples += 1
        try:
            sample = self.trajectory.sample(start + self.tick * np.arange(float(points)))
        except TrajectoryError:
            return False
        self._points = points
        self.pose, self.velocity = sample.pose, sample.velocity
        self.fills += 1
        return True
