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
- :class:`Nav2Controller`, shaped like a nav2 controller plugin: ``set_plan(path)``
  (timed by the time-optimal retimer or at a constant speed),
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

    def on_odometry(odometry: Odometry) -> None:  # in the plan's frame
        if follower.has_plan:
            command = follower.compute_velocity_commands(odometry, odometry.twist.twist)
            publisher.publish(copy_message(command, TwistStamped()))

    node.create_subscription(Odometry, "odom", on_odometry, 10)
    rclpy.spin(node)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control import Command, Controller
from mpc.errors import ControllerError
from mpc.robots import Robot
from mpc.validation import finite, non_negative, positive
from trajectories import FunctionHeading, HeadingSpec, Trajectory
from trajectories.path import PathDerivatives
from trajectories.rosbag import (
    path_reference,
    pose_from_message,
    poses_from_path,
    quaternion_from_yaw,
    require_rosbags,
    stamp_nanoseconds,
    twist_from_message,
    yaw_from_quaternion,
)

require_rosbags()
from rosbags.typesys.stores import ros2_humble as _types  # noqa: E402

__all__ = ["ROS2_MECANUM_ORDER", "Nav2Controller", "ReferenceClock", "copy_message",
           "from_ros2_mecanum", "joint_group_command", "pose_from_message",
           "quaternion_from_yaw", "stamp_nanoseconds", "time_message", "to_ros2_mecanum",
           "twist_from_message", "twist_message", "twist_stamped", "yaw_from_quaternion"]

#: ros2_controllers' Mecanum wheel j is our wheel ``ROS2_MECANUM_ORDER[j]`` (FL, FR, RR, RL
#: from ours FL, FR, RL, RR); the permutation is its own inverse.
ROS2_MECANUM_ORDER = (0, 1, 3, 2)


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
        """The reference time [s] at ``stamp`` (the first stamp starts an unstarted clock)."""
        if self._start is None:
            self._start = stamp_nanoseconds(stamp)
        return self.at(stamp)

    def at(self, stamp: Any) -> float:
        """The reference time [s] at ``stamp`` of a started clock."""
        if self._start is None:
            raise ControllerError("the clock has not started: no stamp seen yet")
        return self.reference_start + (stamp_nanoseconds(stamp) - self._start) * 1e-9


class _Slowed(Trajectory):
    """``source`` played ``rate`` times as fast from time ``start`` on, where it is at its
    own time ``pivot``: source time = pivot + rate (t - start); velocities scale by rate,
    accelerations by rate^2, jerks by rate^3 (a speed limit on a planned reference)."""

    def __init__(self, source: Trajectory, rate: float, start: float, pivot: float) -> None:
        self.source, self.rate, self.start, self.pivot = source, rate, start, pivot
        super().__init__(FunctionHeading(*(self._heading_derivative(k) for k in range(3))))

    def source_time(self, t: FloatArray) -> FloatArray:
        return self.pivot + self.rate * (t - self.start)

    def _heading_derivative(self, order: int) -> Callable[[FloatArray], FloatArray]:
        def derivative(t: FloatArray) -> FloatArray:
            sample = self.source.sample(self.source_time(t))
            field = (sample.pose, sample.velocity, sample.acceleration)[order]
            return self.rate**order * field[..., 2]
        return derivative

    @property
    def start_time(self) -> float:
        return self.start + (self.source.start_time - self.pivot) / self.rate

    @property
    def end_time(self) -> float | None:
        end = self.source.end_time
        return None if end is None else self.start + (end - self.pivot) / self.rate

    def _path(self, t: FloatArray) -> PathDerivatives:
        p, r = self.source.path(self.source_time(t)), self.rate
        return PathDerivatives(p.position, r * p.velocity, r * r * p.acceleration,
                               r**3 * p.jerk)


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
        self._frame = ""
        self._plan: Trajectory | None = None  # as timed by set_plan
        self._peak_speed = 0.0  # [m/s] its peak path speed
        self._now: float | None = None  # [s] reference time of the last command
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
        """Follow a ``nav_msgs/Path`` from the next :meth:`compute_velocity_commands` on,
        timed within ``max_speed`` and the present speed limit."""
        poses = poses_from_path(path)
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
        self._plan, self._now = reference, None
        end = reference.end_time or reference.start_time
        velocity = reference.sample(np.linspace(reference.start_time, end, 2001)).velocity
        self._peak_speed = float(np.hypot(velocity[:, 0], velocity[:, 1]).max())
        self._frame = str(path.header.frame_id)
        self.clock.restart()
        self._velocity_pending = True

    def compute_velocity_commands(self, pose: Any, velocity: Any | None = None) -> Any:
        """The ``TwistStamped`` to send now, in ``base_frame``, stamped with the pose's stamp.

        Args:
            pose: the robot's ``PoseStamped`` (or ``Odometry``) in the plan's frame.
            velocity: its present ``Twist`` (body frame), or None; used once after each new
                plan so that the acceleration limits count from the actual motion.
        """
        if self.controller is None:
            raise ControllerError("no plan yet: call set_plan(path) first")
        frame = str(pose.header.frame_id)
        if frame and self._frame and frame != self._frame:
            raise ControllerError(f"the pose is in frame {frame!r} but the plan in "
                                  f"{self._frame!r}: transform one into the other first")
        if self._velocity_pending and velocity is not None:
            self.controller.reset(last_twist=twist_from_message(velocity))
        self._velocity_pending = False
        self._now = self.clock(pose.header.stamp)
        self.last_command = self.controller.step(pose_from_message(pose), self._now)
        return twist_stamped(self.last_command.twist, pose.header.stamp, self.base_frame)

    def set_speed_limit(self, speed_limit: float, percentage: bool) -> None:
        """nav2's speed limit: ``speed_limit`` [m/s], or [%] of ``max_speed`` if
        ``percentage``; 0 removes it. The present plan keeps its path and its place and
        is played slower from now on, by ``limit / its peak path speed`` (speeds scale by
        that, accelerations by its square: still within the wheel limits). Later plans are
        timed within the limit."""
        limit = non_negative("speed_limit", speed_limit, ControllerError)
        if percentage and limit > 0.0:
            if self.max_speed is None:
                raise ControllerError("a percentage speed limit needs max_speed= [m/s]")
            limit = self.max_speed * limit / 100.0
        self.speed_limit = limit if limit > 0.0 else None
        if self.controller is None or self._plan is None:
            return
        rate = 1.0 if limit == 0.0 or self._peak_speed <= limit else limit / self._peak_speed
        now = self._now if self._now is not None else self._plan.start_time
        current = self.controller.trajectory
        pivot = float(current.source_time(np.array(now))) if isinstance(current, _Slowed) \
            else now
        self.controller.trajectory = _Slowed(self._plan, rate, now, pivot)

    def is_finished(self, stamp: Any) -> bool:
        """Whether the reference time at ``stamp`` has reached the plan's end."""
        end = self.trajectory.end_time
        return end is not None and self.clock.started and self.clock.at(stamp) >= end
