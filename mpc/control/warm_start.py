"""The guess a solve starts from: the previous plan shifted one tick, or the reference."""

from __future__ import annotations

import math

from mpc.arrays import FloatArray
from mpc.model.layout import TickInput


class WarmStart:
    """Keeps the last successful plan and writes the next guess into the tick."""

    def __init__(self, tick: TickInput) -> None:
        self.tick = tick
        self._plan: tuple[FloatArray, FloatArray] | None = None

    def reset(self) -> None:
        """Forget the plan: the next guess is the reference."""
        self._plan = None

    def store(self, poses: FloatArray, twists: FloatArray) -> None:
        """Keep a successful plan (poses (N+1, 3), twists (N, 3)); a solver result's arrays
        are never written to again, so they are kept as they are."""
        self._plan = (poses, twists)

    def fill(self, pose: FloatArray, shift: bool = True) -> None:
        """Write the guess into the tick, starting at the measured ``pose``.

        The previous plan shifted one tick (its last stage repeated; ``shift=False``:
        as it is, to solve the same tick again), or the tick's reference when there
        is none; the headings are moved by a multiple of 2 pi to match a wrapped
        measured heading.
        """
        poses, twists = self.tick.guess_poses, self.tick.guess_twists
        if self._plan is None:
            poses[:] = self.tick.poses_ref
            twists[:] = self.tick.twists_ref
        elif not shift:
            poses[:], twists[:] = self._plan
        else:
            plan_poses, plan_twists = self._plan
            poses[:-1] = plan_poses[1:]
            poses[-1] = plan_poses[-1]
            twists[:-1] = plan_twists[1:]
            twists[-1] = plan_twists[-1]
            turns = math.floor((poses[0, 2] - pose[2]) / (2.0 * math.pi) + 0.5)
            if turns:  # the measured heading was wrapped
                poses[:, 2] -= 2.0 * math.pi * turns
        poses[0] = pose
