"""Known actuator latency: predict the pose the next command will act on.

Two kinds, both as a shift of where and when the plan starts:

- **Whole ticks of delay** (``ticks``): a command sent now acts ``ticks`` ticks later; the
  plan starts from where the commands already in the pipe will have taken the robot.
- **A ramped command** (``ramp``): the drive does not step to a command but ramps to it
  from the last one over the tick (a first-order hold: the motor plant's wheel loops, a
  motion-profiled velocity loop). Over a tick the robot then moves ``(c_prev + c) / 2 dt``
  where the plan's model (a twist held over each stage) moves ``c dt``: the ramped drive
  is the held one half a tick late. So the plan starts half a tick ahead, from the pose
  the robot reaches in half a tick at the twist it moves at now, and on the reference
  half a tick later; its pose at each stage's end is then the robot's at the tick's end
  plus half a tick (exact while the robot does not turn; turning at omega, the ramped
  position differs by about ``omega |dv| dt^2 / 24``: 0.8 mm at 2 rad/s, a 1 m/s change
  and dt = 0.1 s).
"""

from __future__ import annotations

from collections import deque

from mpc.arrays import FloatArray
from mpc.model.se2 import integrate_unchecked as integrate


class DelayCompensator:
    """Remembers the last commands and drives the measured pose through those still acting.

    Args:
        ticks: whole ticks of latency.
        dt: control tick [s].
        ramp: the drive ramps each command from the last one over the tick (module
            docstring); the plan starts half a tick later.

    Attributes:
        lead: how far ahead of the measurement the plan starts [s]:
            ``(ticks + ramp / 2) dt``.
    """

    def __init__(self, ticks: int, dt: float, ramp: bool = False) -> None:
        self.ticks = ticks
        self.dt = dt
        self.ramp = ramp
        self.lead = (ticks + (0.5 if ramp else 0.0)) * dt
        # the commands still acting, oldest first; with a ramp, also the one the robot has
        # reached (it moves at it for the first half tick)
        self._sent: deque[FloatArray] = deque(maxlen=max(ticks + int(ramp), 1))

    def reset(self, last_twist: FloatArray) -> None:
        """The robot has been executing ``last_twist`` for as long as the pipe is."""
        self._sent.clear()
        self._sent.extend([last_twist.copy()] * (self.ticks + int(self.ramp)))

    def predict(self, pose: FloatArray) -> FloatArray:
        """The pose the plan starts from: ``pose`` moved through the commands still acting
        (``pose`` itself with neither delay nor ramp)."""
        if not self.ticks and not self.ramp:
            return pose
        sent = iter(self._sent)
        if self.ramp:  # half a tick at the twist the robot moves at now
            pose = integrate(pose, next(sent), 0.5 * self.dt)
        for twist in sent:
            pose = integrate(pose, twist, self.dt)
        return pose

    def sent(self, twist: FloatArray) -> None:
        """Record the command just sent."""
        if self.ticks or self.ramp:
            self._sent.append(twist)
