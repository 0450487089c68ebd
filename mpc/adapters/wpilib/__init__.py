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

- **Feedforward.** With dynamics (``robot.with_dynamics(...)``) each command carries
  each module's planned contact force; :func:`module_feedforwards` (or
  :meth:`MpcFollower.feedforwards`) gives it as PathPlanner's ``DriveFeedforwards``
  does: robot-relative force x/y per module [N], the force along the wheel [N] and the
  drive motor's torque-current [A].

The modules: :mod:`.conversions` (types), :mod:`.kinematics` (robots),
:mod:`.feedforward` (per-module feedforward),
:mod:`.follower` (:class:`MpcFollower`), :mod:`.reference` (:class:`WpilibReference`).
"""

from mpc.adapters.wpilib.conversions import (
    chassis_speeds_from_twist,
    mecanum_wheel_speeds,
    pose2d_from_pose,
    pose_from_pose2d,
    swerve_module_states,
    twist_from_chassis_speeds,
)
from mpc.adapters.wpilib.feedforward import ModuleFeedforwards, module_feedforwards
from mpc.adapters.wpilib.follower import MpcFollower
from mpc.adapters.wpilib.kinematics import (
    robot_from_mecanum_kinematics,
    robot_from_swerve_kinematics,
)
from mpc.adapters.wpilib.reference import WpilibReference, reference_from_wpilib_trajectory
from mpc.errors import ControllerError as _Error
from mpc.validation import checked_public as _checked_public

__all__ = ["ModuleFeedforwards", "MpcFollower", "WpilibReference", "chassis_speeds_from_twist",
           "mecanum_wheel_speeds", "module_feedforwards", "pose2d_from_pose", "pose_from_pose2d",
           "reference_from_wpilib_trajectory", "robot_from_mecanum_kinematics",
           "robot_from_swerve_kinematics", "swerve_module_states",
           "twist_from_chassis_speeds"]

# Arguments that do not fit a public callable's signature raise ControllerError, not TypeError.
_checked_public(globals(), _Error)
