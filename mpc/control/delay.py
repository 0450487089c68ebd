"""Known actuator latency: predict the pose the next command will act on."""

from __future__ import annotations

from collections import deque

from mpc.arrays import FloatArray
from mpc.model.se2 import integrate_unchecked as integrate


class DelayCompensator:
    """Remembers the last ``ticks`` commands and drives the measured pose through them.

    A command sent now acts ``ticks`` ticks later, so the plan should start
    from where the commands already in the pipe will have taken the robot.

    Args:
        ticks: whole ticks of latency (0: the measured pose is used as is).
        dt: control tick [s].
    """

    def __init__(self, ticks: int, dt: float) -> None:
        self.ticks = ticks
        self.dt = dt
        self._sent: deque[FloatArray] = deque(maxlen=max(ticks, 1))

    def reset(self, last_twist: FloatArray) -> None:
        """The robot has been executing ``last_twist`` for as long as the pipe is."""
        self._sent.clear()
        self._sent.extend([last_twist.copy()] * self.ticks)

    def predict(self, pose: FloatArray) -> FloatArray:
        """The pose after the commands still in the pipe (the pose itself without delay)."""
        for twist in self._sent if self.ticks else ():
            pose = integrate(pose, twist, self.dt)
        return pose

    def sent(self, twist: FloatArray) -> None:
        if self.ticks:
            self._sent.append(twist)
