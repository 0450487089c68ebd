"""What to command when the solver fails: the fallback policy, in order.

1. the previous plan, read at the time since it was made, while it lasts;
2. the reference feedforward scaled into the wheel limits (as many ticks again; skipped
   when the reference itself failed);
3. a stop ramp (zero twist; the clamp keeps the deceleration within the limits).

The state is one count of failures in a row and the last successful plan.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from mpc.arrays import FloatArray
from mpc.control.command import Status
from mpc.robots.base import Robot

#: Fallbacks starting (warning) and ending (info), never once per tick.
log = logging.getLogger("mpc.control")


class FallbackPolicy:
    """Counts failed ticks and picks the fallback twist.

    Args:
        robot: for scaling the feedforward into the wheel limits.
        offsets: each stage's start from the plan's start (N+1,) [s] (the last: its end).
        tick: the control tick [s].
    """

    def __init__(self, robot: Robot, offsets: FloatArray, tick: float) -> None:
        self.robot = robot
        # The stage each tick of a failure streak falls in, while the plan lasts; the
        # first two fallbacks last that many ticks each.
        times = tick * np.arange(int(np.ceil(offsets[-1] / tick - 1e-9)))
        self._stages = np.searchsorted(offsets, times + 1e-9 * tick, side="right") - 1
        self.horizon = int(self._stages.size)
        self.failures = 0
        self._plan: FloatArray | None = None

    def reset(self) -> None:
        self.failures = 0
        self._plan = None

    def succeeded(self, plan_twists: FloatArray) -> None:
        """The solver returned ``plan_twists`` (N, 3) (kept, not copied: results are never
        written to again)."""
        if self.failures:
            log.info("solved again after %d failed ticks", self.failures)
        self.failures = 0
        self._plan = plan_twists

    def failed(self, feedforward: FloatArray, reason: str = "") -> tuple[Status, FloatArray]:
        """One more failure: the fallback status and twist (3,) for this tick (``reason``: what
        failed, for the log)."""
        self.failures += 1
        if self.failures == 1:
            log.warning("falling back: %s", reason)
        elif self.failures == self.horizon:
            log.warning("still failing after %d ticks (%s): the last plan is used up",
                        self.failures, reason)
        if self._plan is not None and self.failures < self.horizon:
            return Status.PREVIOUS_PLAN, self._plan[self._stages[self.failures]]
        if self.failures < 2 * self.horizon and math.isfinite(float(feedforward.sum())):
            return Status.FEEDFORWARD, self.robot.desaturate(feedforward)
        return Status.STOPPING, np.zeros(3)
