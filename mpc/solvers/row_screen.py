"""Which limit rows the dense solver hands daqp: a robot's rows that plans seldom need
(``StageLimits.screened``: a motor model's voltage, current and traction rows) leave daqp's
problem once no plan has had them active for :data:`SCREEN_AFTER` ticks.

daqp's work grows with its rows (each iteration scans them all; its flag to skip a row
does not save that work), and a motor model has many rows of which a manoeuvre binds few
(docs/design/row-screen.md). A plan is checked against the rows left out and the tick
solved again with those it breaks (:meth:`RowScreen.broken`), so the answer is the same:
a plan optimal without some rows and within them is optimal with them. A row is screened
by its place in a stage, for every stage alike (the plan shifts a stage a tick).

Not for swerve's disks, whose rows turn every tick: a screen chosen afresh each tick gave
the same plans but slower ticks, a new daqp model each tick costing more than its fewer
rows saved (docs/design/row-screen.md).
"""

from __future__ import annotations

import numpy as np

from mpc.arrays import FloatArray, IntArray
from mpc.robots.limits import StageLimits, overshoot, rounding_slack, stage_values

__all__ = ["SCREEN_AFTER", "RowScreen"]

#: Ticks without a plan that has a row active (at any stage) before the row leaves daqp's
#: problem; a row a plan breaks comes back and stays for as long again.
SCREEN_AFTER = 50

class RowScreen:
    """The rows in daqp's problem: each stage's rows at the places in play, then the
    ``extra`` rows after the stages' (path mode's progress rows, always in).

    Args:
        limits: the stage rows (N stages of m).
        extra: rows after the stages' in the solver's row order.
    """

    def __init__(self, limits: StageLimits, extra: int) -> None:
        self.horizon, self.stage_rows, self.extra = limits.horizon, limits.rows, extra
        self.in_play = np.ones(self.stage_rows, dtype=bool)
        self.rows: IntArray | None = None  # daqp's rows in the solver's order; None: all
        self._out = np.zeros(0, dtype=np.intp)  # the places out of play
        self._slack = 0.0  # how far past a row left out counts as rounding (set as they leave)
        self._needed_at = np.zeros(self.stage_rows, dtype=np.int64)
        self._ticks = 0

    @property
    def size(self) -> int:
        """Rows in daqp's problem."""
        return self.horizon * int(self.in_play.sum()) + self.extra

    def reset(self) -> None:
        """Every row back in play, needed as of now."""
        self._admit(np.arange(self.stage_rows), None)

    def full(self, multipliers: FloatArray) -> FloatArray:
        """daqp's ``multipliers`` (of its rows) in the solver's row order, 0 for rows out."""
        if self.rows is None:
            return multipliers
        every = np.zeros(self.horizon * self.stage_rows + self.extra)
        every[self.rows] = multipliers
        return every

    def picked(self, values: FloatArray) -> FloatArray:
        """The entries of ``values`` (in the solver's row order) for daqp's rows."""
        return values if self.rows is None else values[self.rows]

    def solved(self, multipliers: FloatArray, again: bool = False) -> None:
        """A tick's plan (its ``multipliers`` in the solver's row order; ``again``: the
        tick's second or later): its active rows are needed as of now."""
        self._ticks += not again
        stages = multipliers[:self.horizon * self.stage_rows].reshape(self.horizon, -1)
        self._needed_at[(stages != 0.0).any(axis=0)] = self._ticks

    def broken(self, limits: StageLimits, twists: FloatArray, last: FloatArray) -> IntArray:
        """The places out of play whose rows the plan ``twists`` (N, 3) (after the command
        ``last``) breaks at some stage, beyond rounding."""
        out = self._out
        if out.size == 0:
            return out
        # every row (contiguous products beat gathering the rows out first)
        excess = overshoot(limits, stage_values(limits, twists, last))[:, out]
        return out[(excess > self._slack).any(axis=0)]

    def admit(self, places: IntArray, limits: StageLimits) -> None:
        """The rows at ``places`` of ``limits`` back in play (a plan broke them)."""
        self._admit(places, limits)

    def retire(self, limits: StageLimits) -> bool:
        """Take out of play the rows no plan has needed for :data:`SCREEN_AFTER` ticks
        (never an equality row of ``limits``: every plan is on it); whether any left."""
        stale = self.in_play & (self._ticks - self._needed_at >= SCREEN_AFTER)
        if not stale.any():
            return False
        stale &= ~(limits.lower == limits.upper).any(axis=0)
        if not stale.any():
            return False
        if stale.sum() == self.in_play.sum():  # daqp needs a row: the last one needed stays
            stale[np.flatnonzero(self.in_play)[np.argmax(self._needed_at[self.in_play])]] = False
            if not stale.any():
                return False
        self.in_play &= ~stale
        self._index(limits)
        return True

    def _admit(self, places: IntArray, limits: StageLimits | None) -> None:
        self.in_play[places] = True
        self._needed_at[places] = self._ticks
        self._index(limits)

    def _index(self, limits: StageLimits | None) -> None:
        """daqp's rows and the places out of play, and the slack of the rows out."""
        self._out = np.flatnonzero(~self.in_play)
        if limits is not None and self._out.size:  # (its bounds when the rows left)
            self._slack = rounding_slack(limits.lower[:, self._out], limits.upper[:, self._out])
        if self.in_play.all():
            self.rows = None
            return
        n, m = self.horizon, self.stage_rows
        stages = (m * np.arange(n)[:, None] + np.flatnonzero(self.in_play)).ravel()
        self.rows = np.concatenate([stages, n * m + np.arange(self.extra)])
