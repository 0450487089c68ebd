"""ROS messages out of ours (``rosbags`` dataclasses): time stamps, twists, joint group
commands, and the Mecanum wheel order of ros2_controllers; :func:`copy_message` into rclpy
messages. (Messages in are read by :mod:`trajectories.rosbag`.)"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import ControllerError
from mpc.validation import finite_vector, real_array, shown
from trajectories.rosbag import require_rosbags, stamp_nanoseconds

require_rosbags()
from rosbags.typesys.stores import ros2_humble as _types  # noqa: E402

#: ros2_controllers' Mecanum wheel j is our wheel ``ROS2_MECANUM_ORDER[j]`` (FL, FR, RR, RL
#: from ours FL, FR, RL, RR); the permutation is its own inverse.
ROS2_MECANUM_ORDER = (0, 1, 3, 2)


def time_message(nanoseconds: int) -> Any:
    """A ``builtin_interfaces/Time`` for integer nanoseconds since the epoch."""
    sec, nanosec = divmod(int(nanoseconds), 1_000_000_000)
    return _types.builtin_interfaces__msg__Time(sec=sec, nanosec=nanosec)


def twist_message(twist: ArrayLike) -> Any:
    """A ``geometry_msgs/Twist`` from ``(vx, vy, omega)``."""
    vx, vy, omega = (float(v) for v in finite_vector(
        "twist", twist, 3, "(vx, vy, omega) [m/s, m/s, rad/s]", ControllerError))
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
    speeds = real_array("wheel_speeds", wheel_speeds, "wheel speeds [rad/s]", ControllerError)
    if speeds.ndim != 1 or not np.isfinite(speeds).all():
        raise ControllerError(f"wheel_speeds must be one finite speed a wheel [rad/s], got "
                              f"{shown(wheel_speeds)}")
    if order is not None:
        if sorted(order) != list(range(len(speeds))):
            raise ControllerError(f"order must be a permutation of 0..{len(speeds) - 1}, "
                                  f"got {shown(order)}")
        speeds = speeds[list(order)]
    layout = _types.std_msgs__msg__MultiArrayLayout(dim=[], data_offset=0)
    return _types.std_msgs__msg__Float64MultiArray(layout=layout, data=speeds.copy())


def copy_message(source: Any, target: Any) -> Any:
    """Copy a rosbags message dataclass field by field into ``target`` (e.g. a fresh rclpy
    message of the same type) and return ``target``. rosbags' own ``__msgtype__`` is not a
    message field (rclpy messages have slots for their fields only); a NumPy array goes in
    as a list (rclpy's ``float64[]`` takes sequences and ``array.array``)."""
    for item in dataclasses.fields(source):
        if item.name.startswith("__"):
            continue
        value = getattr(source, item.name)
        if dataclasses.is_dataclass(value):
            copy_message(value, getattr(target, item.name))
        else:
            setattr(target, item.name, value.tolist() if isinstance(value, np.ndarray)
                    else value)
    return target
