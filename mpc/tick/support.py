"""Which controllers the compiled tick covers (this slice of issue 37), checked once."""

from __future__ import annotations

from mpc.errors import ControllerError
from mpc.robots.base import Robot, ScalarWheels
from mpc.robots.wheels.constant_jacobian import ConstantJacobianRobot
from mpc.tick.motors import motor_wheels

#: What the compiled tick supports, for the error that refuses the rest.
SUPPORTED = ("constant-Jacobian robots (Swedish, Mecanum, omni, ball wheels) with no failed "
             "wheel, with or without a motor model, solver='daqp', mode='time', "
             "delay_ticks=0, command_ramp=False, time_limit=0")


class UnsupportedTickError(ControllerError):
    """A controller the compiled tick does not cover yet (the message says what it does)."""


def check_supported(robot: Robot, solver: str, mode: str, delay_ticks: int,
                    command_ramp: bool, time_limit: float) -> ScalarWheels:
    """The robot's wheels as the tick's graphs take them, or UnsupportedTickError naming
    what is supported."""
    problems = []
    # a motor model leaves scalar_wheels None (its clamp runs on arrays): mpc.tick.motors
    motors = (robot.dynamics is not None and isinstance(robot, ConstantJacobianRobot)
              and robot.wheel_dim == 1 and robot.rest_projector is None)
    if not isinstance(robot, ConstantJacobianRobot) or (robot.scalar_wheels is None
                                                        and not motors):
        steered = (" (motor-aware steered wheels: not covered)"
                   if robot.dynamics is not None and robot.wheel_dim != 1 else "")
        problems.append(f"robot {robot.name!r} ({robot.kind}){steered}")
    if solver != "daqp":
        problems.append(f"solver={solver!r}")
    if mode != "time":
        problems.append(f"mode={mode!r}")
    if delay_ticks:
        problems.append(f"delay_ticks={delay_ticks}")
    if command_ramp:
        problems.append("command_ramp=True")
    if time_limit > 0.0:
        problems.append(f"time_limit={time_limit:g}")
    if problems:
        raise UnsupportedTickError(
            f"compiled tick: {', '.join(problems)} not supported yet; it supports {SUPPORTED}")
    if motors:
        return motor_wheels(robot)
    assert robot.scalar_wheels is not None
    return robot.scalar_wheels
