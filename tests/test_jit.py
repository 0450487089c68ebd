"""The cache of compiled CasADi functions (:mod:`mpc.model.jit`): a function built again
loads the library built before, with the same numbers; a library that will not load is
compiled again; the cache can be moved or turned off."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mpc.model import jit
from mpc.model.jit import CACHE_VARIABLE, JitError, cache_folder, jitted

_COMPILER = os.environ.get("CC") or "gcc"
needs_compiler = pytest.mark.skipif(shutil.which(_COMPILER) is None,
                                    reason=f"no C compiler ({_COMPILER})")


def _function(scale: float = 2.0) -> ca.Function:
    x = ca.SX.sym("x", 3)
    return ca.Function("probe", [x], [ca.sin(x) * x[0] * scale + ca.exp(x[2])])


def _point() -> np.ndarray:
    return np.array([0.3, -1.2, 0.7])


@needs_compiler
def test_a_function_built_again_loads_its_library(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """The first build compiles and keeps one library; the second loads it without the
    compiler (compiling would fail here) and gives the virtual machine's numbers bit for
    bit; another function gets a library of its own."""
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path))
    function = _function()
    first = jitted(function)
    (library,) = tmp_path.iterdir()
    assert library.suffix == ".so" and library.stat().st_mode & 0o777 == 0o644

    def no_compiler(*_: object) -> ca.Function:
        raise JitError("compiled again")

    monkeypatch.setattr(jit, "_compiled", no_compiler)
    second = jitted(function)
    expected = np.asarray(function(_point()))
    np.testing.assert_array_equal(np.asarray(first(_point())), expected)
    np.testing.assert_array_equal(np.asarray(second(_point())), expected)
    with pytest.raises(JitError, match="compiled again"):
        jitted(_function(3.0))  # another function: not in the cache


@needs_compiler
def test_a_library_that_will_not_load_is_compiled_again(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    """A cached file that is not a library (a truncated copy, say) is replaced by a new
    build, whose numbers are right."""
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path))
    function = _function()
    jitted(function)
    (library,) = tmp_path.iterdir()
    library.write_bytes(b"not a library")
    again = jitted(function)
    np.testing.assert_array_equal(np.asarray(again(_point())),
                                  np.asarray(function(_point())))
    assert library.stat().st_size > len(b"not a library")
    assert [path.name for path in tmp_path.iterdir()] == [library.name]  # no partial copies


def test_the_cache_folder_follows_the_environment(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """$MPC_JIT_CACHE names the folder (made if missing), ``off`` turns the cache off, and
    without it the folder is under $XDG_CACHE_HOME; a folder that cannot be made is no
    cache rather than an error."""
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "a" / "b"))
    assert cache_folder() == tmp_path / "a" / "b" and (tmp_path / "a" / "b").is_dir()
    monkeypatch.setenv(CACHE_VARIABLE, " OFF ")
    assert cache_folder() is None
    monkeypatch.delenv(CACHE_VARIABLE)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_folder() == tmp_path / "xdg" / "holonomic-mpc" / "jit"
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv(CACHE_VARIABLE, str(blocker / "below"))
    assert cache_folder() is None


@needs_compiler
def test_without_a_cache_the_function_still_compiles(monkeypatch: pytest.MonkeyPatch) -> None:
    """``MPC_JIT_CACHE=off``: compiled as before, nothing kept."""
    monkeypatch.setenv(CACHE_VARIABLE, "off")
    function = _function(5.0)
    np.testing.assert_array_equal(np.asarray(jitted(function)(_point())),
                                  np.asarray(function(_point())))


def test_the_key_names_the_compiler_and_casadi(monkeypatch: pytest.MonkeyPatch) -> None:
    """Libraries of another compiler or another CasADi release are other entries (the
    compiler named by $CC that cannot run still fails, cache or not)."""
    function = _function()
    keys = {jit._key(function, None), jit._key(function, "clang"),
            jit._key(_function(3.0), None)}
    monkeypatch.setattr(ca.CasadiMeta, "version", staticmethod(lambda: "0.0.0"))
    keys.add(jit._key(function, None))
    assert len(keys) == 4
