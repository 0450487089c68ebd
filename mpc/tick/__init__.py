"""The tick as one program (issue 37, first slice): CasADi graphs built from the model's own
functions, generated to C around daqp's C API and compiled, or run in CasADi's virtual
machine where no compiler works.

``Controller(robot, trajectory, compiled=True)`` runs it (``controller.tick_path`` says
which path); :mod:`mpc.tick.graphs` has the arithmetic, ``tick.c`` the small hand-written
part (daqp's workspace kept between ticks, the dense Cholesky factor),
:mod:`mpc.tick.reuse` when the Hessian kept across ticks is rebuilt,
:mod:`mpc.tick.path` path mode's graphs, :mod:`mpc.tick.progress` its progress
arithmetic, :mod:`mpc.tick.path_runner` its three calls a tick and :mod:`mpc.tick.path_edge`
its reference sampled at the edge, :mod:`mpc.tick.steered` swerve's rows, clamp and module commands,
:mod:`mpc.tick.motors` a motor model's rows, clamp and feedforward,
:mod:`mpc.tick.offset` axle-offset swerve modules' clamp and commands,
:mod:`mpc.tick.casters` powered casters' rows, clamp and joint rates,
:mod:`mpc.tick.build` the compiler and the cache, :mod:`mpc.tick.runners` the two ways to
run it, :mod:`mpc.tick.edge` the Python around it, :mod:`mpc.tick.support` what it covers.
"""

from __future__ import annotations

from mpc.tick.edge import COMPILED_CHOICES, CompiledTick, check_compiled
from mpc.tick.support import SUPPORTED, UnsupportedTickError

__all__ = ["COMPILED_CHOICES", "SUPPORTED", "CompiledTick", "UnsupportedTickError",
           "check_compiled"]
