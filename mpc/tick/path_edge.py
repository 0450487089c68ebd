"""Path mode's reference at the compiled tick's edge: the trajectory sampled at the progress
guess by the Python tick's own objects (:class:`~mpc.control.timing.PathProgress` on a
:class:`~mpc.control.timing.ReferenceWindow` of its own, ``grid=False`` as the Python
tick's path mode), handed to the graphs as the model's parameter vector and the progress
bounds (:mod:`mpc.tick.path`). As time mode's window, the sampling stays in Python: the
trajectory is a Python object, and where it is sampled follows the last plan's progress.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray
from mpc.control.timing import PathProgress, ReferenceWindow
from mpc.model.layout import PathInput, TickInput
from mpc.model.tracking import TrackingModel
from trajectories import Trajectory, TrajectoryError


class PathReference:
    """Where the progress is and the reference there, tick by tick.

    Args:
        trajectory: the reference.
        model: the controller's (path-mode) model.
    """

    def __init__(self, trajectory: Trajectory, model: TrackingModel) -> None:
        self.trajectory = trajectory
        self._tick = TickInput(model.layouts)
        path = self._tick.path
        if path is None:
            raise RuntimeError("PathReference needs a path-mode model")
        self._path: PathInput = path
        self._window = ReferenceWindow(trajectory, model, self._tick, grid=False)
        self._timing = PathProgress(self._window, model)
        #: The model's parameter vector as the graphs take it (its ``x0`` and
        #: ``last_twist`` are the graphs' to fill).
        self.parameters: FloatArray = self._tick.parameters
        #: The progress's bounds [s], (N+1, 2): lower, upper.
        self.bounds = np.zeros((path.lower.size, 2))

    def reset(self) -> None:
        """Forget the progress plan (a reset, a new trajectory)."""
        self._timing.reset()

    def fill(self, t: float, heading: float) -> float:
        """The reference at the progress guess for time ``t`` [s] and the measured
        ``heading`` [rad] into :attr:`parameters` and :attr:`bounds`; returns the progress
        now (the reference time tracked) [s]. Raises TrajectoryError where the trajectory
        cannot be sampled (the reference poses and feedforward are then NaN, as the Python
        tick's: the graphs fall back without the feedforward)."""
        try:
            start = self._timing.fill(t, t, heading)
        except TrajectoryError:
            self._tick.poses_ref[:] = math.nan
            self._tick.twists_ref[:] = math.nan
            raise
        self._bounds()
        return start

    def refine(self, progress: FloatArray, heading: float) -> bool:
        """After a solve with no plan to start from: whether to solve again, the reference
        sampled at the planned ``progress`` (N+1,) [s] (:meth:`PathProgress.refine`)."""
        if not self._timing.refine(progress, heading):
            return False
        self._bounds()
        return True

    def solved(self, progress: FloatArray | None) -> None:
        """The tick's planned progress, or None after a failed tick."""
        self._timing.solved(progress)

    def reference_heading(self) -> float:
        """The reference's own heading at stage 0 [rad] (the unwrapped one plus the turns
        taken off), for the first tick's heading check."""
        return float(self._tick.poses_ref[0, 2]) + 2.0 * math.pi * self._window.turns

    def _bounds(self) -> None:
        self.bounds[:, 0] = self._path.lower
        self.bounds[:, 1] = self._path.upper
