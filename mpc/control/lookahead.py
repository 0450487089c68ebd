"""The reference sampled ahead on the control tick's grid, for time mode's windows.

Time mode samples the reference at ``t + offsets`` every tick. When ``t``
advances by whole ticks (a simulation, a fixed-rate loop that counts its
ticks) and the stage starts are whole ticks too, one tick's window is the
last one moved by one grid point: :class:`Lookahead` samples two windows'
worth of grid points at once (the second sharing the first's last point), and
a tick reads its rows from them (:class:`Strided`), so that most ticks sample
nothing (a sample of the window costs about a fifth of a tick; two windows'
worth costs little more than one: docs/design/lookahead-grid.md). A clock off the grid (a
measured time with jitter) gets exactly the window it asks for, as before, at
the same cost.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray, IntArray
from trajectories import Trajectory

#: How far a time may be from the grid and still read it [s] (rounding of ``k * dt``;
#: the reference moves by its speed times this at most: nanometres).
ON_GRID = 1e-9

#: Windows a grid fill covers (consecutive windows share a point).
WINDOWS = 2

#: The most grid points a fill samples: the tick that fills carries it. A tick much
#: shorter than the stages needs more (1 ms ticks with 0.1 s stages: thousands); such
#: windows are sampled as asked instead (docs/design/lookahead-grid.md).
MAX_POINTS = 400


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
        #: Whether the stage starts lie on the grid and a fill stays small (else every
        #: window is sampled as asked).
        self.gridded = bool(np.abs(steps - index).max() * self.tick <= ON_GRID
                            and WINDOWS * index[-1] + 1 <= MAX_POINTS)
        #: Each stage start's grid point from the window's first (N+1,).
        self.index: IntArray = index.astype(np.intp)
        self._span = int(self.index[-1]) + 1  # grid points one window covers
        #: Grid points a fill samples: two windows' worth, sharing one point.
        self.points = WINDOWS * (self._span - 1) + 1
        #: How a window's rows are read from the grid.
        self.stages = Strided(self.index)
        self._start = math.nan  # time of the grid's first point [s]
        self._filled = 0  # grid points sampled now (0 or points)
        #: The grid's reference pose and velocity (points, 3), replaced at each fill.
        self.pose = self.velocity = np.zeros((0, 3))
        self.fills = 0  # grid fills so far (each replaces ``pose`` and ``velocity``)
        self.samples = 0  # trajectory samples taken (for tests and benchmarks)

    def seek(self, time: float) -> int | None:
        """Move to the window at ``time + offsets``: the grid point it starts at (the grid
        sampled anew when ``time`` is past its end), or None off the grid (then sample the
        window on its own with :meth:`sample`, not :meth:`window`, which would seek again
        and take the time for a grid's start)."""
        if not self.gridded:
            return None
        shift = (time - self._start) / self.tick
        first = round(shift) if math.isfinite(shift) else -1
        on_grid = first >= 0 and abs(time - (self._start + first * self.tick)) <= ON_GRID
        if on_grid and first + self._span <= self._filled:
            return first
        # Past the grid's end on a regular clock: sample two windows' worth (the next
        # window's points included); off the grid (or the first time), nothing.
        self._start, self._filled = time, 0
        return 0 if on_grid and self._fill(time) else None

    def window(self, time: float) -> tuple[FloatArray, FloatArray]:
        """The reference pose and velocity (N+1, 3) at ``time + offsets``: read from the
        grid or sampled on their own."""
        first = self.seek(time)
        if first is None:
            return self.sample(time)
        pose, velocity = np.empty((self.index.size, 3)), np.empty((self.index.size, 3))
        self.stages.gather(self.pose, first, pose)
        self.stages.gather(self.velocity, first, velocity)
        return pose, velocity

    def sample(self, time: float) -> tuple[FloatArray, FloatArray]:
        """The window at ``time + offsets`` sampled on its own (pose, velocity), after a
        :meth:`seek` that gave None."""
        self.samples += 1
        sample = self.trajectory.sample(time + self._offsets)
        return sample.pose, sample.velocity

    def _fill(self, start: float) -> bool:
        """Sample the grid from ``start``; False (nothing kept) if the reference fails
        somewhere on it (its numbers overflow further on, or a user's callable raises
        there: the window alone is sampled then, which raises only if the window itself
        fails; each tick within two windows of such a failure samples twice)."""
        points = self.points
        self.samples += 1
        try:
            sample = self.trajectory.sample(start + self.tick * np.arange(float(points)))
        except Exception:  # anything past the window (a user callable's own error too)
            return False
        self._filled = points
        self.pose, self.velocity = sample.pose, sample.velocity
        self.fills += 1
        return True


class Strided:
    """Rows ``first + index`` of a grid, read as a few strided slices (``index`` split into
    runs of one step: the first stage's one tick, then the rest's ``dt``), which NumPy
    copies several times faster than it gathers an index array.

    Args:
        index: the grid rows from ``first`` (K,), increasing.
    """

    def __init__(self, index: IntArray) -> None:
        self.runs: list[tuple[slice, int, int]] = []  # (rows out, first row in, step)
        start = 0
        while start < index.size:
            step = int(index[start + 1] - index[start]) if start + 1 < index.size else 1
            stop = start + 1
            while stop < index.size and index[stop] - index[stop - 1] == step:
                stop += 1
            self.runs.append((slice(start, stop), int(index[start]), step))
            start = stop

    def gather(self, grid: FloatArray, first: int, out: FloatArray) -> None:
        """``out[:] = grid[first + index]``."""
        for rows, offset, step in self.runs:
            begin = first + offset
            out[rows] = grid[begin:begin + step * (rows.stop - rows.start):step]
