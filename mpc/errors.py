"""The project's exceptions: one root, a subclass per area.

Every error holonomic-mpc raises on bad input or an unusable file derives
from :class:`MpcError`, which is a ``ValueError``, so ``except mpc.MpcError``
(or ``except ValueError``) catches all of them. Messages name the input, say
what was expected and what arrived.

=======================  ==============================================
exception                raised for
=======================  ==============================================
``MpcError``             the root; nothing raises it directly
``RobotError``           robot geometry, limits, presets, robot files
``TrajectoryError``      trajectory arguments, waypoint files
``ControllerError``      controller options, ``step()`` arguments
``SimulationError``      plant settings, simulation arguments
``ReportError``          results files and runs that cannot be plotted
=======================  ==============================================

This module imports nothing from the project, so every layer (the
``trajectories`` package included) can use it.
"""

from __future__ import annotations


class MpcError(ValueError):
    """Root of every exception raised by holonomic-mpc on bad input."""


class RobotError(MpcError):
    """A robot description is invalid (geometry, limits, file or preset)."""


class TrajectoryError(MpcError):
    """A trajectory argument has the wrong type, shape or value, or a file is unusable."""


class ControllerError(MpcError):
    """A controller option or a ``step()`` argument is invalid."""


class SimulationError(MpcError):
    """A plant setting or a simulation argument is invalid."""


class ReportError(MpcError):
    """A results file, document or run cannot be plotted or reported: missing, not JSON,
    lacking keys or of the wrong shape."""


def __getattr__(name: str) -> type[MpcError]:
    if name == "MpcInputError":
        import warnings

        warnings.warn("mpc.errors.MpcInputError is now mpc.errors.MpcError (the one root)",
                      DeprecationWarning, stacklevel=2)
        return MpcError
    if name == "SolverFailedError":
        raise AttributeError(
            "SolverFailedError was never raised and has been removed: a failed solve is "
            "reported in Command.status and Command.consecutive_failures")
    raise AttributeError(f"module 'mpc.errors' has no attribute {name!r}")
