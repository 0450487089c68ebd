"""Robots from a wheel-set description (``type = "wheels"``), refused unless omnidirectional.

A robot file may list its wheels by the types of the mobility analysis
(:mod:`mpc.robots.description.mobility`: ``fixed``, ``steered``, ``caster``, ``swedish``,
``spherical``, ``axle_offset``; positions ``x``, ``y`` [m] in the body frame) with the
limits shared by every wheel::

    type = "wheels"
    wheel_radius = 0.088        # [m]
    max_wheel_speed = 15.0      # [rad/s]
    max_steer_rate = 8.0        # [rad/s], steered, caster and axle-offset wheels
    [[wheels]]
    type = "caster"
    x = 0.24
    y = 0.19
    offset = 0.045              # [m]
    ...

Loading first runs the mobility analysis: a wheel set whose manoeuvrability
``dm + ds`` is below 3 (a differential drive, a car, anything with a fixed wheel's
sliding constraint) cannot follow an arbitrary pose trajectory and is refused with a
one-line error naming its degree of mobility and degree of steerability. An
omnidirectional set of one wheel type becomes the robot of the wheel type registered for
it (:func:`~mpc.robots.description.registry.register_wheel_set`): casters a
:class:`~mpc.robots.wheels.caster.robot.CasterRobot`, steered or axle-offset modules a
:class:`~mpc.robots.wheels.swerve.robot.SwerveRobot` (one lever for every module), balls a
:class:`~mpc.robots.wheels.spherical.SphericalRobot`, Swedish wheels a
:class:`~mpc.robots.wheels.swedish.SwedishRobot` (``heading`` the rolling direction,
``gamma`` the roller angle).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from mpc.errors import RobotError
from mpc.plausibility import (
    OFFSET,
    SIZE,
    STEER_RATE,
    WHEEL_ACCEL,
    WHEEL_RADIUS,
    WHEEL_SPEED,
    check_plausible,
)
from mpc.robots.base import Robot
from mpc.robots.description.mobility import parse_wheels, require_omnidirectional
from mpc.robots.description.registry import register, wheel_set_builder


def wheel_set(
    *,
    wheels: Sequence[Any],
    wheel_radius: float,
    max_wheel_speed: float,
    max_steer_rate: float | None = None,
    max_wheel_accel: float | None = None,
    name: str = "wheels",
    allow_unusual: bool = False,
) -> Robot:
    """A robot from wheel tables of the mobility analysis's types (module docstring).

    Raises RobotError naming (degree of mobility, degree of steerability) if the set
    cannot follow an arbitrary pose trajectory, or if it mixes wheel types; and, unless
    ``allow_unusual``, for sizes and limits beyond any real robot's
    (:mod:`mpc.plausibility`), naming the likely unit mistake.
    """
    robot = _build(wheels, wheel_radius, max_wheel_speed, max_steer_rate, max_wheel_accel,
                   name)
    specs = parse_wheels({"wheels": wheels}, "wheels")
    check_plausible({
        "wheels": (SIZE, [[spec.x, spec.y] for spec in specs]),
        "wheel_radius": (WHEEL_RADIUS, wheel_radius),
        **{f"wheels[{i}].offset": (OFFSET, spec.offset) for i, spec in enumerate(specs)},
        **{f"wheels[{i}].lever": (OFFSET, spec.lever) for i, spec in enumerate(specs)},
        "max_wheel_speed": (WHEEL_SPEED, max_wheel_speed),
        "max_wheel_accel": (WHEEL_ACCEL, max_wheel_accel),
        "max_steer_rate": (STEER_RATE, max_steer_rate)}, allow_unusual)
    return robot


def _build(wheels: Sequence[Any], wheel_radius: float, max_wheel_speed: float,
           max_steer_rate: float | None, max_wheel_accel: float | None, name: str) -> Robot:
    """The robot of :func:`wheel_set`, its plausibility not yet checked (its factories are
    called with ``allow_unusual=True``: the wheel set checks under its own names)."""
    description = {"wheels": wheels}
    require_omnidirectional(description, "wheels")
    specs = parse_wheels(description, "wheels")
    kinds = sorted({spec.kind for spec in specs})
    if len(kinds) != 1:
        raise RobotError(f"wheels: one wheel type per robot is supported, got {kinds}")
    builder = wheel_set_builder(kinds[0], "wheels")
    return builder(specs, wheel_radius=wheel_radius, max_wheel_speed=max_wheel_speed,
                   max_steer_rate=max_steer_rate, max_wheel_accel=max_wheel_accel, name=name)


register("wheels", wheel_set)
