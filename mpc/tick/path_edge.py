"""Path mode's reference at the compiled tick's edge: the trajectory sampled at the times
the progress graphs give (:mod:`mpc.tick.progress`, through :mod:`mpc.tick.path_runner`).
The trajectory is a Python object, so sampling it stays in Python (an exported library's
caller samples its own); everything made of the samples is the graphs'.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray
from trajectories import Trajectory, TrajectoryError


def sample_at(trajectory: Trajectory, times: FloatArray
              ) -> tuple[tuple[FloatArray, FloatArray, FloatArray], str | None]:
    """The reference's poses, world velocities and accelerations at ``times`` (N+1,) [s],
    each (N+1, 3), and None; all NaN and the reason where the trajectory cannot be sampled
    there (the tick then falls back without the feedforward)."""
    try:
        sample = trajectory.sample(np.asarray(times, dtype=float))
    except TrajectoryError as error:
        nan = np.full((len(times), 3), math.nan)
        return (nan, nan.copy(), nan.copy()), f"reference failed: {error}"
    return (sample.pose, sample.velocity, sample.acceleration), None
