"""References from ROS 2 messages and bags: ``nav_msgs/Path`` and ``nav_msgs/Odometry``.

Bags are read with the pure-Python ``rosbags`` package (ROS 1 bags and ROS 2 bags in
sqlite3 or MCAP storage; no ROS install), an optional extra: ``pip install
'holonomic-mpc[ros]'``. It is imported only when a bag is opened.

- A **Path** holds poses only. :func:`path_reference` joins them by natural cubic splines
  of x, y and the unwrapped yaw in the path parameter ``s`` [m] (chord length, a turn
  counting ``turn_length`` metres per radian, so turning in place takes time too; where
  two poses differ in yaw only, the position is held between them, and the yaw along a
  run of poses with one yaw: the splines would swing past them there) and
  times them: with ``robot=`` by :func:`~trajectories.time_optimal` (rest to rest, the
  fastest timing inside the robot's exact wheel limits, optionally capped at
  ``max_speed``), or with ``speed=`` at that constant rate of ``s`` [m/s] (no limits
  checked). Heading: the poses' yaw, unless ``heading=`` (e.g. ``"tangent"``, planners
  often leave yaw at 0) says otherwise. ``position_tolerance=`` and ``yaw_tolerance=``
  smooth a grid planner's path first (:mod:`trajectories.smoothing`).
- An **Odometry** stream is already timed: the poses and the twist (body frame,
  ``child_frame_id``) become a :class:`~trajectories.sampled.SampledTrajectory` (cubic
  Hermite), its clock the seconds since the first ``header.stamp``.

Frames: REP-103/REP-105; poses are taken in the message's ``header.frame_id`` as they
are (nothing is transformed). Yaw from a quaternion (x, y, z, w):
``atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))``.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.interpolate import CubicSpline

from mpc.validation import is_integer

from ._validation import FloatArray, non_negative_number, positive_number, shown
from .base import Trajectory
from .errors import TrajectoryError
from .heading import HeadingSpec
from .retiming import DEFAULT_SAMPLES, MAX_REPAIRS, RetimingRobot, time_optimal
from .sampled import SampledTrajectory
from .smoothing import smooth_poses

#: How to install what bag reading and writing need.
ROS_EXTRA = "pip install 'holonomic-mpc[ros]'"
PATH_TYPE = "nav_msgs/msg/Path"
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
#: [m/rad] a turn in place counts this much path length per radian.
TURN_LENGTH = 0.5
_SAME_POSE = 1e-9  # [m] consecutive poses closer than this (turn included) are one
#: A step between two poses whose move is under this share of its length (the turn
#: counting ``turn_length`` per radian), alone among its neighbours, is a turn in place.
TURN_SHARE = 0.1


def require_rosbags() -> None:
    """ImportError naming the extra unless ``rosbags`` is installed."""
    try:
        import rosbags  # noqa: F401
    except ImportError as error:
        raise ImportError(f"ROS 2 bags and messages need the rosbags package: {ROS_EXTRA} "
                          "(or pip install 'rosbags>=0.11')") from error


def yaw_from_quaternion(q: Any) -> float:
    """Yaw [rad] in (-pi, pi] of a quaternion with fields x, y, z, w (REP-103, z up); one
    that is not of unit length is taken as its direction (the formula is homogeneous)."""
    x, y, z, w = (float(q.x), float(q.y), float(q.z), float(q.w))
    if not all(math.isfinite(v) for v in (x, y, z, w)):
        raise TrajectoryError(f"quaternion must be finite, got ({x}, {y}, {z}, {w})")
    if not x * x + y * y + z * z + w * w > 0.0:
        raise TrajectoryError(f"quaternion must not be zero (it is no rotation), got "
                              f"({x}, {y}, {z}, {w})")
    return math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """The unit quaternion (x, y, z, w) of a rotation by ``yaw`` [rad] about z."""
    return (0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


def stamp_nanoseconds(stamp: Any) -> int:
    """A ``builtin_interfaces/Time`` (sec, nanosec) as integer nanoseconds since its epoch."""
    sec: Any = getattr(stamp, "sec", None)
    nanosec: Any = getattr(stamp, "nanosec", None)
    if not (is_integer(sec) and is_integer(nanosec) and 0 <= nanosec < 1_000_000_000):
        raise TrajectoryError("a stamp must be a builtin_interfaces/Time (integer sec, and "
                              f"nanosec in [0, 1e9)), got {shown(stamp)}")
    return int(sec) * 1_000_000_000 + int(nanosec)


def poses_from_path(message: Any) -> FloatArray:
    """(n, 3) poses (x, y, yaw) [m, m, rad] of a ``nav_msgs/Path`` message, in its frame."""
    rows = [(p.pose.position.x, p.pose.position.y, yaw_from_quaternion(p.pose.orientation))
            for p in message.poses]
    poses = np.array(rows, dtype=np.float64).reshape(-1, 3)
    if not np.isfinite(poses).all():
        raise TrajectoryError("path poses must be finite")
    return poses


def pose_from_message(message: Any) -> FloatArray:
    """``(x, y, yaw)`` [m, m, rad] of a ``Pose``, ``PoseStamped``, ``PoseWithCovariance``
    or ``nav_msgs/Odometry`` (in its ``header.frame_id``)."""
    pose = message
    while not hasattr(pose, "position"):
        pose = pose.pose
    return np.array([pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation)],
                    dtype=float)


def twist_from_message(message: Any) -> FloatArray:
    """Body twist ``(vx, vy, omega)`` [m/s, m/s, rad/s] of a ``Twist`` or ``TwistStamped``."""
    twist = getattr(message, "twist", message)
    return np.array([twist.linear.x, twist.linear.y, twist.angular.z], dtype=float)


def path_reference(poses: npt.ArrayLike, *, robot: RetimingRobot | None = None,
                   speed: float | None = None, heading: HeadingSpec | None = None,
                   max_speed: float | None = None, turn_length: float = TURN_LENGTH,
                   samples: int = DEFAULT_SAMPLES, start_speed: float = 0.0,
                   max_repairs: int = MAX_REPAIRS, position_tolerance: float = 0.0,
                   yaw_tolerance: float = 0.0) -> Trajectory:
    """A timed reference through poses (n, 3) (x, y, yaw) [m, m, rad] (module docstring).

    Give exactly one of ``robot`` (time-optimal within its wheel limits; ``max_speed``
    [m/s] caps the path speed, ``samples`` is the retiming grid, ``start_speed`` [m/s] the
    speed the robot has at the first pose: a new plan for a robot under way, and
    ``max_repairs`` bounds its re-solves, see :func:`~trajectories.time_optimal`) or
    ``speed`` [m/s] (constant rate of the path parameter). Consecutive duplicate poses are
    dropped; at least two distinct poses are needed.

    ``position_tolerance`` [m] and ``yaw_tolerance`` [rad] > 0 smooth the path first
    (:func:`~trajectories.smoothing.smooth_poses`): as smooth as keeps every pose within
    them of the one given, the ends and turns in place exactly where they are; for a grid
    planner's path, whose steps along the cells the splines would bend through (e.g.
    half a cell and 0.4 rad for yaws in eighths of a turn). 0 (the default): through every
    pose as given.
    """
    if (robot is None) == (speed is None):
        raise TrajectoryError("give exactly one of robot= (time-optimal timing within its "
                              "wheel limits) or speed= [m/s] (constant speed), got "
                              f"robot={shown(robot)}, speed={shown(speed)}")
    rate = 1.0 if speed is None else positive_number("speed [m/s]", speed)
    tolerances = (non_negative_number("position_tolerance [m]", position_tolerance),
                  non_negative_number("yaw_tolerance [rad]", yaw_tolerance))
    geometry = _spline_through(poses, rate, positive_number("turn_length [m/rad]",
                                                            turn_length), heading, tolerances)
    if robot is None:
        return geometry
    return time_optimal(geometry, robot, periodic=False, max_speed=max_speed, samples=samples,
                        start_speed=start_speed, max_repairs=max_repairs)


def _spline_through(poses: npt.ArrayLike, speed: float, turn_length: float,
                    heading: HeadingSpec | None, tolerances: tuple[float, float] = (0.0, 0.0)
                    ) -> SampledTrajectory:
    try:
        table = np.array(poses, dtype=np.float64)
    except (TypeError, ValueError):
        raise TrajectoryError(f"poses must be an (n, 3) array (x, y, yaw), got "
                              f"{shown(poses)}") from None
    if table.ndim != 2 or table.shape[1] != 3 or not np.isfinite(table).all():
        raise TrajectoryError(f"poses must be a finite (n, 3) array (x, y, yaw), got shape "
                              f"{table.shape}")
    table[:, 2] = np.unwrap(table[:, 2])
    steps = np.diff(table, axis=0)
    lengths = np.hypot(np.hypot(steps[:, 0], steps[:, 1]), turn_length * steps[:, 2])
    keep = np.concatenate(([True], lengths > _SAME_POSE))
    if keep.sum() < 2:
        raise TrajectoryError(f"a path needs at least 2 distinct poses, got {keep.sum()} "
                              f"distinct of {len(table)}")
    times = np.concatenate(([0.0], np.cumsum(lengths[keep[1:]]))) / speed
    kept = table[keep]
    if any(tolerances):  # smoothed, then timed along the smoothed path's own lengths
        # the ends and both poses of each step that only turns stay as they are (a step
        # that mostly turns is left to the smoothing: a grid's yaw steps in eighths)
        pinned = np.zeros(len(kept), dtype=bool)
        pinned[[0, -1]] = True
        still = np.flatnonzero(np.hypot(*np.diff(kept[:, :2], axis=0).T) <= _SAME_POSE)
        pinned[still] = pinned[still + 1] = True
        kept = smooth_poses(kept, *tolerances, pinned)
        steps = np.diff(kept, axis=0)
        lengths = np.hypot(np.hypot(steps[:, 0], steps[:, 1]), turn_length * steps[:, 2])
        keep = np.concatenate(([True], lengths > _SAME_POSE))
        times = np.concatenate(([0.0], np.cumsum(lengths[keep[1:]]))) / speed
        kept = kept[keep]
    slopes = CubicSpline(times, kept, bc_type="natural", axis=0)(times, 1)
    # Where the robot turns in place the position stays put in between (the position's
    # slopes 0 at both poses: a monotone piece), and along a run of poses with one yaw the
    # yaw does: the splines would swing past the poses there (14 cm beyond a goal that ends
    # by turning). A step that mostly turns (its move under TURN_SHARE of its length) and
    # stands alone counts as a turn in place (a goal pose a little off the last one); a
    # run of them is a robot that creeps while it turns, left smooth. One interval of equal
    # yaw is not a run: the two sides of a symmetric turn.
    steps = np.diff(kept, axis=0)
    turning = _turns_in_place(kept, lengths[keep[1:]])
    slopes[turning, :2] = 0.0
    slopes[turning + 1, :2] = 0.0
    level = np.abs(steps[:, 2]) <= _SAME_POSE
    run = np.flatnonzero(level & _beside(level))
    slopes[run, 2] = 0.0
    slopes[run + 1, 2] = 0.0
    return SampledTrajectory(times, kept, slopes, heading=heading)


def _turns_in_place(poses: FloatArray, lengths: FloatArray) -> npt.NDArray[np.intp]:
    """The steps between ``poses`` (n, 3) (of ``lengths`` (n - 1,), the turn counted) that
    turn in place: no move, or one under :data:`TURN_SHARE` of the step that stands alone."""
    steps = np.diff(poses, axis=0)
    moves = np.hypot(steps[:, 0], steps[:, 1])
    mostly = moves < TURN_SHARE * lengths
    return np.flatnonzero((moves <= _SAME_POSE) | (mostly & ~_beside(mostly)))


def _beside(mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """Whether the step before or after each one is set in ``mask``."""
    before = np.concatenate(([False], mask[:-1]))
    after = np.concatenate((mask[1:], [False]))
    return before | after

def odometry_reference(messages: Sequence[Any], *, use_twist: bool = True) -> SampledTrajectory:
    """A timed reference through ``nav_msgs/Odometry`` messages, clock 0 at the first stamp.

    Velocities: the twist (body frame) rotated into the world frame; with ``use_twist``
    False, central differences of the poses (for sources that leave the twist empty).
    """
    if len(messages) < 2:
        raise TrajectoryError(f"an odometry reference needs at least 2 messages, got "
                              f"{len(messages)}")
    stamps = np.array([stamp_nanoseconds(m.header.stamp) for m in messages], dtype=np.int64)
    bad = np.flatnonzero(np.diff(stamps) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise TrajectoryError(f"odometry message {k}: header.stamp {int(stamps[k])} ns is not "
                              f"after message {k - 1}'s {int(stamps[k - 1])} ns")
    times = (stamps - stamps[0]) * 1e-9
    poses = np.array([pose_from_message(m) for m in messages])
    poses[:, 2] = np.unwrap(poses[:, 2])
    if use_twist:
        body = np.array([twist_from_message(m.twist) for m in messages])
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        velocities = np.stack([c * body[:, 0] - s * body[:, 1],
                               s * body[:, 0] + c * body[:, 1], body[:, 2]], axis=1)
    else:
        velocities = np.gradient(poses, times, axis=0)
    return SampledTrajectory(times, poses, velocities)


def bag_topics(bag: str | os.PathLike[str]) -> dict[str, tuple[str, int]]:
    """Every topic of a bag: ``{topic: (message type, message count)}``."""
    with _open(Path(bag)) as reader:
        return {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}


def read_bag_reference(bag: str | os.PathLike[str], topic: str | None = None, *,
                       robot: RetimingRobot | None = None, speed: float | None = None,
                       heading: HeadingSpec | None = None, max_speed: float | None = None,
                       message: int = -1, use_twist: bool = True) -> Trajectory:
    """A reference from a ``nav_msgs/Path`` or ``nav_msgs/Odometry`` topic of a bag.

    Args:
        bag: a ROS 2 bag directory (sqlite3 or MCAP), a ``.mcap`` file or a ROS 1 ``.bag``.
        topic: the topic; None: the bag's only Path or Odometry topic.
        robot, speed, heading, max_speed: a Path's timing, see :func:`path_reference`.
        message: which Path message (a planner publishes many; default the last).
        use_twist: Odometry velocities, see :func:`odometry_reference`.

    Raises:
        TrajectoryError: not a bag, a missing topic (the message lists the topics and types
            present), a topic of another type, too few or badly stamped messages.
    """
    file = Path(bag)
    with _open(file) as reader:
        topics = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        chosen = _choose(file, topics, topic)
        connections = [c for c in reader.connections if c.topic == chosen]
        messages = [reader.deserialize(raw, c.msgtype)
                    for c, _, raw in reader.messages(connections=connections)]
    where = f"ROS bag {str(file)!r}, topic {shown(chosen)}"
    try:
        if topics[chosen][0] == ODOMETRY_TYPE:
            return odometry_reference(messages, use_twist=use_twist)
        if not -len(messages) <= message < len(messages):
            raise TrajectoryError(f"message {message} does not exist ({len(messages)} "
                                  "messages)")
        return path_reference(poses_from_path(messages[message]), robot=robot, speed=speed,
                              heading=heading, max_speed=max_speed)
    except TrajectoryError as error:
        raise TrajectoryError(f"{where}: {error}") from None


def _listing(topics: dict[str, tuple[str, int]]) -> str:
    return ", ".join(f"{name} ({kind}, {count} message{'' if count == 1 else 's'})"
                     for name, (kind, count) in sorted(topics.items())) or "none"


def _choose(file: Path, topics: dict[str, tuple[str, int]], topic: str | None) -> str:
    usable = {n: v for n, v in topics.items() if v[0] in (PATH_TYPE, ODOMETRY_TYPE)}
    if topic is None:
        if len(usable) == 1:
            return next(iter(usable))
        raise TrajectoryError(f"ROS bag {str(file)!r}: {len(usable)} Path or Odometry topics, "
                              f"give topic=; topics: {_listing(topics)}")
    if topic not in topics:
        raise TrajectoryError(f"ROS bag {str(file)!r} has no topic {topic!r}; topics: "
                              f"{_listing(topics)}")
    if topic not in usable:
        raise TrajectoryError(f"ROS bag {str(file)!r}: topic {topic!r} is {topics[topic][0]}, "
                              f"a reference needs {PATH_TYPE} or {ODOMETRY_TYPE} (such topics "
                              f"here: {_listing(usable)})")
    return topic


@contextlib.contextmanager
def _open(file: Path) -> Iterator[Any]:
    """An open rosbags ``AnyReader`` (ROS 2 default types: Humble), or TrajectoryError if
    ``file`` is not a readable bag."""
    require_rosbags()
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    if not file.exists():
        raise TrajectoryError(f"ROS bag {str(file)!r} does not exist")
    try:
        reader = AnyReader([file], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except (AnyReaderError, OSError, ValueError, KeyError) as error:
        raise TrajectoryError(f"ROS bag {str(file)!r}: not a readable ROS 1 or ROS 2 bag "
                              f"(sqlite3 or MCAP): {error}") from None
    try:
        yield reader
    finally:
        reader.close()
