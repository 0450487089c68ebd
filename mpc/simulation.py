"""Deprecated: the simulation harness moved to :mod:`mpc.sim` (``from mpc.sim import simulate``)."""

import warnings

from mpc.sim import LIMIT_RTOL, SimResult, TrackingController, simulate

warnings.warn("mpc.simulation is now mpc.sim (from mpc.sim import simulate, SimResult)",
              DeprecationWarning, stacklevel=2)

__all__ = ["LIMIT_RTOL", "SimResult", "TrackingController", "simulate"]
