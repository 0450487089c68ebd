"""From the clamped twist to what the wheels are told: wheel speeds, swerve steer angles,
caster joint rates held over the tick, and the motors' feedforward fields of a
:class:`~mpc.control.command.Command`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import Robot


def wheel_commands(robot: Robot, twist: FloatArray, target: FloatArray,
                   steer: FloatArray | None, measured: FloatArray | None,
                   planned: FloatArray | None, dt: float, durations: FloatArray,
                   memory: dict[str, FloatArray] | None = None
                   ) -> tuple[FloatArray, FloatArray, FloatArray | None,
                              Callable[[], FloatArray] | None, FloatArray | None]:
    """What the wheels are told for the clamped ``twist``: (the twist they will drive,
    wheel speeds, caster steer rates, what predicts the caster steer angles along the plan
    when called, the steer angles the controller now believes in).

    ``steer`` is the steer angles the controller believed in before this tick,
    ``measured`` the casters' measured angles (None for other robots), ``planned`` the
    plan's twists (N, 3), or None if the solve failed (casters then predict their angles
    holding ``twist``), ``memory`` what the robot's commands keep from tick to tick (the
    controller's; steering ranges keep the speeds sent and the turns under way). The
    prediction is left to whoever reads it
    (:attr:`~mpc.control.command.Command.predicted_steer_angles`): it is not a command,
    and it is a sizeable part of a caster tick (docs/design/caster-steer-prediction.md)."""
    if measured is not None:  # casters: joint rates held over the tick
        speeds, steer_rates = tick_rates(robot, twist, measured, dt)
        if planned is None:
            planned = np.tile(twist, (len(durations), 1))
        predict = functools.partial(robot.predict_steer_angles, measured.copy(), planned,
                                    durations)
        return twist, speeds, steer_rates, predict, measured + steer_rates * dt
    previous = steer
    speeds, steer = robot.planned_wheel_commands(twist, steer, target, dt, planned, durations,
                                                 memory)
    if steer is not None:  # steered wheels at rest: the twist they will drive
        turning = None if previous is None else (
            np.mod(steer - previous + math.pi, 2.0 * math.pi) - math.pi) / dt
        twist = robot.steering_forward_kinematics(speeds, steer, turning)
    return twist, speeds, None, None, steer


def prepare_commands(robot: Robot, dt: float, durations: FloatArray) -> None:
    """Build what :func:`wheel_commands` predicts with for robots whose steer angles are
    measured (casters: the angle flow over a tick, :func:`tick_rates`, and along the plan's
    stage ``durations`` [s]) now, at set-up, so that the first tick is as quick as the rest
    (docs/design/caster-steer-prediction.md)."""
    if not robot.steer_states:
        return
    angles = np.zeros(robot.n_wheels)
    robot.predict_steer_angles(angles, np.zeros((2, 3)), _tick_halves(dt))
    robot.predict_steer_angles(angles, np.zeros((len(durations), 3)), durations)


def _tick_halves(dt: float) -> FloatArray:
    """The grid :func:`tick_rates` predicts the angles on: the tick in two halves [s]."""
    return np.array([0.5 * dt, 0.5 * dt])


def tick_rates(robot: Robot, twist: FloatArray, angles: FloatArray,
               dt: float) -> tuple[FloatArray, FloatArray]:
    """Joint rates to hold over a tick for ``twist``, from the measured steer ``angles``.

    The angles turn during the tick while the motors hold their rates. So the steer rates
    are the ones that end the tick where ``twist`` turns the casters (the model's angle
    flow over ``dt``), and the drive rates the average over the tick of what ``twist``
    asks for along that flow (Simpson's rule): a smaller steady error from model mismatch
    than rates taken at the measured angles (docs/design/caster-steer-prediction.md). A
    rate that ends up past its limit (the clamp kept them within at the measured angles;
    a leading caster's rate grows within the tick) scales them all down together."""
    flow = robot.predict_steer_angles(angles, np.tile(twist, (2, 1)), _tick_halves(dt))
    rows = robot.joint_rows(flow)[0] @ twist  # (3, n): at the start, middle and end
    drive = (rows[0] + 4.0 * rows[1] + rows[2]) / 6.0
    steer = (flow[2] - flow[0]) / dt
    limit_steer = robot.max_steer_rates
    magnitude = np.concatenate([np.abs(drive), np.abs(steer)])
    bound = np.concatenate([robot.max_wheel_speed,
                            limit_steer if limit_steer is not None else np.abs(steer)])
    over = magnitude > bound
    if over.any():
        scale = float((bound[over] / magnitude[over]).min())
        drive, steer = drive * scale, steer * scale
    return drive, steer


def feedforward_fields(values: tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None
                       ) -> dict[str, FloatArray]:
    """``Command``'s motor feedforward fields (none without dynamics)."""
    if values is None:
        return {}
    forces, torques, currents, vectors = values
    return {"wheel_forces": forces, "motor_torques": torques, "motor_currents": currents,
            "contact_forces": vectors}
