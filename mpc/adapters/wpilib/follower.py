""":class:`MpcFollower`: the controller with WPILib types and a clock of its own, shaped
like PathPlanner's ``PathFollowingController`` (the time base is in
:mod:`mpc.adapters.wpilib`'s docstring)."""

from __future__ import annotations

from typing import Any

from wpimath.geometry import Pose2d
from wpimath.kinematics import ChassisSpeeds, MecanumDriveWheelSpeeds, SwerveModuleState

from mpc.adapters.wpilib.conversions import (
    chassis_speeds_from_twist,
    mecanum_wheel_speeds,
    pose_from_pose2d,
    swerve_module_states,
    twist_from_chassis_speeds,
)
from mpc.adapters.wpilib.feedforward import ModuleFeedforwards, module_feedforwards
from mpc.arrays import FloatArray
from mpc.control import Command, Controller
from mpc.errors import ControllerError
from mpc.robots import Robot
from mpc.validation import finite
from trajectories import Trajectory


class MpcFollower:
    """A :class:`~mpc.control.Controller` with WPILib types and a clock of its own.

    Shaped like PathPlanner's ``PathFollowingController``: call :meth:`reset` when the
    path starts (e.g. a command's ``initialize``), then :meth:`calculate` once per loop.
    A new follower behaves as if reset at rest, its clock starting at the first
    :meth:`calculate`.

    Args:
        robot: the drive layout (e.g. from :func:`robot_from_swerve_kinematics`).
        trajectory: the reference (e.g. from :func:`reference_from_wpilib_trajectory`).
        dt: the loop period [s] (``TimedRobot``'s 20 ms by default); also the MPC tick.
        horizon: MPC stages planned ahead (default 25: with the default stages, one tick
            then ``2 dt`` each, 0.98 s at 20 ms).
        **options: further :class:`~mpc.control.Controller` options (``solver``,
            ``weights``, ``delay_ticks``, ``time_scaling``, ...).
    """

    def __init__(self, robot: Robot, trajectory: Trajectory, *, dt: float = 0.02,
                 horizon: int = 25, **options: Any) -> None:
        self.controller = Controller(robot, trajectory, horizon=horizon, dt=dt, **options)
        self._origin: float | None = None
        self._start = trajectory.start_time
        self._command: Command | None = None
        self.reset_pose: FloatArray | None = None

    def reset(self, pose: Pose2d, speeds: ChassisSpeeds, *, timestamp: float | None = None,
              start_time: float | None = None) -> None:
        """Start following from here: forget the plan and restart the clock.

        Args:
            pose: the robot's pose now; kept as :attr:`reset_pose` (the MPC needs no state
                from it: every :meth:`calculate` measures the pose afresh).
            speeds: the robot-relative ``ChassisSpeeds`` it is executing now (the first
                command's acceleration limit counts from them).
            timestamp: the caller's clock now [s] (the ``t`` later passed to
                :meth:`calculate`: FPGA time, a ``Timer``...); None: the first ``t``
                passed to :meth:`calculate` is this moment.
            start_time: the reference's time at this moment [s]; default its start.
        """
        self.reset_pose = pose_from_pose2d(pose)
        self.controller.reset(last_twist=twist_from_chassis_speeds(speeds))
        self._origin = None if timestamp is None else finite("timestamp [s]", timestamp,
                                                              ControllerError)
        self._start = (self.controller.trajectory.start_time if start_time is None
                       else finite("start_time [s]", start_time, ControllerError))
        self._command = None

    def reference_time(self, t: float) -> float:
        """The reference's time [s] at the caller's clock reading ``t`` [s]."""
        clock = finite("t [s]", t, ControllerError)
        return self._start + (clock - (clock if self._origin is None else self._origin))

    def calculate(self, pose: Pose2d, t: float) -> ChassisSpeeds:
        """Robot-relative ``ChassisSpeeds`` to command now (not to be discretized).

        Args:
            pose: the measured pose (odometry or pose estimator), field frame.
            t: the caller's clock [s], on the same base as :meth:`reset`'s ``timestamp``.
        """
        clock = finite("t [s]", t, ControllerError)
        if self._origin is None:
            self._origin = clock
        self._command = self.controller.step(pose_from_pose2d(pose), self.reference_time(clock))
        return chassis_speeds_from_twist(self._command.twist)

    def is_finished(self, t: float) -> bool:
        """Whether the reference time at ``t`` has reached a finite reference's end."""
        end = self.controller.trajectory.end_time
        return end is not None and self.reference_time(t) >= end

    @property
    def last_command(self) -> Command:
        """The full :class:`~mpc.control.Command` of the last :meth:`calculate`."""
        if self._command is None:
            raise ControllerError("no command yet: call calculate(pose, t) first")
        return self._command

    def module_states(self) -> list[SwerveModuleState]:
        """The last command as swerve module states [m/s] (see :func:`swerve_module_states`)."""
        return swerve_module_states(self.controller.robot, self.last_command)

    def feedforwards(self) -> ModuleFeedforwards:
        """The last command's per-module feedforward (see :func:`module_feedforwards`;
        the robot needs dynamics)."""
        return module_feedforwards(self.controller.robot, self.last_command)

    def wheel_speeds(self) -> MecanumDriveWheelSpeeds:
        """The last command as Mecanum wheel speeds [m/s] (see :func:`mecanum_wheel_speeds`)."""
        return mecanum_wheel_speeds(self.controller.robot, self.last_command)
