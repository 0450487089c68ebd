"""Wheel types by name: how a robot description (a TOML file, a dict) becomes a robot.

Each wheel-type module registers its factories here (``register("swerve", swerve)``);
:func:`~mpc.robots.description.files.from_dict` looks them up. A factory takes keyword
arguments only, ``name`` among them; its other parameters are the keys a
description may hold, and those without a default are required.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

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


#: Builders of a robot from a wheel set of one of the mobility analysis's wheel kinds
#: (:mod:`mpc.robots.description.wheel_set`), registered by the wheel type that drives those wheels.
_WHEEL_SETS: dict[str, Callable[..., Robot]] = {}


def register_wheel_set(kinds: tuple[str, ...], builder: Callable[..., Robot]) -> None:
    """Make wheel sets of ``kinds`` (mobility wheel types: ``"caster"``, ``"steered"``, ...)
    robots of ``builder``, called as ``builder(specs, *, wheel_radius, max_wheel_speed,
    max_steer_rate, max_wheel_accel, name)`` with the wheels' ``WheelSpec`` list. The wheel
    set checks plausibility (:mod:`mpc.plausibility`) under its own names, so a builder
    calls its factory with ``allow_unusual=True``."""
    for kind in kinds:
        _WHEEL_SETS[kind] = builder


def wheel_set_builder(kind: str, source: str) -> Callable[..., Robot]:
    """The builder registered for wheel kind ``kind``, or RobotError naming the kinds that
    have one."""
    if kind not in _WHEEL_SETS:
        raise RobotError(f"{source}: no robot type drives {kind!r} wheels; wheel sets of "
                         f"{sorted(_WHEEL_SETS)} become robots")
    return _WHEEL_SETS[kind]


def steer_rate(kind: str, max_steer_rate: float | None) -> float:
    """A wheel set's ``max_steer_rate`` [rad/s], required for steered ``kind`` wheels."""
    if max_steer_rate is None:
        raise RobotError(f"wheels: {kind} wheels need max_steer_rate [rad/s]")
    return max_steer_rate


#: Random robot descriptions by name, for Monte-Carlo sweeps (``mpc-bench sweep --kinds``):
#: each takes a seeded generator and returns a description for
#: :func:`~mpc.robots.description.files.from_dict` without ``max_wheel_accel`` and ``name``.
_SAMPLERS: dict[str, Callable[[np.random.Generator], dict[str, Any]]] = {}


def register_sampler(name: str,
                     sampler: Callable[[np.random.Generator], dict[str, Any]]) -> None:
    """Make ``name`` a robot kind Monte-Carlo sweeps can draw, from ``sampler``."""
    _SAMPLERS[name] = sampler


def robot_samplers() -> dict[str, Callable[[np.random.Generator], dict[str, Any]]]:
    """Every registered sampler by name, in the order registered."""
    return dict(_SAMPLERS)
