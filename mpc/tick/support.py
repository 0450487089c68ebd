"""Which controllers the compiled tick covers (this slice of issue 37), checked once."""

from __future__ import annotations

from mpc.errors import ControllerError
from mpc.robots.base import PlanarModules, Robot, ScalarWheels
from mpc.robots.wheels.caster.robot import CasterRobot
from mpc.robots.wheels.constant_jacobian import ConstantJacobianRobot
from mpc.robots.wheels.swerve.robot import SwerveRobot
from mpc.tick.casters import caster_modules
from mpc.tick.motors import motor_wheels
from mpc.tick.offset import axle_modules

#: What the compiled tick supports, for the error that refuses the rest.
SUPPORTED = ("constant-Jacobian robots (Swedish, Mecanum, omni, ball wheels) with no failed "
             "wheel, with or without a motor model, and swerve robots (axle-offset modules "
             "included, the mpo700 preset) with no steering range, failed module or motor "
             "model, and powered casters (the caster4 preset) with no acceleration limit, "
             "failed caster or motor model; solver='daqp', mode='time' (or "
             "'path' on constant-Jacobian robots with no motor model), delay_ticks=0, "
             "command_ramp=False, time_limit=0")


class UnsupportedTickError(ControllerError):
    """A controller set-up the compiled tick does not cover (:data:`SUPPORTED`)."""


def check_supported(robot: Robot, solver: str, mode: str, delay_ticks: int,
                    command_ramp: bool, time_limit: float,
                    polygon_sides: int | None = None) -> ScalarWheels | PlanarModules:
    """The robot's wheels as the tick's graphs take them (:class:`ScalarWheels`, a
    motor-aware constant-Jacobian robot's as :func:`mpc.tick.motors.motor_wheels` gives
    them, or a swerve robot's :class:`PlanarModules`), or UnsupportedTickError naming what
    is supported."""
    problems = []
    wheels: ScalarWheels | PlanarModules | None = None
    motors = _motor_aware(robot)
    if motors:  # a motor model leaves scalar_wheels None (its clamp runs on arrays)
        wheels = motor_wheels(robot)
    elif isinstance(robot, ConstantJacobianRobot):
        wheels = robot.scalar_wheels
    elif isinstance(robot, SwerveRobot):
        wheels = robot.planar_modules
        if wheels is None and _axle_only(robot):  # (mpc.tick.offset)
            wheels = axle_modules(robot)
    elif isinstance(robot, CasterRobot) and _casters_covered(robot):  # (mpc.tick.casters)
        wheels = caster_modules(robot)
    if wheels is None:
        problems.append(f"robot {robot.name!r} ({robot.kind}{_why(robot)})")
    if solver != "daqp":
        problems.append(f"solver={solver!r}")
    if mode not in ("time", "path"):
        problems.append(f"mode={mode!r}")
    elif mode == "path" and isinstance(robot, SwerveRobot):
        problems.append("mode='path' on a swerve robot")
    elif mode == "path" and isinstance(robot, CasterRobot):
        problems.append("mode='path' on a caster robot")
    elif mode == "path" and motors:
        problems.append("mode='path' on a robot with a motor model")
    if delay_ticks:
        problems.append(f"delay_ticks={delay_ticks}")
    if command_ramp:
        problems.append("command_ramp=True")
    if polygon_sides is not None and isinstance(robot, SwerveRobot):
        problems.append(f"polygon_sides={polygon_sides}")
    if time_limit > 0.0:
        problems.append(f"time_limit={time_limit:g}")
    if problems:
        raise UnsupportedTickError(
            f"compiled tick: {', '.join(problems)} not supported yet; it supports {SUPPORTED}")
    assert wheels is not None
    return wheels


def _motor_aware(robot: Robot) -> bool:
    """A constant-Jacobian robot with a motor model whose wheels do not steer and none
    failed: its motor rows, clamp and feedforward from :mod:`mpc.tick.motors`."""
    return (robot.dynamics is not None and isinstance(robot, ConstantJacobianRobot)
            and robot.wheel_dim == 1 and robot.rest_projector is None)


def _casters_covered(robot: CasterRobot) -> bool:
    """Casters with no acceleration limit, motor model or failed caster."""
    return (robot.max_wheel_accel is None and robot.dynamics is None
            and robot.rest_projector is None)


def _axle_only(robot: SwerveRobot) -> bool:
    """Axle-offset modules and nothing else the compiled tick does not cover."""
    return bool(robot.axle_offset and robot.steer_range is None and robot.dynamics is None
                and robot.rest_projector is None)


def _why(robot: Robot) -> str:
    """What of a swerve robot the compiled tick does not cover, for the refusal."""
    if isinstance(robot, CasterRobot):
        parts = [name for name, present in (
            ("an acceleration limit", robot.max_wheel_accel is not None),
            ("a motor model", robot.dynamics is not None),
            ("a failed caster", robot.rest_projector is not None)) if present]
        return f" with {' and '.join(parts)}" if parts else ""
    if not isinstance(robot, SwerveRobot):
        return ""
    parts = [name for name, present in (
        ("a steering range", robot.steer_range is not None),
        ("a motor model", robot.dynamics is not None),
        ("a failed module", robot.rest_projector is not None)) if present]
    return f" with {' and '.join(parts)}" if parts else ""
