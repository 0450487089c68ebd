"""What to command when the solver fails: the fallback policy, in order.

1. the shifted previous plan, while it lasts (``horizon`` ticks);
2. the reference feedforward scaled into the wheel limits (another ``horizon`` ticks);
3. a stop ramp (zero twist; the clamp keeps the deceleration within the limits).

The state is one count of failures in a row and the last successful plan.
"""

from __future__ import annotations

import numpy as np

from mpc.arrays import FloatArray
from mpc.control.command import Status
from mpc.robots.base import Robot


class FallbackPolicy:
    """Counts failed ticks and picks the fallback twist.

    Args:
        robot: for scaling the feedforward into the wheel limits.
        horizon: ticks each of the first two fallbacks lasts.
    """

    def __init__(self, robot: Robot, horizon: int) -> None:
        self.robot = robot
        self.horizon = horizon
        self.failures = 0
        self._plan: FloatArray | None = None

    def reset(self) -> None:
        self.failures = 0
        self._plan = None

    def succeeded(self, plan_twists: FloatArray) -> None:
        """The solver returned ``plan_twists`` (N, 3) (kept, not copied: results are never
        written to again)."""
        self.failures = 0
        self._plan = plan_twists

    def failed(self, feedforward: FloatArray) -> tuple[Status, FloatArray]:
        """One more failure: the fallback status and twist (3,) for this tick."""
        self.failures += 1
        if self._plan is not None and self.failures < self.horizon:
            return Status.PREVIOUS_PLAN, self._plan[self.failures]
        if self.failures < 2 * self.horizon:
            return Status.FEEDFORWARD, self.robot.desaturate(feedforward)
        return Status.STOPPING, np.zeros(3)
