"""The plan's time grid moved on by one control tick: how a plan made now reads later."""

from __future__ import annotations

import numpy as np

from mpc.arrays import FloatArray


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
