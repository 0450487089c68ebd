"""Which controllers the compiled tick covers (this slice of issue 37), checked once."""

from __future__ import annotations

from mpc.errors import ControllerError
from mpc.robots.base import Robot, ScalarWheels
from mpc.robots.wheels.constant_jacobian import ConstantJacobianRobot

#: What the compiled tick supports, for the error that refuses the rest.
SUPPORTED = ("constant-Jacobian robots (Swedish, Mecanum, omni, ball wheels) with no failed "
             "wheel and no motor model, solver='daqp', mode='time' or 'path', delay_ticks=0, "
             "command_ramp=False, time_limit=0")


class UnsupportedTickError(ControllerError):
    """A controller the compiled tick does not cover yet (the message says what it does)."""


def check_supported(robot: Robot, solver: str, mode: str, delay_ticks: int,
                    command_ramp: bool, time_limit: float) -> ScalarWheels:
    """The robot's wheels as the tick's graphs take them, or UnsupportedTickError naming
    what is supported."""
    problems = []
    if not isinstance(robot, ConstantJacobianRobot) or robot.scalar_wheels is None:
        problems.append(f"robot {robot.name!r} ({robot.kind})")
    if solver != "daqp":
        problems.append(f"solver={solver!r}")
    if mode not in ("time", "path"):
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
    assert robot.scalar_wheels is not None
    return robot.scalar_wheels
