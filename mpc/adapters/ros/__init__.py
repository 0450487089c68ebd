"""ROS 2 adapter on ``rosbags``' message types (optional extra ``ros``; no ROS install).

Needs ``rosbags`` (``pip install 'holonomic-mpc[ros]'``). Inputs are read by field name,
so rclpy messages work as they are; outputs are ``rosbags`` message dataclasses with the
same fields (:func:`copy_message` copies one into an rclpy message).

- Poses: ``Odometry``, ``PoseStamped``, ``Pose`` -> ``(x, y, yaw)`` (quaternion to yaw).
  Twists: ``Twist`` / ``TwistStamped`` in and out; commands are body twists in
  ``base_link`` (REP-105), stamped with the pose's stamp.
- **Time base.** ROS stamps are seconds since the Unix epoch (~1.7e9); the controller's
  ``t`` is seconds since the reference's start: ``controller.step(pose, 1.7e9)`` on a
  periodic reference (a circle) silently tracks whatever phase 1.7e9 s falls on, and on
  a finite one its end. :class:`ReferenceClock` converts (integer nanoseconds, starting
  at the first stamp it sees unless told).
- **Wheel order.** ros2_controllers' ``mecanum_drive_controller`` orders its wheels FL,
  FR, RR, RL, ours FL, FR, RL, RR (same kinematics otherwise): :func:`to_ros2_mecanum`,
  :func:`from_ros2_mecanum`; :func:`joint_group_command` for a
  ``JointGroupVelocityController`` ([rad/s] in its ``joints`` order).
- **JetAuto's driver** (:mod:`.jetauto`): the command as its motors take it, ids 1-4 in
  revolutions per second, right side negated (:func:`jetauto_motors`, :func:`motors_state`).
- :class:`Nav2Controller`, shaped like a nav2 controller plugin: ``set_plan(path)``
  (timed by the time-optimal retimer or at a constant speed; a grid planner's path not
  smoothed upstream: ``position_tolerance=``, ``yaw_tolerance=``),
  ``compute_velocity_commands(pose, twist) -> TwistStamped``, ``set_speed_limit``.

A node (not run here)::

    import rclpy
    from geometry_msgs.msg import TwistStamped
    from nav_msgs.msg import Odometry, Path
    from mpc.adapters.ros import Nav2Controller, copy_message
    from mpc.robots import preset

    rclpy.init()
    node = rclpy.create_node("mpc")
    follower = Nav2Controller(preset("mecanum"), dt=0.05)
    publisher = node.create_publisher(TwistStamped, "cmd_vel", 10)
    node.create_subscription(Path, "plan", follower.set_plan, 1)

    def on_odometry(odometry: Odometry) -> None:
        # nav2's plans are in "map", odometry in "odom": the pose must be in the plan's
        # frame (here a localisation that publishes Odometry in "map", e.g. robot_localization
        # with world_frame map; or look up map -> base_link in tf2 and stamp it)
        if follower.has_plan:
            command = follower.compute_velocity_commands(odometry, odometry.twist.twist)
            publisher.publish(copy_message(command, TwistStamped()))

    node.create_subscription(Odometry, "odometry/global", on_odometry, 10)
    rclpy.spin(node)

Re-planning (nav2 plans again about once a second, from where the robot is): a new plan
starts at the pose nearest the robot and at the speed the robot has along it. The clock
runs on the poses' stamps: give each pose its measurement's stamp (a stamp that does not
move holds the reference where it is).

The modules: :mod:`.messages` (messages out, wheel order), :mod:`.clock`
(:class:`ReferenceClock`), :mod:`.nav2` (:class:`Nav2Controller`), :mod:`.jetauto` (JetAuto's
motor messages).
"""

from mpc.adapters.ros.clock import ReferenceClock
from mpc.adapters.ros.jetauto import jetauto_motors, jetauto_typestore, motors_state
from mpc.adapters.ros.messages import (
    ROS2_MECANUM_ORDER,
    copy_message,
    from_ros2_mecanum,
    joint_group_command,
    time_message,
    to_ros2_mecanum,
    twist_message,
    twist_stamped,
)
from mpc.adapters.ros.nav2 import Nav2Controller
from mpc.errors import ControllerError as _Error
from mpc.validation import checked_public as _checked_public
from trajectories.rosbag import (
    pose_from_message,
    quaternion_from_yaw,
    stamp_nanoseconds,
    twist_from_message,
    yaw_from_quaternion,
)

__all__ = ["ROS2_MECANUM_ORDER", "Nav2Controller", "ReferenceClock", "copy_message",
           "from_ros2_mecanum", "jetauto_motors", "jetauto_typestore", "joint_group_command",
           "motors_state", "pose_from_message",
           "quaternion_from_yaw", "stamp_nanoseconds", "time_message", "to_ros2_mecanum",
           "twist_from_message", "twist_message", "twist_stamped", "yaw_from_quaternion"]

# Arguments that do not fit a public callable's signature raise ControllerError, not TypeError.
_checked_public(globals(), _Error)
