"""What this machine can build: the C compiler the compiled tick uses (``$CC`` or gcc, as
:mod:`mpc.tick.build`) and CMake, and the tick path ``compiled=True`` gives here (the
virtual machine where no compiler works: the tests then check that path)."""

from __future__ import annotations

import os
import shutil

import pytest

COMPILER = os.environ.get("CC") or "gcc"
HAS_COMPILER = shutil.which(COMPILER) is not None
HAS_CMAKE = HAS_COMPILER and shutil.which("cmake") is not None
#: ``Controller(..., compiled=True).tick_path`` on this machine.
COMPILED_PATH = "compiled" if HAS_COMPILER else "virtual-machine"

needs_compiler = pytest.mark.skipif(not HAS_COMPILER, reason=f"no C compiler ({COMPILER})")
needs_cmake = pytest.mark.skipif(not HAS_CMAKE, reason=f"needs cmake and a C compiler "
                                                       f"({COMPILER})")
