"""Output folders that are not silently overwritten.

Every ``mpc-bench`` command that writes results takes ``--out DIR`` and ``--force``:
:func:`claim` refuses a folder that already holds a file the command is about to write
(a second ``mpc-bench`` into ``bench-out`` would replace the first run's results.json)
unless ``--force`` is given. It is called before the long work starts, so a refusal
costs nothing. Other commands' files in the same folder do not count: ``mpc-bench`` and
``mpc-bench perf`` share ``bench-out`` by default.
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Iterable
from pathlib import Path

from benchmarks.scenarios import ScenarioError


def add_force_argument(parser: argparse.ArgumentParser) -> None:
    """The ``--force`` option of every command that writes into ``--out``."""
    parser.add_argument("--force", action="store_true",
                        help="overwrite the results already in --out (default: refuse)")


def claim(out: str | Path, writes: Iterable[str], force: bool) -> Path:
    """The folder ``out``, created if needed, once it is safe to write ``writes`` (paths
    relative to it) there: raises a one-line :class:`ScenarioError` naming the folder and
    ``--force`` if one of them exists and ``force`` is False, if ``out`` is a file, or if
    it cannot be written (a file is made and removed in it: found before the work, not
    after it, with the results lost)."""
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise ScenarioError(f"--out must be a folder, {str(folder)!r} is a file")
    held = [name for name in writes if (folder / name).exists()]
    if held and not force:
        raise ScenarioError(f"--out {str(folder)!r} already holds results ({', '.join(held)}); "
                            "add --force to overwrite them, or choose another --out")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as error:
        raise ScenarioError(f"--out {str(folder)!r} cannot be written: {error.strerror or error}"
                            ) from None
    return folder


__all__ = ["add_force_argument", "claim"]
