"""Test-session settings: every hypothesis suite runs derandomized (a fixed seed, no example
database), so CI runs the same examples every time and a failure reproduces; compiled
libraries (``jit=True``) are cached in a folder of the session's own."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from hypothesis import settings

from mpc.model.jit import CACHE_VARIABLE

settings.register_profile("fixed", derandomize=True, database=None, deadline=None)
settings.load_profile("fixed")


@pytest.fixture(autouse=True, scope="session")
def _jit_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Libraries that ``jit=True`` compiles go to this session's own cache folder (and to
    the processes it starts), not the user's."""
    previous = os.environ.get(CACHE_VARIABLE)
    os.environ[CACHE_VARIABLE] = str(tmp_path_factory.mktemp("jit-cache"))
    yield
    if previous is None:
        os.environ.pop(CACHE_VARIABLE, None)
    else:
        os.environ[CACHE_VARIABLE] = previous
