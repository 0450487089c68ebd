"""WPILib / robotpy adapter: WPILib types in and out of the MPC (optional extra ``wpilib``).

Needs ``robotpy-wpimath`` (``pip install 'holonomic-mpc[wpilib]'``); the core library
never imports this module. It converts ``Pose2d``, ``ChassisSpeeds`` (robot-relative, as
our twist), ``SwerveModuleState`` and ``MecanumDriveWheelSpeeds``; builds robots from
WPILib kinematics objects; follows a reference with :class:`MpcFollower`
(PathPlanner's shape: ``reset(pose, speeds)``, then ``calculate(pose, t)`` each loop);
and turns a WPILib ``Trajectory`` into a reference that reproduces its ``sample(t)``.

Read before wiring it into a robot:

- **Units.** Our wheel speeds are wheel *angular* speeds [rad/s]; WPILib's module and
  wheel speeds are rim speeds [m/s]. The helpers here multiply by the wheel radius;
  ``max_wheel_speed`` arguments stay in rad/s (attainable rim speed [m/s] / radius [m]).
- **Time base.** ``Controller.step(pose, t)`` wants ``t`` in seconds since the
  reference's start (0 for the built-in shapes); WPILib's clocks are FPGA timestamps
  (``Timer.getFPGATimestamp()``, seconds since boot) or a ``Timer`` you reset, and
  passing one straight to ``step`` tracks an arbitrary point of the reference.
  :class:`MpcFollower` converts: reference time = ``start_time + (t - t_reset)``, with
  ``t_reset`` the ``timestamp`` given to :meth:`MpcFollower.reset` or, without one,
  the first ``t`` given to :meth:`MpcFollower.calculate`.
- **No ``ChassisSpeeds.discretize``.** WPILib's swerve templates discretize the desired
  speeds to correct the skew of a twist held over a loop period. Our twist already is
  the exact constant twist over the tick (the plan's model is the SE(2) exponential);
  discretizing it again would double-correct. Send the speeds as they come.
- **Desaturation.** Commands are already within every wheel's limit, so WPILib's
  ``desaturateWheelSpeeds`` is not needed (it would leave them as they are).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeGuard

import numpy as np
from numpy.typing import ArrayLike
from wpimath.geometry import Pose2d, Rotation2d, Translation2d
from wpimath.kinematics import ChassisSpeeds, MecanumDriveWheelSpeeds, SwerveModuleState
from wpimath.trajectory import Trajectory as WpilibTrajectory

from mpc.arrays import FloatArray, IntArray
from mpc.control import Command, Controller
from mpc.errors import ControllerError, RobotError, TrajectoryError
from mpc.robots import Robot, SwedishRobot, SwedishWheel, SwerveRobot, swerve
from mpc.validation import finite
from trajectories import HeadingDerivatives, HeadingProfile, HeadingSpec, Trajectory
from trajectories.path import PathDerivatives

# ---------------------------------------------------------------- conversions


def pose_from_pose2d(pose: Pose2d) -> FloatArray:
    """``(x, y, theta)`` [m, m, rad] of a ``Pose2d``; theta as its ``Rotation2d`` holds it
    (odometry's are in (-pi, pi]; the controller matches any turn count to the reference)."""
    if not isinstance(pose, Pose2d):
        raise ControllerError(f"pose must be a wpimath.geometry.Pose2d, got {pose!r}")
    return np.array([pose.X(), pose.Y(), pose.rotation().radians()])


def pose2d_from_pose(pose: ArrayLike) -> Pose2d:
    """A ``Pose2d`` from ``(x, y, theta)`` [m, m, rad]."""
    x, y, theta = _three("pose", pose, "(x, y, theta)")
    return Pose2d(x, y, Rotation2d(theta))


def twist_from_chassis_speeds(speeds: ChassisSpeeds) -> FloatArray:
    """Robot-relative ``ChassisSpeeds`` as our body twist ``(vx, vy, omega)`` [m/s, m/s, rad/s]."""
    if not isinstance(speeds, ChassisSpeeds):
        raise ControllerError(f"speeds must be a wpimath ChassisSpeeds, got {speeds!r}")
    return np.array([speeds.vx, speeds.vy, speeds.omega])


def chassis_speeds_from_twist(twist: ArrayLike) -> ChassisSpeeds:
    """Robot-relative ``ChassisSpeeds`` from a body twist ``(vx, vy, omega)``."""
    return ChassisSpeeds(*_three("twist", twist, "(vx, vy, omega)"))


def swerve_module_states(robot: Robot, command: Command) -> list[SwerveModuleState]:
    """A swerve command as ``SwerveModuleState`` s: signed rim speed [m/s] (wheel speed times
    the wheel radius) and steer angle, in the robot's module order, after our flip rule."""
    if not isinstance(robot, SwerveRobot) or command.steer_angles is None:
        raise RobotError(f"module states need a swerve robot and its command, got {robot!r}")
    rim = np.asarray(command.wheel_speeds) * robot.wheel_radius
    return [SwerveModuleState(float(speed), Rotation2d(float(angle)))
            for speed, angle in zip(rim, command.steer_angles, strict=True)]


def mecanum_wheel_speeds(robot: Robot, command: Command) -> MecanumDriveWheelSpeeds:
    """A Mecanum command as ``MecanumDriveWheelSpeeds`` [m/s] (wheel speed times radius);
    our order FL, FR, RL, RR is WPILib's frontLeft, frontRight, rearLeft, rearRight."""
    if not _is_mecanum(robot):
        raise RobotError(f"wheel speeds need a four-wheel Mecanum robot, got {robot!r}")
    radii = np.array([wheel.radius for wheel in robot.wheels])
    return MecanumDriveWheelSpeeds(*(float(v) for v in np.asarray(command.wheel_speeds) * radii))


def _three(name: str, value: ArrayLike, what: str) -> tuple[float, float, float]:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ControllerError(f"{name} must be 3 numbers {what}, got {value!r}") from None
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise ControllerError(f"{name} must be 3 finite numbers {what}, got {value!r}")
    return float(array[0]), float(array[1]), float(array[2])


def _is_mecanum(robot: Robot) -> TypeGuard[SwedishRobot]:
    """Four Swedish wheels with rollers at -45, +45, +45, -45 deg: FL, FR, RL, RR as ours."""
    pattern = (-math.pi / 4, math.pi / 4, math.pi / 4, -math.pi / 4)
    return (isinstance(robot, SwedishRobot) and robot.n_wheels == 4
            and all(math.isclose(w.gamma, g) for w, g in zip(robot.wheels, pattern, strict=True)))


# ---------------------------------------------------------------- robots from kinematics


def _positions(source: Any, count: int | None, what: str) -> FloatArray:
    """Module or wheel centres (n, 2) [m] of a WPILib kinematics object or of a sequence of
    ``Translation2d`` or (x, y) pairs."""
    if hasattr(source, "getModules"):  # SwerveDrive{2,3,4,6}Kinematics
        items: Sequence[Any] = source.getModules()
    elif hasattr(source, "getFrontLeft"):  # MecanumDriveKinematics
        items = (source.getFrontLeft(), source.getFrontRight(), source.getRearLeft(),
                 source.getRearRight())
    else:
        items = source
    try:
        rows = [(p.X(), p.Y()) if isinstance(p, Translation2d) else p for p in items]
        positions = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        raise RobotError(f"{what} must be a WPILib kinematics object or a sequence of "
                         f"Translation2d or (x, y) pairs [m], got {source!r}") from None
    if positions.ndim != 2 or positions.shape[1] != 2 or (count and len(positions) != count):
        raise RobotError(f"{what}: expected {count or 'n'} positions (x, y) [m], got shape "
                         f"{positions.shape}")
    return positions


def robot_from_swerve_kinematics(kinematics_or_translations: Any, *, wheel_radius: float,
                                 max_wheel_speed: float, max_steer_rate: float,
                                 max_wheel_accel: float | None = None,
                                 name: str = "swerve") -> SwerveRobot:
    """Our :func:`~mpc.robots.swerve` robot with the modules of a WPILib
    ``SwerveDrive{2,3,4,6}Kinematics`` (or their ``Translation2d`` s), in the same order.

    Args:
        wheel_radius: [m]. max_wheel_speed: [rad/s] (rim speed limit [m/s] / radius).
        max_steer_rate: [rad/s]. max_wheel_accel: [rad/s^2] or None.
    """
    positions = _positions(kinematics_or_translations, None, "swerve kinematics")
    return swerve(module_positions=positions, wheel_radius=wheel_radius,
                  max_wheel_speed=max_wheel_speed, max_steer_rate=max_steer_rate,
                  max_wheel_accel=max_wheel_accel, name=name)


def robot_from_mecanum_kinematics(kinematics_or_translations: Any, *, wheel_radius: float,
                                  max_wheel_speed: float, max_wheel_accel: float | None = None,
                                  name: str = "mecanum") -> SwedishRobot:
    """A Mecanum robot (wheels FL, FR, RL, RR) with the wheel positions of a WPILib
    ``MecanumDriveKinematics`` (or four ``Translation2d`` s in that order).

    Each wheel is Siegwart's Swedish wheel at its position with rollers at -45 deg (FL, RR)
    or +45 deg (FR, RL), which is WPILib's inverse kinematics for any positions
    (``r phidot_FL = vx - vy - (x + y) omega``, ``r phidot_FR = vx + vy + (x - y) omega``,
    ...). For the rectangle ``(+-a, +-b)`` the wheels are exactly those of
    ``mecanum(wheelbase=2a, track=2b, ...)``. Units as :func:`robot_from_swerve_kinematics`.
    """
    positions = _positions(kinematics_or_translations, 4, "Mecanum kinematics")
    quarter = math.pi / 4.0
    wheels = []
    for (x, y), gamma in zip(positions, (-quarter, quarter, quarter, -quarter), strict=True):
        alpha = math.atan2(y, x)
        wheels.append(SwedishWheel(alpha=alpha, beta=math.pi / 2.0 - alpha, gamma=gamma,
                                   l=math.hypot(x, y), radius=wheel_radius,
                                   max_speed=max_wheel_speed, max_accel=max_wheel_accel))
    return SwedishRobot(tuple(wheels), name=name)


# ---------------------------------------------------------------- follower


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
        horizon: MPC steps planned ahead (default 25: 0.5 s at 20 ms).
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

    def wheel_speeds(self) -> MecanumDriveWheelSpeeds:
        """The last command as Mecanum wheel speeds [m/s] (see :func:`mecanum_wheel_speeds`)."""
        return mecanum_wheel_speeds(self.controller.robot, self.last_command)


# ---------------------------------------------------------------- WPILib trajectories


class WpilibReference(Trajectory):
    """A WPILib ``Trajectory`` as our reference, reproducing its ``sample(t)`` exactly.

    Between states k and k+1 WPILib moves the distance ``s = v_k tau + a_k tau^2 / 2``
    (negated when reversing) and places the pose at the fraction ``f = s / chord_k`` of
    the straight step from pose k to pose k+1 (heading by the shortest turn). This is
    that curve; its velocity and acceleration are its exact time derivatives (jerk 0).
    WPILib's trajectories are for robots that face their direction of travel, so the
    heading is the poses' rotation unless ``heading`` (a heading spec, e.g. ``0.0``) says.
    Times are WPILib's: seconds since the trajectory's start. A step without translation
    holds its first pose (WPILib's ``sample`` divides by its zero length there).
    """

    def __init__(self, trajectory: WpilibTrajectory, heading: HeadingSpec | None = None) -> None:
        states = trajectory.states() if isinstance(trajectory, WpilibTrajectory) else []
        if len(states) < 2:
            raise TrajectoryError("expected a wpimath.trajectory.Trajectory with at least 2 "
                                  f"states, got {trajectory!r}")
        self._times = np.array([s.t for s in states])
        if np.any(np.diff(self._times) < 0.0):
            raise TrajectoryError("WPILib trajectory state times must not decrease")
        poses = np.array([pose_from_pose2d(s.pose) for s in states])
        poses[:, 2] = np.unwrap(poses[:, 2])
        self._poses = poses
        self._steps = np.diff(poses, axis=0)  # (n-1, 3): straight steps, shortest turns
        chord = np.hypot(self._steps[:, 0], self._steps[:, 1])
        self._per_metre = np.divide(1.0, chord, out=np.zeros_like(chord), where=chord > 0.0)
        speed, accel = np.array([[s.velocity, s.acceleration] for s in states]).T
        reversing = (speed < 0.0) | ((np.abs(speed) < 1e-9) & (accel < 0.0))
        sign = np.where(reversing, -1.0, 1.0)
        self._speed, self._accel = (sign * speed)[:-1], (sign * accel)[:-1]
        self._short = np.diff(self._times) < 1e-9  # WPILib returns the later state there
        super().__init__(_PoseHeading(self._pose_heading) if heading is None else heading)

    @property
    def start_time(self) -> float:
        return float(self._times[0])

    @property
    def end_time(self) -> float:
        return float(self._times[-1])

    def _fractions(self, t: FloatArray) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
        """(segment k, fraction f, df/dt [1/s], d2f/dt2 [1/s^2]) at times ``t`` in the span."""
        k = np.clip(np.searchsorted(self._times[1:], t, side="left"), 0, len(self._steps) - 1)
        tau = t - self._times[k]
        per_metre = np.where(self._short[k], 0.0, self._per_metre[k])
        f = (self._speed[k] * tau + 0.5 * self._accel[k] * tau * tau) * per_metre
        rate = (self._speed[k] + self._accel[k] * tau) * per_metre
        return k, np.where(self._short[k], 1.0, f), rate, self._accel[k] * per_metre

    def _path(self, t: FloatArray) -> PathDerivatives:
        k, f, rate, accel = self._fractions(t)
        step = self._steps[k, :2]
        return PathDerivatives(self._poses[k, :2] + f[..., None] * step, rate[..., None] * step,
                               accel[..., None] * step, np.zeros(step.shape))

    def _pose_heading(self, t: FloatArray) -> HeadingDerivatives:
        k, f, rate, accel = self._fractions(t)
        turn = self._steps[k, 2]
        return HeadingDerivatives(self._poses[k, 2] + f * turn, rate * turn, accel * turn)


@dataclass(frozen=True)
class _PoseHeading(HeadingProfile):
    """theta from the WPILib states' rotations, interpolated as WPILib does."""

    at: Callable[[FloatArray], HeadingDerivatives]

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        return self.at(t)


def reference_from_wpilib_trajectory(trajectory: WpilibTrajectory,
                                     heading: HeadingSpec | None = None) -> WpilibReference:
    """Our reference for a WPILib ``Trajectory`` (see :class:`WpilibReference`)."""
    return WpilibReference(trajectory, heading)
