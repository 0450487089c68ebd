"""The exception raised by :mod:`trajectories` for every bad argument or unusable file.

It is :class:`mpc.errors.TrajectoryError`, a subclass of the project's one
root :class:`mpc.errors.MpcError` (a ``ValueError``). Messages say what was
expected and what arrived, e.g. ``radius must be a finite number > 0, got -1.0``.
"""

from mpc.errors import TrajectoryError

__all__ = ["TrajectoryError"]
