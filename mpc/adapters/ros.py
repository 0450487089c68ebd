"""ROS 2 adapter on ``rosbags``' message types (optional extra ``ros``; no ROS install).

Needs ``rosbags`` (``pip install 'holonomic-mpc[ros]'``). Inputs are read by field name,
so rclpy messages work as they are; outputs are ``rosbags`` message dataclasses with the
same fields (copy one into an rclpy message with :func:`copy_message`).

- Poses: ``Odometry`` / ``PoseStamped`` -> ``(x, y, yaw)`` (quaternion to yaw, z up).
- Twists: ``Twist`` / ``TwistStamped`` in and out; commands are body twists, frame
  ``base_link`` (REP-105), stamped with the pose's stamp.
- **Time base.** ROS stamps are seconds since the Unix epoch (~1.7e9); the controller's
  ``t`` is seconds since the reference's start. ``controller.step(pose, 1.7e9)`` on a
  periodic reference (a circle) silently tracks whatever phase 1.7e9 s falls on, and on
  a finite one the end pose. :class:`ReferenceClock` converts: reference time =
  ``reference_start + (stamp - start stamp)``, in integer nanoseconds, the start being
  the first stamp it sees unless set.
- **Wheel order.** ros2_controllers' ``mecanum_drive_controller`` orders its wheels FL,
  FR, RR, RL; ours are FL, FR, RL, RR (same kinematics otherwise, see README
  "Conventions"): :func:`to_ros2_mecanum` / :func:`from_ros2_mecanum`.
  ``JointGroupVelocityController`` takes a ``Float64MultiArray`` [rad/s] in its
  ``joints`` order: :func:`joint_group_command`.
- :class:`Nav2Controller` has the shape of a nav2 controller plugin: ``set_plan(path)``
  (timed by the time-optimal retimer, or a constant speed), then
  ``compute_velocity_commands(pose, twist) -> TwistStamped`` every cycle, and
  ``set_speed_limit(limit, percentage)``.

A node (not run here; rclpy messages in, rosbags dataclasses out)::

    import rclpy
    from geometry_msgs.msg import TwistStamped
    from nav_msgs.msg import Odometry, Path
    from mpc.adapters.ros import Nav2Controller, copy_message, pose_stamped_from_odometry
    from mpc.robots import preset

    rclpy.init()
    node = rclpy.create_node("mpc")
    follower = Nav2Controller(preset("mecanum"), dt=0.05)
    publisher = node.create_publisher(TwistStamped, "cmd_vel", 10)
    node.create_subscription(Path, "plan", follower.set_plan, 1)

    def on_odometry(odometry: Odometry) -> None:   # pose and plan in the same frame
        if follower.has_plan:
            command = follower.compute_velocity_commands(
                pose_stamped_from_odometry(odometry), odometry.twist.twist)
            publisher.publish(copy_message(command, TwistStamped()))

    node.create_subscription(Odometry, "odom", on_odometry, 10)
    rclpy.spin(node)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control import Command, Controller
from mpc.errors import ControllerError
from mpc.robots import Robot
from mpc.validation import finite, non_negative, positive
from trajectories import HeadingSpec, Trajectory
from trajectories.rosbag import (
    path_reference,
    poses_from_path,
    quaternion_from_yaw,
    require_rosbags,
    stamp_nanoseconds,
    yaw_from_quaternion,
)

require_rosbags()
from rosbags.typesys.stores import ros2_humble as _types  # noqa: E402

__all__ = [
    "ROS2_MECANUM_ORDER", "Nav2Controller", "ReferenceClock", "copy_message",
    "from_ros2_mecanum", "joint_group_command", "pose_from_odometry",
    "pose_from_pose_stamped", "pose_stamped_from_odometry", "quaternion_from_yaw",
    "stamp_nanoseconds", "time_message", "to_ros2_mecanum", "twist_from_message",
    "twist_message", "twist_stamped", "yaw_from_quaternion",
]

#: ros2_controllers' Mecanum wheel j is our wheel ``ROS2_MECANUM_ORDER[j]`` (FL, FR, RR, RL
#: from ours FL, FR, RL, RR); the permutation is its own inverse.
ROS2_MECANUM_ORDER = (0, 1, 3, 2)


def pose_from_pose_stamped(message: Any) -> FloatArray:
    """``(x, y, yaw)`` [m, m, rad] of a ``geometry_msgs/PoseStamped`` (or a ``Pose``)."""
    pose = getattr(message, "pose", message)
    return np.array([pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation)],
                    dtype=float)


def pose_from_odometry(message: Any) -> FloatArray:
    """``(x, y, yaw)`` [m, m, rad] of a ``nav_msgs/Odometry`` in its ``header.frame_id``."""
    return pose_from_pose_stamped(message.pose.pose)


def pose_stamped_from_odometry(message: Any) -> Any:
    """The ``PoseStamped`` (header and pose) of a ``nav_msgs/Odometry``."""
    return _types.geometry_msgs__msg__PoseStamped(header=message.header, pose=message.pose.pose)


def twist_from_message(message: Any) -> FloatArray:
    """Body twist ``(vx, vy, omega)`` [m/s, m/s, rad/s] of a ``Twist`` or ``TwistStamped``."""
    twist = getattr(message, "twist", message)
    return np.array([twist.linear.x, twist.linear.y, twist.angular.z], dtype=float)


def time_message(nanoseconds: int) -> Any:
    """A ``builtin_interfaces/Time`` for integer nanoseconds since the epoch."""
    sec, nanosec = divmod(int(nanoseconds), 1_000_000_000)
    return _types.builtin_interfaces__msg__Time(sec=sec, nanosec=nanosec)


def twist_message(twist: ArrayLike) -> Any:
    """A ``geometry_msgs/Twist`` from ``(vx, vy, omega)``."""
    vx, vy, omega = (float(v) for v in np.asarray(twist, dtype=float).reshape(3))
    return _types.geometry_msgs__msg__Twist(
        linear=_types.geometry_msgs__msg__Vector3(x=vx, y=vy, z=0.0),
        angular=_types.geometry_msgs__msg__Vector3(x=0.0, y=0.0, z=omega))


def twist_stamped(twist: ArrayLike, stamp: Any, frame_id: str = "base_link") -> Any:
    """A ``geometry_msgs/TwistStamped``: ``twist`` in ``frame_id`` at ``stamp`` (a ``Time``)."""
    header = _types.std_msgs__msg__Header(stamp=time_message(stamp_nanoseconds(stamp)),
                                          frame_id=frame_id)
    return _types.geometry_msgs__msg__TwistStamped(header=header, twist=twist_message(twist))


def to_ros2_mecanum(values: ArrayLike) -> FloatArray:
    """Our Mecanum wheel values (FL, FR, RL, RR) in ros2_controllers' order (FL, FR, RR, RL)."""
    return _four(values)[list(ROS2_MECANUM_ORDER)]


def from_ros2_mecanum(values: ArrayLike) -> FloatArray:
    """ros2_controllers' Mecanum wheel values (FL, FR, RR, RL) in ours (FL, FR, RL, RR)."""
    return _four(values)[list(ROS2_MECANUM_ORDER)]


def _four(values: ArrayLike) -> FloatArray:
    array = np.asarray(values, dtype=float)
    if array.shape[-1:] != (4,):
        raise ControllerError(f"expected 4 Mecanum wheel values, got shape {array.shape}")
    return array


def joint_group_command(wheel_speeds: ArrayLike, order: Sequence[int] | None = None) -> Any:
    """A ``std_msgs/Float64MultiArray`` [rad/s] for a ``JointGroupVelocityController``: entry j
    is our wheel ``order[j]`` (default our order; ``ROS2_MECANUM_ORDER`` for the joints
    listed as ros2_controllers lists Mecanum wheels)."""
    speeds = np.asarray(wheel_speeds, dtype=float)
    if order is not None:
        if sorted(order) != list(range(len(speeds))):
            raise ControllerError(f"order must be a permutation of 0..{len(speeds) - 1}, "
                                  f"got {order!r}")
        speeds = speeds[list(order)]
    layout = _types.std_msgs__msg__MultiArrayLayout(dim=[], data_offset=0)
    return _types.std_msgs__msg__Float64MultiArray(layout=layout, data=speeds.copy())


def copy_message(source: Any, target: Any) -> Any:
    """Copy a rosbags message dataclass field by field into ``target`` (e.g. a fresh rclpy
    message of the same type) and return ``target``."""
    for item in dataclasses.fields(source):
        value = getattr(source, item.name)
        if dataclasses.is_dataclass(value):
            copy_message(value, getattr(target, item.name))
        else:
            setattr(target, item.name, value)
    return target


class ReferenceClock:
    """Reference time [s] from ROS stamps: ``reference_start + (stamp - start)``.

    ``start`` is a ``builtin_interfaces/Time``; None: the first stamp given to the clock.
    Differences are taken in integer nanoseconds (no float rounding of epoch seconds).
    """

    def __init__(self, start: Any | None = None, reference_start: float = 0.0) -> None:
        self.restart(start, reference_start)

    def restart(self, start: Any | None = None, reference_start: float = 0.0) -> None:
        """Start again: ``start`` (None: the next stamp seen) is ``reference_start`` [s]."""
        self._start = None if start is None else stamp_nanoseconds(start)
        self.reference_start = finite("reference_start [s]", reference_start, ControllerError)

    @property
    def started(self) -> bool:
        """Whether the start stamp is known."""
        return self._start is not None

    def __call__(self, stamp: Any) -> float:
        """The reference time [s] at ``stamp``."""
        now = stamp_nanoseconds(stamp)
        if self._start is None:
            self._start = now
        return self.reference_start + (now - self._start) * 1e-9


class Nav2Controller:
    """The MPC with the shape of a nav2 controller plugin, on ROS messages.

    Args:
        robot: the drive layout and its wheel limits.
        dt: control period [s] (the controller server's rate), also the MPC tick.
        horizon: MPC ticks planned ahead.
        speed: None: time each plan time-optimally within the wheel limits; a number:
            drive plans at this constant path speed [m/s].
        max_speed: cap on the time-optimal path speed [m/s]; also the 100 % of
            percentage speed limits.
        heading: None: the plan's yaw; else a heading spec (``"tangent"``, an angle...).
        base_frame: frame of the commands (REP-105 ``base_link``).
        **options: further :class:`~mpc.control.Controller` options.
    """

    def __init__(self, robot: Robot, *, dt: float = 0.05, horizon: int = 20,
                 speed: float | None = None, max_speed: float | None = None,
                 heading: HeadingSpec | None = None, base_frame: str = "base_link",
                 **options: Any) -> None:
        self.robot, self.dt, self.horizon, self._options = robot, dt, horizon, options
        self.speed = None if speed is None else positive("speed [m/s]", speed, ControllerError)
        self.max_speed = None if max_speed is None else positive("max_speed [m/s]", max_speed,
                                                                  ControllerError)
        self.heading, self.base_frame = heading, base_frame
        self.clock = ReferenceClock()
        self.controller: Controller | None = None
        self.speed_limit: float | None = None  # [m/s] from set_speed_limit
        self._plan = np.zeros((0, 3))
        self._frame = ""
        self._pose: FloatArray | None = None
        self._velocity_pending = True
        self.last_command: Command | None = None

    @property
    def has_plan(self) -> bool:
        """Whether :meth:`set_plan` has been given a plan."""
        return self.controller is not None

    @property
    def trajectory(self) -> Trajectory:
        """The timed reference of the current plan."""
        if self.controller is None:
            raise ControllerError("no plan yet: call set_plan(path) first")
        return self.controller.trajectory

    def set_plan(self, path: Any) -> None:
        """Follow a ``nav_msgs/Path`` from the next :meth:`compute_velocity_commands` on."""
        poses = poses_from_path(path)
        self._frame = str(path.header.frame_id)
        self._follow(poses)

    def _follow(self, poses: FloatArray) -> None:
        cap = min((c for c in (self.max_speed, self.speed_limit) if c is not None),
                  default=None)
        if self.speed is None:
            reference = path_reference(poses, robot=self.robot, heading=self.heading,
                                       max_speed=cap)
        else:
            reference = path_reference(poses, speed=min(self.speed, cap or self.speed),
                                       heading=self.heading)
        if self.controller is None:
            self.controller = Controller(self.robot, reference, horizon=self.horizon,
                                         dt=self.dt, **self._options)
        else:
            self.controller.trajectory = reference
        self._plan = poses
        self.clock.restart()
        self._velocity_pending = True

    def compute_velocity_commands(self, pose: Any, velocity: Any | None = None) -> Any:
        """The ``TwistStamped`` to send now, in ``base_frame``, stamped with the pose's stamp.

        Args:
            pose: the robot's ``PoseStamped`` in the plan's frame.
            velocity: its present ``Twist`` (body frame), or None; used once after each new
                plan so that the acceleration limits count from the actual motion.
        """
        if self.controller is None:
            raise ControllerError("no plan yet: call set_plan(path) first")
        frame = str(pose.header.frame_id)
        if frame and self._frame and frame != self._frame:
            raise ControllerError(f"the pose is in frame {frame!r} but the plan in "
                                  f"{self._frame!r}: transform one into the other first")
        self._pose = pose_from_pose_stamped(pose)
        if self._velocity_pending and velocity is not None:
            self.controller.reset(last_twist=twist_from_message(velocity))
        self._velocity_pending = False
        self.last_command = self.controller.step(self._pose, self.clock(pose.header.stamp))
        return twist_stamped(self.last_command.twist, pose.header.stamp, self.base_frame)

    def set_speed_limit(self, speed_limit: float, percentage: bool) -> None:
        """nav2's speed limit: ``speed_limit`` [m/s], or [%] of ``max_speed`` if
        ``percentage``; 0 removes it. The rest of the plan, from the robot's last pose on,
        is timed again at once (from rest: the robot slows down briefly)."""
        limit = non_negative("speed_limit", speed_limit, ControllerError)
        if percentage and limit > 0.0:
            if self.max_speed is None:
                raise ControllerError("a percentage speed limit needs max_speed= [m/s]")
            limit = self.max_speed * limit / 100.0
        self.speed_limit = limit if limit > 0.0 else None
        if self.controller is not None and self._pose is not None:
            nearest = int(np.argmin(np.hypot(*(self._plan[:, :2] - self._pose[:2]).T)))
            rest = self._plan[nearest + 1:]
            if len(rest):
                self._follow(np.vstack([self._pose, rest]))

    def is_finished(self, stamp: Any) -> bool:
        """Whether the reference time at ``stamp`` has reached the plan's end."""
        end = self.trajectory.end_time
        return end is not None and self.clock.started and self.clock(stamp) >= end
