"""Wheel types by name: how a robot description (a TOML file, a dict) becomes a robot.

Each wheel-type module registers its factories here (``register("swerve", swerve)``);
:func:`~mpc.robots.files.from_dict` looks them up. A factory takes keyword
arguments only, ``name`` among them; its other parameters are the keys a
description may hold, and those without a default are required.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass

from mpc.errors import RobotError
from mpc.robots.base import Robot


@dataclass(frozen=True)
class RobotType:
    """A registered factory and the description keys it takes."""

    name: str
    factory: Callable[..., Robot]
    keys: frozenset[str]
    required: frozenset[str]


_TYPES: dict[str, RobotType] = {}


def register(name: str, factory: Callable[..., Robot]) -> RobotType:
    """Make ``type = "<name>"`` descriptions build robots with ``factory``.

    Registering a name again replaces the earlier factory.
    """
    if not isinstance(name, str) or not name.isidentifier():
        raise RobotError(f"a robot type name must be an identifier, got {name!r}")
    parameters = inspect.signature(factory).parameters
    keys = {p.name for p in parameters.values() if p.kind is p.KEYWORD_ONLY}
    if "name" not in keys:
        raise RobotError(f"robot factory for {name!r} must take a keyword-only 'name'")
    keys.discard("name")
    required = {p.name for p in parameters.values()
                if p.kind is p.KEYWORD_ONLY and p.default is p.empty and p.name != "name"}
    entry = RobotType(name, factory, frozenset(keys), frozenset(required))
    _TYPES[name] = entry
    return entry


def robot_type(name: object, source: str) -> RobotType:
    """The registered type ``name``, or RobotError listing the known ones."""
    if not isinstance(name, str) or name not in _TYPES:
        raise RobotError(f"{source}: type must be one of {sorted(_TYPES)}, got {name!r}")
    return _TYPES[name]


def robot_types() -> tuple[str, ...]:
    """Names of every registered wheel type."""
    return tuple(sorted(_TYPES))
