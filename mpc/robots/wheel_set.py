"""Robots from a wheel-set description (``type = "wheels"``), refused unless omnidirectional.

A robot file may list its wheels by the types of the mobility analysis
(:mod:`mpc.robots.mobility`: ``fixed``, ``steered``, ``caster``, ``swedish``,
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
omnidirectional set of one wheel type becomes that robot: casters a
:class:`~mpc.robots.caster.CasterRobot`, steered or axle-offset modules a
:class:`~mpc.robots.swerve.SwerveRobot` (one lever for every module), balls a
:class:`~mpc.robots.spherical.SphericalRobot`, Swedish wheels a
:class:`~mpc.robots.swedish.SwedishRobot` (``heading`` the rolling direction,
``gamma`` the roller angle).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

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
from mpc.robots.caster import caster
from mpc.robots.mobility import WheelSpec, parse_wheels, require_omnidirectional
from mpc.robots.registry import register
from mpc.robots.spherical import spherical
from mpc.robots.swedish import SwedishRobot, SwedishWheel, wheel_limits
from mpc.robots.swerve import swerve


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
    kind = kinds[0]
    positions = [[spec.x, spec.y] for spec in specs]
    if kind in ("caster", "steered", "axle_offset") and max_steer_rate is None:
        raise RobotError(f"wheels: {kind} wheels need max_steer_rate [rad/s]")
    if kind == "caster":
        return caster(positions=positions, offset=[spec.offset or 0.0 for spec in specs],
                      wheel_radius=wheel_radius, max_wheel_speed=max_wheel_speed,
                      max_steer_rate=_given(max_steer_rate), max_wheel_accel=max_wheel_accel,
                      name=name, allow_unusual=True)
    if kind in ("steered", "axle_offset"):
        levers = {spec.lever or 0.0 for spec in specs}
        if len(levers) != 1:
            raise RobotError(f"wheels: every axle_offset module needs the same lever, got "
                             f"{sorted(levers)}")
        return swerve(module_positions=positions, wheel_radius=wheel_radius,
                      max_wheel_speed=max_wheel_speed, max_steer_rate=_given(max_steer_rate),
                      max_wheel_accel=max_wheel_accel, axle_offset=levers.pop(), name=name,
                      allow_unusual=True)
    if kind == "spherical":
        return spherical(positions=positions, wheel_radius=wheel_radius,
                         max_wheel_speed=max_wheel_speed, max_wheel_accel=max_wheel_accel,
                         name=name, allow_unusual=True)
    radius, speed, accel = wheel_limits(wheel_radius, max_wheel_speed, max_wheel_accel)
    return SwedishRobot(name=name, wheels=tuple(
        _swedish(spec, radius, speed, accel) for spec in specs))


def _given(value: float | None) -> float:
    if value is None:  # pragma: no cover - checked by the caller
        raise RobotError("wheels: max_steer_rate [rad/s] is required")
    return value


def _swedish(spec: WheelSpec, radius: float, speed: float, accel: float | None) -> SwedishWheel:
    """Siegwart's parameters of a wheel at (x, y) rolling along ``heading``:
    ``alpha = atan2(y, x)``, ``l = |(x, y)|``, ``beta = heading + pi / 2 - alpha``."""
    alpha = math.atan2(spec.y, spec.x)
    heading = 0.0 if spec.heading is None else spec.heading
    return SwedishWheel(alpha=alpha, beta=heading + math.pi / 2 - alpha,
                        gamma=0.0 if spec.gamma is None else spec.gamma,
                        l=float(np.hypot(spec.x, spec.y)), radius=radius, max_speed=speed,
                        max_accel=accel)


register("wheels", wheel_set)
