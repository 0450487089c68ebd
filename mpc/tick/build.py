"""The tick's graphs generated to C with ``tick.c`` around them, compiled with gcc (or
``$CC``) against the casadi wheel's own daqp, and kept in the library cache.

Recipe (docs/guide/compiled-tick.md): daqp's headers from
``casadi/include/daqp``, its static library ``libdaqpstat.a`` linked in with its symbols
kept private (``--exclude-libs,ALL``: the casadi wheel and the daqp Python module carry
different daqp versions) and ``-z defs`` (a missing daqp is a link error, not a load error
later). The library is named by a hash of the generated sources, ``tick.c``, the compiler
and its flags, in :func:`~mpc.model.jit.cache_folder` (``$MPC_JIT_CACHE``): the same
controller built again loads it (milliseconds) instead of compiling it (seconds).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from mpc.model.jit import JitError, cache_folder
from mpc.tick import screen
from mpc.tick.graphs import TickGraphs

#: The hand-written C around the graphs, and its header (the interface).
TICK_SOURCE = Path(__file__).with_name("tick.c")
TICK_HEADER = Path(__file__).with_name("mpc_tick.h")

#: Compiler flags (no ``-march``: the library runs where it was built and on its kind;
#: no ``-ffast-math``: no reassociated sums). The generated graphs at -O2 (long straight
#: code: -O3 only compiles longer); ``tick.c``'s loops at -O3 (vectorised; measured in
#: docs/guide/compiled-tick.md).
FLAGS = ("-O2", "-fPIC")
LOOP_FLAGS = ("-O3", "-fPIC")

#: The generated sources' base name (``.c``, ``.h``).
GRAPHS_NAME = "mpc_tick_graphs"


def casadi_folder() -> Path:
    """The casadi wheel's folder (its ``include/daqp`` and ``libdaqpstat.a``)."""
    return Path(ca.__file__).parent


def write_sources(graphs: TickGraphs, folder: Path) -> list[Path]:
    """The generated graphs (``mpc_tick_graphs.c``/``.h``), their sizes
    (``mpc_tick_config.h``) and ``tick.c`` written into ``folder``: the C sources."""
    folder.mkdir(parents=True, exist_ok=True)
    generator = ca.CodeGenerator(f"{GRAPHS_NAME}.c", {"with_header": True})
    functions = (graphs.prepare, graphs.hessian, graphs.whiten, graphs.whiten_rows,
                 graphs.unwhiten, graphs.finish,
                 *getattr(graphs, "progress_graphs", ()))  # path mode's (mpc.tick.progress)
    for function in functions:
        generator.add(function)
    generator.generate(str(folder) + os.sep)
    sizes = {
        "MPC_N": graphs.horizon, "MPC_NV": graphs.variables, "MPC_M": graphs.rows,
        "MPC_W": graphs.wheels, "MPC_CARRY": graphs.carry, "MPC_TERMS": graphs.terms,
        # motor-aware robots (mpc.tick.motors): the feedforward's numbers (else 0)
        "MPC_FF": graphs.feedforward,
        "MPC_SZ_ARG": max(f.sz_arg() for f in functions),
        "MPC_SZ_RES": max(f.sz_res() for f in functions),
        "MPC_SZ_IW": max(max(f.sz_iw() for f in functions), 1),
        "MPC_SZ_W": max(max(f.sz_w() for f in functions), 1),
        # swerve (mpc/tick/steered.py) and motor-aware robots (mpc/tick/motors.py): rows
        # that move every tick (their nonzeros); swerve: the rows' state (the faces'
        # directions), the steer angles; 0 for other robots
        "MPC_MOVING_ROWS": graphs.moving_rows, "MPC_ROW_STATE": len(graphs.row_state),
        "MPC_STEER": graphs.steer,
        # the row screen (mpc/tick/screen.py): rows a stage it covers (0: none), its default
        "MPC_SCREEN_ROWS": len(graphs.screen_places), "MPC_SCREEN_AFTER": screen.LIBRARY_AFTER,
    }
    config = getattr(graphs, "config", None)  # path mode's sizes (mpc.tick.path)
    if config is not None:
        sizes.update(config())
    offsets = ", ".join(f"{value!r}" for value in graphs.offsets)
    moving = []  # moving rows' sparsity (column by column), for tick.c's whitening
    if graphs.moving_rows:
        pattern = graphs.whiten_rows.sparsity_in(1)
        moving = [f"#define MPC_ROWS_COLIND {{{', '.join(map(str, pattern.colind()))}}}",
                  f"#define MPC_ROWS_ROW {{{', '.join(map(str, pattern.row()))}}}",
                  f"#define MPC_ROWS_MOVE {{{', '.join(str(int(x)) for x in graphs.rows_move)}}}"]
    config = ["/* Sizes of the generated tick (mpc/tick/build.py). */",
              "#ifndef MPC_TICK_CONFIG_H", "#define MPC_TICK_CONFIG_H",
              *(f"#define {name} {value}" for name, value in sizes.items()),
              "/* the control tick [s]; each stage's start from the window's [s] */",
              f"#define MPC_DT {graphs.tick!r}",
              f"#define MPC_STAGE_OFFSETS {{{offsets}}}",
              *([f"#define MPC_ROW_STATE_START {{{', '.join(map(repr, graphs.row_state))}}}"]
                if graphs.row_state else []), *moving,
              *([f"#define MPC_SCREEN_PLACES {{{', '.join(map(str, graphs.screen_places))}}}"]
                if graphs.screen_places else []), "#endif", ""]
    (folder / "mpc_tick_config.h").write_text("\n".join(config))
    shutil.copyfile(TICK_SOURCE, folder / "tick.c")
    shutil.copyfile(TICK_HEADER, folder / "mpc_tick.h")
    return [folder / f"{GRAPHS_NAME}.c", folder / "tick.c"]


def compiled_library(graphs: TickGraphs) -> tuple[Path, bool]:
    """The tick's shared library, and whether it is a private copy the caller removes once
    loaded (no cache): from the cache if built before, else compiled now.

    Raises:
        JitError: no C compiler works (the message has the command and what it printed).
    """
    compiler = os.environ.get("CC") or "gcc"
    build = Path(tempfile.mkdtemp(prefix="mpc-tick-"))
    try:
        sources = write_sources(graphs, build)
        key = _key(build, compiler)
        folder = cache_folder()
        cached = None if folder is None else folder / f"mpc_tick-{key}.so"
        if cached is not None and cached.is_file():
            return cached, False
        library = build / "mpc_tick.so"
        _compile(compiler, sources, build, library)
        if cached is not None and keep_whole(library, cached):
            return cached, False
        # no cache (or it cannot be written): a private copy that outlives the build
        handle, name = tempfile.mkstemp(prefix="mpc_tick-", suffix=".so")
        os.close(handle)
        shutil.copyfile(library, name)
        return Path(name), True
    finally:
        shutil.rmtree(build, ignore_errors=True)


def _key(build: Path, compiler: str) -> str:
    """What the library depends on, hashed: the sources, the compiler and its flags."""
    digest = hashlib.sha256()
    for name in sorted(os.listdir(build)):
        digest.update(name.encode())
        digest.update((build / name).read_bytes())
    digest.update("\n".join([compiler, *FLAGS, *LOOP_FLAGS,
                             ca.CasadiMeta.version()]).encode())
    return digest.hexdigest()[:32]


def _compile(compiler: str, sources: list[Path], build: Path, library: Path) -> None:
    """Compile ``sources`` into ``library`` (JitError with the compiler's words if not)."""
    casadi = casadi_folder()
    include = [f"-I{build}", f"-I{casadi / 'include'}"]
    objects = []
    for source in sources:
        flags = LOOP_FLAGS if source.name == "tick.c" else FLAGS
        objects.append(source.with_suffix(".o"))
        _run([compiler, *flags, "-c", str(source), *include, "-o", str(objects[-1])],
             compiler)
    _run([compiler, "-shared", *map(str, objects), f"-L{casadi}", "-l:libdaqpstat.a", "-lm",
          "-Wl,--exclude-libs,ALL", "-Wl,-z,defs", "-o", str(library)], compiler)
    if not library.is_file():
        raise JitError(f"compiling the tick failed ({compiler}): no library was written")


def _run(command: list[str], compiler: str) -> None:
    """One compiler command (JitError with its last words if it fails)."""
    try:
        done = subprocess.run(command, capture_output=True, text=True, check=False)
    except OSError as error:
        raise JitError(f"compiling the tick failed: {compiler}: {error}") from None
    if done.returncode != 0:
        words = (done.stderr or done.stdout).strip().splitlines()[-3:]
        raise JitError(f"compiling the tick failed ({compiler}, exit {done.returncode}): "
                       + " / ".join(words))


def keep_whole(library: Path, cached: Path, mode: int = 0o644) -> bool:
    """``library`` copied to ``cached`` (permissions ``mode``), whole or not at all (a copy
    renamed into place); whether it is there now."""
    try:
        handle, name = tempfile.mkstemp(dir=cached.parent, suffix=".part")
    except OSError:
        return False
    os.close(handle)
    partial = Path(name)
    try:
        shutil.copyfile(library, partial)
        partial.chmod(mode)
        os.replace(partial, cached)
    except OSError:
        partial.unlink(missing_ok=True)
        return False
    return True
