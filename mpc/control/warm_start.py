"""The guess a solve starts from: the previous plan moved on one tick, or the reference."""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray
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


def shift_maps(offsets: FloatArray, step: float) -> tuple[FloatArray, FloatArray]:
    """Linear maps from a plan to the same plan ``step`` seconds later, on the same stages.

    Poses (N+1, N+1): the plan's poses interpolated linearly in time at ``step + offsets``
    (the last pose held beyond the end). Twists (N, N): each new stage's time average of
    the plan's piecewise-constant twists (the last twist held beyond the end). With stages
    of one ``step`` each, both are the plain shift by one stage.
    """
    n = offsets.size - 1
    eye = np.eye(n + 1)
    poses_map = np.stack([np.interp(step + offsets, offsets, eye[:, j]) for j in range(n + 1)],
                         axis=1)
    durations = np.diff(offsets)
    # Integral of twist j's indicator from the plan's start, at the old offsets, then
    # extended past the end with the last twist held.
    integral = np.clip(offsets[:, None] - offsets[None, :-1], 0.0, durations[None, :])

    def at(times: FloatArray) -> FloatArray:
        inside = np.stack([np.interp(times, offsets, integral[:, j]) for j in range(n)], axis=1)
        inside[:, -1] += np.maximum(times - offsets[-1], 0.0)
        return inside

    starts, ends = step + offsets[:-1], step + offsets[1:]
    twists_map = (at(ends) - at(starts)) / (ends - starts)[:, None]
    return poses_map, twists_map
