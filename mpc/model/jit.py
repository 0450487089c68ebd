"""Opt-in compilation of the fast path's per-tick CasADi functions to C.

CasADi evaluates an SX function in its virtual machine; its JIT instead generates C
for it, compiles that with the system's C compiler (CasADi's ``shell`` compiler: ``gcc``
unless ``$CC`` names another) and loads the library. Same inputs, outputs and numbers
(tested bit for bit against the virtual machine): a quicker tick for about 1.5 s of
compiling when the controller is built (docs/design/jit.md). ``Controller(jit=True)``
compiles the tick's terms, the plan's poses and the reference terms of windows sampled
on their own (windows read from the lookahead's grid take the grid's terms, evaluated in
the virtual machine once a fill); ``jit="auto"`` does the same where a compiler works and
keeps the virtual machine where none does.

Each library built is kept in a cache folder (:func:`cache_folder`), named by a hash of
the function, CasADi's version, the compiler and its flags: the same problem built again,
in this process or a later one, loads its library instead of compiling it (tens of
milliseconds). A library that will not load is compiled again; a folder that cannot be
written only means no cache.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import casadi as ca

#: Flags for the compiler (-O1 compiles a little quicker to code as fast: docs/design/jit.md).
FLAGS = ("-O2",)

#: The environment variable naming the cache folder of compiled libraries (see
#: :func:`cache_folder`); ``off`` turns the cache off.
CACHE_VARIABLE = "MPC_JIT_CACHE"


class JitError(RuntimeError):
    """The C compiler could not build a function (the message says what it printed)."""


def cache_folder() -> Path | None:
    """Where compiled libraries are kept: ``$MPC_JIT_CACHE`` if set (``off``: nowhere),
    else ``$XDG_CACHE_HOME/holonomic-mpc/jit`` (``~/.cache/holonomic-mpc/jit``); None if
    that folder cannot be made."""
    named = os.environ.get(CACHE_VARIABLE)
    if named is not None and named.strip().lower() == "off":
        return None
    if named:
        folder = Path(named).expanduser()
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join("~", ".cache")
        folder = Path(base).expanduser() / "holonomic-mpc" / "jit"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return folder


def jitted(function: ca.Function) -> ca.Function:
    """``function`` (an SX function) as compiled C: its library from the cache
    (:func:`cache_folder`) if it is there, else rebuilt with CasADi's JIT and its library
    put there. The build files go to a private temporary folder, removed as soon as the
    library is loaded (CasADi's own clean-up is off: it would look for them again when the
    function is dropped).

    Raises:
        JitError: no C compiler, or it failed (the message has the command CasADi tried).
    """
    compiler = os.environ.get("CC")
    folder = cache_folder()
    cached = (None if folder is None
              else folder / f"{function.name()}-{_key(function, compiler)}.so")
    if cached is not None and cached.is_file():
        try:
            return ca.external(function.name(), str(cached))
        except RuntimeError:  # not a library this CasADi can load: compile it again
            pass
    return _compiled(function, compiler, cached)


def _key(function: ca.Function, compiler: str | None) -> str:
    """What a compiled library depends on, hashed: the function, CasADi's version, the
    compiler and its flags."""
    text = "\n".join([function.serialize(), ca.CasadiMeta.version(), compiler or "", *FLAGS])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _compiled(function: ca.Function, compiler: str | None,
              cached: Path | None) -> ca.Function:
    """``function`` rebuilt with CasADi's JIT (see :func:`jitted`); its library copied to
    ``cached`` (whole or not at all: a copy renamed into place) when given."""
    inputs = function.sx_in()
    build = tempfile.mkdtemp(prefix="mpc-jit-")
    options: dict[str, Any] = {"flags": list(FLAGS), "verbose": False, "cleanup": False,
                               "directory": build + os.sep}
    if compiler:
        options["compiler"] = compiler
    try:
        compiled = ca.Function(function.name(), inputs, function.call(inputs),
                               {"cse": True, "jit": True, "compiler": "shell",
                                "jit_name": function.name(), "jit_cleanup": False,
                                "jit_options": options})
        if cached is not None:
            _keep(Path(build), cached)
        return compiled
    except RuntimeError as error:
        lines = [line for line in str(error).splitlines() if line.strip()]
        tried = next((line[line.index("Compilation failed"):] for line in lines
                      if "Compilation failed" in line), lines[-1] if lines else "")
        raise JitError(f"compiling {function.name()!r} to C failed (CasADi's JIT needs a C "
                       f"compiler: gcc on PATH, or $CC): {tried}") from None
    finally:
        shutil.rmtree(build, ignore_errors=True)


def _keep(build: Path, cached: Path) -> None:
    """The library in ``build`` copied to ``cached`` (nothing if there is not exactly one,
    or the copy fails: the cache is a convenience)."""
    libraries = list(build.glob("*.so"))
    if len(libraries) != 1:
        return
    try:
        handle, name = tempfile.mkstemp(dir=cached.parent, suffix=".part")
    except OSError:
        return
    os.close(handle)
    partial = Path(name)
    try:
        shutil.copyfile(libraries[0], partial)
        partial.chmod(0o644)  # (mkstemp's 0600 would keep a shared folder's others out)
        os.replace(partial, cached)
    except OSError:
        partial.unlink(missing_ok=True)
