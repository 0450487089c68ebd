"""Opt-in compilation of the fast path's per-tick CasADi functions to C.

CasADi evaluates an SX function in its virtual machine; its JIT instead generates C
for it, compiles that with the system's C compiler (CasADi's ``shell`` compiler: ``gcc``
unless ``$CC`` names another) and loads the library. Same inputs, outputs and numbers
(tested bit for bit against the virtual machine). Measured on this project's machine
(2-core EPYC, Mecanum, N = 20): the tick's terms 9.4 -> 1.3 us a call (timeit), the whole tick
0.67-0.97x at the median in runs alternating with the default (README, "Performance");
it costs about 1.5 s of compiling when the controller is built. ``Controller(jit=True)``
compiles the tick's terms, the plan's poses and the reference terms of windows sampled
on their own (windows read from the lookahead's grid take the grid's terms, evaluated in
the virtual machine once a fill).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from typing import Any

import casadi as ca

#: Flags for the compiler: -O2 compiled the N = 20 terms in 1.2 s (-O1: 0.8 s) to the same
#: 1.5-1.6 us a call.
FLAGS = ("-O2",)


class JitError(RuntimeError):
    """The C compiler could not build a function (the message says what it printed)."""


def jitted(function: ca.Function) -> ca.Function:
    """``function`` (an SX function) rebuilt with CasADi's JIT; its build files go to a
    private temporary folder, removed as soon as the library is loaded (CasADi's own
    clean-up is off: it would look for them again when the function is dropped).

    Raises:
        JitError: no C compiler, or it failed (the message has the command CasADi tried).
    """
    inputs = function.sx_in()
    folder = tempfile.mkdtemp(prefix="mpc-jit-")
    options: dict[str, Any] = {"flags": list(FLAGS), "verbose": False, "cleanup": False,
                               "directory": folder + os.sep}
    compiler = os.environ.get("CC")
    if compiler:
        options["compiler"] = compiler
    try:
        return ca.Function(function.name(), inputs, function.call(inputs),
                           {"cse": True, "jit": True, "compiler": "shell",
                            "jit_name": function.name(), "jit_cleanup": False,
                            "jit_options": options})
    except RuntimeError as error:
        lines = [line for line in str(error).splitlines() if line.strip()]
        tried = next((line[line.index("Compilation failed"):] for line in lines
                      if "Compilation failed" in line), lines[-1] if lines else "")
        raise JitError(f"compiling {function.name()!r} to C failed (CasADi's JIT needs a C "
                       f"compiler: gcc on PATH, or $CC): {tried}") from None
    finally:
        shutil.rmtree(folder, ignore_errors=True)
