"""Test-session settings: every hypothesis suite runs derandomized (a fixed seed, no example
database), so CI runs the same examples every time and a failure reproduces."""

from __future__ import annotations

from hypothesis import settings

settings.register_profile("fixed", derandomize=True, database=None, deadline=None)
settings.load_profile("fixed")
