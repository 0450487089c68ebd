"""The guess a solve starts from: the previous plan moved on one tick, or the reference."""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray
from mpc.model.grid import shift_maps
from mpc.model.layout import TickInput


class WarmStart:
    """Keeps the last successful plan and writes the next guess into the tick.

    Args:
        tick: the tick input the guess is written into.
        offsets: each stage's start from the plan's start (N+1,) [s] (the last: its end).
        step: the control tick [s]: how far the plan moves on between solves.
    """

    def __init__(self, tick: TickInput, offsets: FloatArray, step: float) -> None:
        self.tick = tick
        self._poses_map, self._twists_map = shift_maps(np.asarray(offsets, dtype=float), step)
        self._plan: tuple[FloatArray, FloatArray] | None = None

    def reset(self) -> None:
        """Forget the plan: the next guess is the reference."""
        self._plan = None

    @property
    def cold(self) -> bool:
        """Whether the next guess is the reference (no plan kept)."""
        return self._plan is None

    def hold(self, twist: FloatArray) -> None:
        """Make the guess's twists ``twist`` (3,) at every stage (its poses stay): a guess
        at the robot's own motion, for a solve that failed from the reference's."""
        self.tick.guess_twists[:] = twist

    def store(self, poses: FloatArray, twists: FloatArray) -> None:
        """Keep a successful plan (poses (N+1, 3), twists (N, 3)); a solver result's arrays
        are never written to again, so they are kept as they are."""
        self._plan = (poses, twists)

    def fill(self, pose: FloatArray, shift: bool = True) -> None:
        """Write the guess into the tick, starting at the measured ``pose``.

        The previous plan moved on one tick (see :func:`shift_maps`; ``shift=False``: as
        it is, to solve the same tick again), or the tick's reference when there is none;
        the headings are moved by a multiple of 2 pi to match a wrapped measured heading.
        """
        poses, twists = self.tick.guess_poses, self.tick.guess_twists
        if self._plan is None:
            poses[:] = self.tick.poses_ref
            twists[:] = self.tick.twists_ref
        elif not shift:
            poses[:], twists[:] = self._plan
        else:
            plan_poses, plan_twists = self._plan
            np.matmul(self._poses_map, plan_poses, out=poses)
            np.matmul(self._twists_map, plan_twists, out=twists)
            turns = math.floor((poses[0, 2] - pose[2]) / (2.0 * math.pi) + 0.5)
            if turns:  # the measured heading was wrapped
                poses[:, 2] -= 2.0 * math.pi * turns
        poses[0] = pose
