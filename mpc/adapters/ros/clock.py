""":class:`ReferenceClock`: the reference's time from ROS stamps (epoch nanoseconds)."""

from __future__ import annotations

from typing import Any

from mpc.errors import ControllerError
from mpc.validation import finite
from trajectories.rosbag import stamp_nanoseconds


class ReferenceClock:
    """Reference time [s] from ROS stamps: ``reference_start + (stamp - start)``.

    ``start`` is a ``builtin_interfaces/Time``; None: the first stamp given to the clock.
    Differences are taken in integer nanoseconds (no float rounding of epoch seconds).
    """

    def __init__(self, start: Any | None = None, reference_start: float = 0.0) -> None:
        self.restart(start, reference_start)

    def restart(self, start: Any | None = None, reference_start: float = 0.0) -> None:
        """Start again: ``start`` (None: the next stamp seen) is ``reference_start`` [s]."""
        self._start = None if start is None else stamp_nanoseconds(start)
        self.reference_start = finite("reference_start [s]", reference_start, ControllerError)

    @property
    def started(self) -> bool:
        """Whether the start stamp is known."""
        return self._start is not None

    def __call__(self, stamp: Any) -> float:
        """The reference time [s] at ``stamp`` (the first stamp starts an unstarted clock)."""
        if self._start is None:
            self._start = stamp_nanoseconds(stamp)
        return self.at(stamp)

    def at(self, stamp: Any) -> float:
        """The reference time [s] at ``stamp`` of a started clock."""
        if self._start is None:
            raise ControllerError("the clock has not started: no stamp seen yet")
        return self.reference_start + (stamp_nanoseconds(stamp) - self._start) * 1e-9
