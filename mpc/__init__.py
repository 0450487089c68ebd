"""holonomic-mpc: model-predictive trajectory tracking for holonomic robots.

The public entry point is :class:`Controller`; robots live in
:mod:`mpc.robots`, reference trajectories in the ``trajectories`` package.
"""

from mpc.command import Command, Status
from mpc.controller import SOLVERS, Controller
from mpc.errors import ControllerError, MpcError, MpcInputError, RobotError, SolverFailedError
from mpc.weights import Weights

__all__ = [
    "SOLVERS",
    "Command",
    "Controller",
    "ControllerError",
    "MpcError",
    "MpcInputError",
    "RobotError",
    "SolverFailedError",
    "Status",
    "Weights",
]
