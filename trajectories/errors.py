"""The exception raised by :mod:`trajectories` for every bad argument."""

from __future__ import annotations


class TrajectoryError(ValueError):
    """An argument has the wrong type, shape or value, or a file is unusable.

    Messages say what was expected and what arrived, e.g.
    ``radius must be a finite number > 0, got -1.0``.
    """
