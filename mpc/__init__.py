"""holonomic-mpc: model-predictive trajectory tracking for holonomic robots.

The public entry point is :class:`Controller`; robots live in
:mod:`mpc.robots`, reference trajectories in the ``trajectories`` package,
the simulation harness in :mod:`mpc.sim`, figures and report pages of any
run (simulated or recorded from a loop of your own) in :mod:`mpc.plot`.

Layers, each importing only those before it: :mod:`mpc.errors` ->
:mod:`mpc.robots` (and ``trajectories``) -> :mod:`mpc.model` ->
:mod:`mpc.solvers` -> :mod:`mpc.control` -> :mod:`mpc.sim` -> :mod:`mpc.plot`
(the only one that imports matplotlib, when it draws).

The names below load on first use, so ``import mpc.errors`` (which the
``trajectories`` package does) does not pull in the solvers.
"""

from __future__ import annotations

import importlib
import logging
from typing import TYPE_CHECKING, Any

from mpc.errors import (
    ControllerError,
    MpcError,
    ReportError,
    RobotError,
    SimulationError,
    TrajectoryError,
)

# The library's log (fallbacks starting and ending, never per tick): silent unless the
# application configures logging.
logging.getLogger("mpc").addHandler(logging.NullHandler())

if TYPE_CHECKING:
    from mpc.control import SOLVERS, Command, Controller, Status
    from mpc.model.weights import Weights
    from mpc.tick.export import export_c

_LAZY = {
    "SOLVERS": "mpc.control",
    "Command": "mpc.control",
    "Controller": "mpc.control",
    "Status": "mpc.control",
    "Weights": "mpc.model.weights",
    "export_c": "mpc.tick.export",
}

__all__ = [
    "SOLVERS",
    "Command",
    "Controller",
    "ControllerError",
    "MpcError",
    "ReportError",
    "RobotError",
    "SimulationError",
    "Status",
    "TrajectoryError",
    "Weights",
    "export_c",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    if name in ("MpcInputError", "SolverFailedError"):
        from mpc import errors

        return getattr(errors, name)
    raise AttributeError(f"module 'mpc' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
