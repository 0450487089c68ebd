"""Per-module feedforward in the shape WPILib and PathPlanner users feed forward:
robot-relative force x/y per module [N], the force along each wheel [N] and the drive
motor's torque-current [A] (PathPlanner's ``DriveFeedforwards``).

PathPlanner's ``DriveFeedforwards`` fields and ours: ``robotRelativeForcesXNewtons`` /
``robotRelativeForcesYNewtons`` = :attr:`ModuleFeedforwards.forces_x` / ``forces_y``
(the module's whole contact force in the robot frame, drive and lateral: what a team
projects onto the module's measured angle), ``linearForcesNewtons`` =
``linear_forces`` (the part along the wheel as commanded, signed like the module state's
speed after the flip rule), ``torqueCurrentsAmps`` = ``torque_currents`` (each drive
motor's current, wheel inertia included: a TorqueCurrentFOC request's ``Amps``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc.control import Command
from mpc.errors import RobotError
from mpc.robots import Robot
from mpc.validation import shown


@dataclass(frozen=True)
class ModuleFeedforwards:
    """One command's feedforward per module (or Mecanum wheel), in the robot's order.

    Attributes:
        forces_x: robot-relative contact force along x per module [N].
        forces_y: robot-relative contact force along y per module [N].
        linear_forces: the force along each wheel's commanded rolling direction [N].
        torque_currents: each drive motor's current [A] (torque-current control).
    """

    forces_x: list[float]
    forces_y: list[float]
    linear_forces: list[float]
    torque_currents: list[float]


def module_feedforwards(robot: Robot, command: Command) -> ModuleFeedforwards:
    """The feedforward of ``command`` (from a :class:`~mpc.control.Controller` of
    ``robot``, which needs dynamics: :meth:`~mpc.robots.Robot.with_dynamics`) per module:
    see :class:`ModuleFeedforwards`."""
    vectors = command.contact_forces
    if (robot.dynamics is None or vectors is None or command.wheel_forces is None
            or command.motor_currents is None):
        raise RobotError(f"module feedforward needs a robot with dynamics and its command "
                         f"(robot.with_dynamics(...)); got robot {shown(robot.name)} "
                         f"with{'out' if robot.dynamics is None else ''} dynamics")
    forces = np.asarray(vectors, dtype=float)
    if forces.shape != (robot.n_wheels, 2):
        raise RobotError(f"command has {forces.shape[0]} contact forces, robot "
                         f"{robot.name!r} {robot.n_wheels} wheels")
    return ModuleFeedforwards(
        forces_x=[float(f) for f in forces[:, 0]],
        forces_y=[float(f) for f in forces[:, 1]],
        linear_forces=[float(f) for f in np.asarray(command.wheel_forces, dtype=float)],
        torque_currents=[float(i) for i in np.asarray(command.motor_currents, dtype=float)])
