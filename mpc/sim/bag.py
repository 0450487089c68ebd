"""A simulated run as a ROS 2 bag (MCAP storage) for Foxglove, RViz or ``ros2 bag play``.

Needs the ``rosbags`` package (``pip install 'holonomic-mpc[ros]'``), imported only when
:func:`write_bag` runs. One message per tick on every topic but the path:

==========================  ================================  ==========================
topic                       type                              content
==========================  ================================  ==========================
``/odom``                   ``nav_msgs/msg/Odometry``         true pose; twist: the body
                                                              twist that moved it over
                                                              the tick (SE(2) logarithm)
``/tf``                     ``tf2_msgs/msg/TFMessage``        ``odom`` -> ``base_link``
``/mpc/reference_path``     ``nav_msgs/msg/Path``             once, at the first tick:
                                                              the reference at every tick
``/mpc/reference_pose``     ``geometry_msgs/msg/PoseStamped`` the reference tracked (at
                                                              ``time - lag``)
``/mpc/cmd_vel``            ``geometry_msgs/msg/TwistStamped`` commanded body twist
``/mpc/wheel_command``      ``sensor_msgs/msg/JointState``    ``velocity``: commands
``/mpc/wheel_actual``       ``sensor_msgs/msg/JointState``    ``velocity``: reached
``/mpc/wheel_limit``        ``sensor_msgs/msg/JointState``    ``velocity``: speed limits
==========================  ================================  ==========================

Wheel values are wheel angular speeds [rad/s]. ``JointState`` rather than
``Float64MultiArray``: every message carries the wheel names, so Foxglove's raw-message
and state views and PlotJuggler (which plots JointState fields by joint name) label the
wheels, the limit plots on the same axes as the command, and ros2_control tools read it.

Frames (REP-103/REP-105): poses in ``odom`` (the world frame of the run), twists in
``base_link``. Stamps: the simulation clock, ``stamp = start_stamp_ns + round(t * 1e9)``;
by default the epoch is 0, so the stamp *is* the simulation time (Foxglove shows dates in
January 1970; give ``start_stamp_ns=time.time_ns()`` for today's). The bag's receive
timestamps equal the header stamps. The bag's metadata (``custom_data``) records the
wheel names, the limits, ``dt`` and the epoch.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mpc.angles import wrap_angle
from mpc.arrays import FloatArray
from mpc.errors import SimulationError
from mpc.sim.result import SimResult
from mpc.validation import shown
from trajectories.rosbag import quaternion_from_yaw, require_rosbags

#: Topic names written by :func:`write_bag`, by role.
TOPICS = {
    "odometry": "/odom",
    "tf": "/tf",
    "reference_path": "/mpc/reference_path",
    "reference_pose": "/mpc/reference_pose",
    "cmd_vel": "/mpc/cmd_vel",
    "wheel_command": "/mpc/wheel_command",
    "wheel_actual": "/mpc/wheel_actual",
    "wheel_limit": "/mpc/wheel_limit",
}
#: REP-105 frames.
WORLD_FRAME, BODY_FRAME = "odom", "base_link"
#: Wheel names for four-wheel layouts in the project's order (Mecanum, swerve).
FOUR_WHEEL_NAMES = ("front_left", "front_right", "rear_left", "rear_right")


def body_twists(pose: FloatArray, dt: float) -> FloatArray:
    """(K, 3) body twists (vx, vy, omega) [m/s, m/s, rad/s] that drive each pose exactly to
    the next in ``dt`` (SE(2) logarithm; the last repeats the one before, a single pose
    gives zeros)."""
    if len(pose) < 2:
        return np.zeros((len(pose), 3))
    step = np.diff(pose, axis=0)
    angle = wrap_angle(step[:, 2])
    c, s = np.cos(pose[:-1, 2]), np.sin(pose[:-1, 2])
    forward, left = c * step[:, 0] + s * step[:, 1], c * step[:, 1] - s * step[:, 0]
    half = 0.5 * angle
    small = np.abs(half) < 1e-4
    # V(a)^-1 = [[h cot h, h], [-h, h cot h]], h = a / 2 (inverse of the exact integral)
    cot = np.where(small, 1.0 - half * half / 3.0,
                   half * np.cos(half) / np.where(small, 1.0, np.sin(half)))
    twists = np.stack([cot * forward + half * left, cot * left - half * forward, angle], axis=1)
    return np.vstack([twists, twists[-1:]]) / dt


def write_bag(result: SimResult, path: str | os.PathLike[str], *,
              wheel_names: Sequence[str] | None = None, start_stamp_ns: int = 0) -> dict[
                  str, tuple[str, int]]:
    """Write ``result`` as a ROS 2 bag directory (MCAP storage, rosbag2 format 9).

    Args:
        result: a run from :func:`~mpc.sim.simulate` or a :class:`~mpc.sim.Recorder`.
        path: the bag directory to create (it must not exist; it holds ``<name>.mcap``
            and ``metadata.yaml``).
        wheel_names: one name per wheel in the robot's order; default ``FOUR_WHEEL_NAMES``
            for four wheels, else ``wheel_0``, ``wheel_1``...
        start_stamp_ns: the stamp [ns] of simulation time 0 (see the module docstring).

    Returns:
        ``{topic: (message type, message count)}`` as written.
    """
    require_rosbags()
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
    from rosbags.typesys import Stores, get_typestore

    names = _wheel_names(result, wheel_names)
    if isinstance(start_stamp_ns, bool) or not isinstance(start_stamp_ns, int) or (
            start_stamp_ns < 0):
        raise SimulationError(f"start_stamp_ns must be an integer >= 0 [ns], got "
                              f"{shown(start_stamp_ns)}")
    stamps = start_stamp_ns + np.round(np.asarray(result.time) * 1e9).astype(np.int64)
    if (stamps < 0).any():
        raise SimulationError("the run starts before the bag's epoch: raise start_stamp_ns")
    store = get_typestore(Stores.ROS2_HUMBLE)
    messages = _Messages(stamps)
    streams = {
        TOPICS["odometry"]: messages.odometry(result),
        TOPICS["tf"]: messages.transforms(result.pose),
        TOPICS["reference_path"]: [messages.path(result)],
        TOPICS["reference_pose"]: [messages.pose_stamped(k, p)
                                   for k, p in enumerate(result.reference)],
        TOPICS["cmd_vel"]: messages.twists(result.twist_command),
        TOPICS["wheel_command"]: messages.joints(names, result.wheel_command),
        TOPICS["wheel_actual"]: messages.joints(names, result.wheel_actual),
        TOPICS["wheel_limit"]: messages.joints(
            names, np.broadcast_to(result.wheel_limit, result.wheel_command.shape)),
    }
    target = Path(path)
    try:
        with Writer(target, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            queue = []  # written in time order, topics in TOPICS order at equal stamps
            for order, (topic, stream) in enumerate(streams.items()):
                connection = writer.add_connection(topic, stream[0].__msgtype__,
                                                   typestore=store)
                queue += [(messages.stamp_of(m), order, connection, m) for m in stream]
            for stamp, _, connection, message in sorted(queue, key=lambda row: row[:2]):
                writer.write(connection, stamp, store.serialize_cdr(message,
                                                                    message.__msgtype__))
            _metadata(writer, result, names, start_stamp_ns)
    except (WriterError, OSError) as error:
        raise SimulationError(f"cannot write the bag {str(target)!r}: {error}") from None
    return {topic: (stream[0].__msgtype__, len(stream)) for topic, stream in streams.items()}


def _wheel_names(result: SimResult, wheel_names: Sequence[str] | None) -> tuple[str, ...]:
    n = len(result.wheel_limit)
    if wheel_names is None:
        return FOUR_WHEEL_NAMES if n == 4 else tuple(f"wheel_{i}" for i in range(n))
    names = tuple(wheel_names)
    if len(names) != n or not all(isinstance(name, str) and name for name in names):
        raise SimulationError(f"wheel_names must be {n} non-empty strings (one per wheel), "
                              f"got {wheel_names!r}")
    return names


def _metadata(writer: Any, result: SimResult, names: tuple[str, ...], epoch: int) -> None:
    accel = result.wheel_accel_limit
    data = {
        "wheel_names": list(names),
        "wheel_speed_limit_rad_s": np.asarray(result.wheel_limit).tolist(),
        "wheel_accel_limit_rad_s2": None if accel is None else np.asarray(accel).tolist(),
        "dt_s": result.dt,
        "start_stamp_ns": epoch,
    }
    for key, value in data.items():
        writer.set_custom_data(f"holonomic_mpc.{key}", json.dumps(value))


class _Messages:
    """rosbags message objects for the rows of a run; ``stamps`` (K,) [ns]."""

    def __init__(self, stamps: np.ndarray) -> None:
        from rosbags.typesys.stores import ros2_humble as types

        self.types, self.stamps = types, stamps

    def header(self, k: int, frame: str) -> Any:
        sec, nanosec = divmod(int(self.stamps[k]), 1_000_000_000)
        return self.types.std_msgs__msg__Header(
            stamp=self.types.builtin_interfaces__msg__Time(sec=sec, nanosec=nanosec),
            frame_id=frame)

    @staticmethod
    def stamp_of(message: Any) -> int:
        stamp = message.header.stamp if hasattr(message, "header") else (
            message.transforms[0].header.stamp)
        return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)

    def pose(self, pose: FloatArray) -> Any:
        t = self.types
        x, y, z, w = quaternion_from_yaw(float(pose[2]))
        return t.geometry_msgs__msg__Pose(
            position=t.geometry_msgs__msg__Point(x=float(pose[0]), y=float(pose[1]), z=0.0),
            orientation=t.geometry_msgs__msg__Quaternion(x=x, y=y, z=z, w=w))

    def twist(self, twist: FloatArray) -> Any:
        t = self.types
        return t.geometry_msgs__msg__Twist(
            linear=t.geometry_msgs__msg__Vector3(x=float(twist[0]), y=float(twist[1]), z=0.0),
            angular=t.geometry_msgs__msg__Vector3(x=0.0, y=0.0, z=float(twist[2])))

    def pose_stamped(self, k: int, pose: FloatArray) -> Any:
        return self.types.geometry_msgs__msg__PoseStamped(header=self.header(k, WORLD_FRAME),
                                                          pose=self.pose(pose))

    def odometry(self, result: SimResult) -> list[Any]:
        t, zeros = self.types, np.zeros(36)
        twists = body_twists(np.asarray(result.pose), result.dt)
        return [t.nav_msgs__msg__Odometry(
            header=self.header(k, WORLD_FRAME), child_frame_id=BODY_FRAME,
            pose=t.geometry_msgs__msg__PoseWithCovariance(pose=self.pose(p), covariance=zeros),
            twist=t.geometry_msgs__msg__TwistWithCovariance(twist=self.twist(v),
                                                            covariance=zeros))
            for k, (p, v) in enumerate(zip(result.pose, twists, strict=True))]

    def transforms(self, poses: FloatArray) -> list[Any]:
        t = self.types
        out = []
        for k, pose in enumerate(poses):
            x, y, z, w = quaternion_from_yaw(float(pose[2]))
            transform = t.geometry_msgs__msg__Transform(
                translation=t.geometry_msgs__msg__Vector3(x=float(pose[0]), y=float(pose[1]),
                                                          z=0.0),
                rotation=t.geometry_msgs__msg__Quaternion(x=x, y=y, z=z, w=w))
            out.append(t.tf2_msgs__msg__TFMessage(transforms=[
                t.geometry_msgs__msg__TransformStamped(header=self.header(k, WORLD_FRAME),
                                                       child_frame_id=BODY_FRAME,
                                                       transform=transform)]))
        return out

    def path(self, result: SimResult) -> Any:
        reference = result.trajectory.sample(np.asarray(result.time)).pose
        return self.types.nav_msgs__msg__Path(
            header=self.header(0, WORLD_FRAME),
            poses=[self.pose_stamped(k, p) for k, p in enumerate(reference)])

    def twists(self, twists: FloatArray) -> list[Any]:
        return [self.types.geometry_msgs__msg__TwistStamped(header=self.header(k, BODY_FRAME),
                                                            twist=self.twist(v))
                for k, v in enumerate(twists)]

    def joints(self, names: tuple[str, ...], values: FloatArray) -> list[Any]:
        empty = np.zeros(0)
        return [self.types.sensor_msgs__msg__JointState(
            header=self.header(k, ""), name=list(names), position=empty,
            velocity=np.array(row, dtype=np.float64), effort=empty)
            for k, row in enumerate(values)]

