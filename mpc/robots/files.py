"""Robots from TOML files, and the shipped presets.

A robot file has a ``type`` and the keyword arguments of its factory::

    type = "mecanum"            # omni | mecanum | swerve | swedish
    name = "my-chassis"         # optional
    wheelbase = 0.30            # [m]
    track = 0.25                # [m]
    wheel_radius = 0.05         # [m]
    max_wheel_speed = 20.0      # [rad/s]
    max_wheel_accel = 40.0      # [rad/s^2], optional

``type = "swedish"`` takes ``[[wheels]]`` tables with the fields of
:class:`~mpc.robots.swedish.SwedishWheel`. Unknown keys are an error.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from mpc.errors import RobotError
from mpc.robots.base import Robot
from mpc.robots.swedish import SwedishRobot, SwedishWheel, mecanum, omni
from mpc.robots.swerve import swerve

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: Names of the shipped presets, usable with :func:`preset`.
PRESETS: tuple[str, ...] = ("omni3", "omni4", "mecanum", "swerve")


def _swedish(*, name: str, wheels: list[Mapping[str, Any]]) -> SwedishRobot:
    allowed = {"alpha", "beta", "gamma", "l", "radius", "max_speed", "max_accel"}
    built = []
    for index, table in enumerate(wheels):
        if not isinstance(table, Mapping):
            raise RobotError(f"wheels[{index}] must be a table, got {table!r}")
        _check_keys(table, allowed, f"wheels[{index}]")
        try:
            built.append(SwedishWheel(**table))
        except TypeError as error:
            raise RobotError(f"wheels[{index}]: {error}") from None
    return SwedishRobot(name=name, wheels=tuple(built))


_FACTORIES: dict[str, Callable[..., Robot]] = {
    "omni": omni,
    "mecanum": mecanum,
    "swerve": swerve,
    "swedish": _swedish,
}

_KEYS: dict[str, set[str]] = {
    "omni": {"n_wheels", "base_radius", "wheel_radius", "max_wheel_speed",
             "first_wheel_angle", "max_wheel_accel"},
    "mecanum": {"wheelbase", "track", "wheel_radius", "max_wheel_speed", "max_wheel_accel"},
    "swerve": {"module_positions", "wheel_radius", "max_wheel_speed", "max_steer_rate",
               "max_wheel_accel"},
    "swedish": {"wheels"},
}


def _check_keys(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise RobotError(
            f"{where}: unknown key(s) {unknown}; expected some of {sorted(allowed)}"
        )


def from_dict(description: Mapping[str, Any], source: str = "robot description") -> Robot:
    """Build a robot from a parsed description (the contents of a TOML file)."""
    kind = description.get("type")
    if kind not in _FACTORIES:
        raise RobotError(f"{source}: type must be one of {sorted(_FACTORIES)}, got {kind!r}")
    params = {k: v for k, v in description.items() if k not in ("type", "name")}
    _check_keys(params, _KEYS[kind], source)
    name = str(description.get("name", kind))
    try:
        return _FACTORIES[kind](name=name, **params)
    except TypeError as error:  # a missing required key
        raise RobotError(f"{source}: {error}") from None


def load(path: str | Path) -> Robot:
    """Load a robot from a TOML file (see the module docstring for the keys)."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as error:
        raise RobotError(f"cannot read robot file {str(file)!r}: {error.strerror}") from None
    try:
        description = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise RobotError(f"robot file {str(file)!r} is not valid TOML: {error}") from None
    return from_dict(description, source=f"robot file {str(file)!r}")


def preset(name: str) -> Robot:
    """A shipped robot by name, one of :data:`PRESETS`."""
    if name not in PRESETS:
        raise RobotError(f"unknown robot preset {name!r}; expected one of {list(PRESETS)}")
    folder = resources.files("mpc.robots").joinpath("presets")
    text = folder.joinpath(f"{name}.toml").read_text("utf-8")
    return from_dict(tomllib.loads(text), source=f"preset {name!r}")
