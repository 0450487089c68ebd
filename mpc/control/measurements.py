"""What :meth:`~mpc.control.Controller.step` receives each tick, checked at the boundary:
the measured pose, the time, and the measured steer angles of robots whose angles are states.
"""

from __future__ import annotations

import math

from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import ControllerError
from mpc.plausibility import check_heading
from mpc.robots.base import Robot
from mpc.robots.wheels.caster.checks import joint_vector
from mpc.validation import MAX_COORDINATE, MAX_TIME, is_finite_number, real_array, shown


def check_pose(pose: ArrayLike, allow_unusual: bool = False) -> FloatArray:
    """The measured pose (x, y, theta) [m, m, rad] as a float array (3,): finite, within
    ``MAX_COORDINATE``, and its heading within 10,000 turns unless ``allow_unusual``
    (:func:`~mpc.plausibility.check_heading`)."""
    x0 = real_array("pose", pose, "3 numbers (x, y, theta)", ControllerError)
    if x0.shape != (3,):
        raise ControllerError(f"pose must have shape (3,) as (x, y, theta), got shape {x0.shape}")
    if not (math.isfinite(x0[0]) and math.isfinite(x0[1]) and math.isfinite(x0[2])):
        raise ControllerError(f"pose must be finite, got {x0.tolist()}")
    if not (abs(x0[0]) <= MAX_COORDINATE and abs(x0[1]) <= MAX_COORDINATE
            and abs(x0[2]) <= MAX_COORDINATE):
        raise ControllerError(f"pose must lie within +-{MAX_COORDINATE:g} (m, m, rad), "
                              f"got {x0.tolist()}")
    check_heading("pose", float(x0[2]), None, allow_unusual, ControllerError)
    return x0


def check_time(t: object) -> float:
    """``t`` [s] as a float, finite and within ``+-MAX_TIME``."""
    if not is_finite_number(t) or abs(t) > MAX_TIME:  # type: ignore[arg-type]
        raise ControllerError(f"t must be a finite time in seconds within +-{MAX_TIME:g}, "
                              f"got {shown(t)}")
    return float(t)  # type: ignore[arg-type]


def check_steer_angles(robot: Robot, steer_angles: ArrayLike | None) -> FloatArray | None:
    """The measured steer angles of a robot whose angles are states (required), else None."""
    if not robot.steer_states:
        if steer_angles is not None:
            raise ControllerError(
                f"steer_angles is for robots whose steer angles are states (casters); robot "
                f"{robot.name!r} ({robot.kind}) follows its own commanded angles: pass None")
        return None
    n = robot.n_wheels
    if steer_angles is None:
        raise ControllerError(f"robot {robot.name!r} ({robot.kind}) needs the measured steer "
                              f"angles each tick: step(pose, t, steer_angles=<{n} angles [rad]>)")
    angles = joint_vector("steer_angles", steer_angles, n, "[rad]", ControllerError).copy()
    return angles
