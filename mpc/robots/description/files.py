"""Robots from descriptions (TOML files, dicts) through the wheel-type registry, and presets.

A robot file has a ``type`` (a registered wheel type) and the keyword
arguments of its factory::

    type = "mecanum"            # omni | mecanum | swerve | swedish | any registered type
    name = "my-chassis"         # optional
    wheelbase = 0.30            # [m]
    track = 0.25                # [m]
    wheel_radius = 0.05         # [m]
    max_wheel_speed = 20.0      # [rad/s]
    max_wheel_accel = 40.0      # [rad/s^2], optional

``type = "swedish"`` takes ``[[wheels]]`` tables with the fields of
:class:`~mpc.robots.wheels.swedish.SwedishWheel`; ``type = "caster"`` the arguments of
:func:`~mpc.robots.wheels.caster.robot.caster` (``positions``, ``offset``, ``max_steer_rate``, ...);
``type = "swerve"`` an optional ``axle_offset`` [m]; ``type = "wheels"`` a wheel set by
the mobility analysis's types (:mod:`mpc.robots.description.wheel_set`), refused with a one-line
error naming its degree of mobility and steerability when it cannot follow an arbitrary
pose trajectory. An optional ``[dynamics]`` table describes mass, motors, battery and
traction (:mod:`mpc.robots.drive.dynamics`). Unknown keys are an error.

Sizes and limits beyond any real robot's (a wheelbase over 5 m, a wheel radius over
0.5 m, a wheel speed limit over 1000 rad/s, a mass over 100 t, ...: :mod:`mpc.plausibility`)
raise RobotError naming the likely unit mistake (millimetres, rpm, ...) unless the file
says ``allow_unusual = true`` (top level; it covers ``[dynamics]`` too).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from mpc.errors import RobotError
from mpc.robots.base import Robot
from mpc.robots.description.registry import robot_type
from mpc.robots.drive.dynamics import dynamics_from_dict
from mpc.validation import file_text, parsed, shown

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: Names of the project's layouts, usable with :func:`preset` (every shipped preset is,
#: :func:`shipped_presets`).
PRESETS: tuple[str, ...] = ("omni3", "omni4", "mecanum", "swerve", "ball3", "caster4", "mpo700")
#: The founding documents' robots; each has its source's wheel order, signs and units in
#: :data:`mpc.robots.description.conventions.CONVENTIONS`.
SEED_PRESETS: tuple[str, ...] = ("jetauto", "kosen-mecanum", "kosen-omni4", "swedish3")
_MOTORS = "-motors"  # the suffix of a layout's file with motors (:func:`motor_preset`)


def _presets_folder() -> Any:
    return resources.files("mpc.robots.description").joinpath("presets")


def shipped_presets() -> tuple[str, ...]:
    """Every preset :func:`preset` takes: :data:`PRESETS`, :data:`SEED_PRESETS`, then any
    other file in the presets folder (a new wheel type's), by name."""
    files = sorted(entry.name.removesuffix(".toml") for entry in _presets_folder().iterdir()
                   if entry.name.endswith(".toml") and not entry.name.endswith(
                       f"{_MOTORS}.toml"))
    return PRESETS + SEED_PRESETS + tuple(name for name in files
                                          if name not in PRESETS + SEED_PRESETS)


def from_dict(description: Mapping[str, Any], source: str = "robot description") -> Robot:
    """Build a robot from a parsed description (the contents of a TOML file)."""
    if not isinstance(description, Mapping):
        raise RobotError(f"{source}: expected a table of keys, got {type(description).__name__}")
    entry = robot_type(description.get("type"), source)
    params = {k: v for k, v in description.items() if k not in ("type", "dynamics")}
    unknown = sorted(set(params) - entry.keys - {"name"})
    if unknown:
        raise RobotError(
            f"{source}: unknown key(s) {unknown}; expected some of {sorted(entry.keys)}")
    missing = sorted(entry.required - set(params))
    if missing:
        raise RobotError(f"{source}: missing key(s) {missing} for type {shown(entry.name)}")
    params.setdefault("name", entry.name)
    try:
        robot = entry.factory(**params)
        if "dynamics" in description:
            robot = robot.with_dynamics(dynamics_from_dict(
                description["dynamics"], source, description.get("allow_unusual", False)))
        return robot
    except RobotError as error:
        message = str(error)
        raise RobotError(message if message.startswith(source) else f"{source}: {message}"
                         ) from None


def load(path: str | Path) -> Robot:
    """Load a robot from a TOML file (see the module docstring for the keys)."""
    text = file_text(path, "robot", RobotError)
    file = Path(path)
    description = parsed(tomllib.loads, text, f"robot file {str(file)!r}", "TOML", RobotError)
    return from_dict(description, source=f"robot file {str(file)!r}")


def preset(name: str, **overrides: Any) -> Robot:
    """A shipped robot by name, one of :func:`shipped_presets`; ``overrides`` replace its
    file's top-level keys (``preset("jetauto", max_wheel_speed=2.0 * 2 * math.pi)``: a 2
    rev/s motor limit), checked as a robot file's keys are."""
    names = shipped_presets()
    if name not in names:
        raise RobotError(f"unknown robot preset {name!r}; expected one of {list(names)}")
    text = _presets_folder().joinpath(f"{name}.toml").read_text("utf-8")
    return from_dict({**tomllib.loads(text), **overrides}, source=f"preset {name!r}")


#: Layouts shipped with motors as well (:func:`motor_preset`).
MOTOR_ROBOT_PRESETS: tuple[str, ...] = ("omni3", "omni4", "mecanum", "swerve", "ball3")


def motor_preset(name: str) -> Robot:
    """A shipped robot with motors (``[dynamics]``) by layout name, one of
    :data:`MOTOR_ROBOT_PRESETS`: the same wheel layout as :func:`preset`, with illustrative
    motors, mass and traction; its speed limit is the motors' free speed and it has no
    acceleration limit (the motor rows bound acceleration)."""
    if name not in MOTOR_ROBOT_PRESETS:
        raise RobotError(f"no motor preset {name!r}; expected one of "
                         f"{list(MOTOR_ROBOT_PRESETS)}")
    text = _presets_folder().joinpath(f"{name}{_MOTORS}.toml").read_text("utf-8")
    return from_dict(tomllib.loads(text), source=f"motor preset {name!r}")
