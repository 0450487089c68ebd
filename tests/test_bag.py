"""ROS 2 bags: a run written as MCAP and read back by rosbags; Path and Odometry references."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402
from rosbags.typesys.stores import ros2_humble as types  # noqa: E402

from mpc import Controller  # noqa: E402
from mpc.errors import SimulationError, TrajectoryError  # noqa: E402
from mpc.model.se2 import integrate  # noqa: E402
from mpc.robots import preset  # noqa: E402
from mpc.sim import SimResult, simulate  # noqa: E402
from mpc.sim.bag import FOUR_WHEEL_NAMES, TOPICS, body_twists, write_bag  # noqa: E402
from trajectories import Circle, feasibility  # noqa: E402
from trajectories.rosbag import (  # noqa: E402
    bag_topics,
    odometry_reference,
    path_reference,
    read_bag_reference,
)

STORE = get_typestore(Stores.ROS2_HUMBLE)
EPOCH = 1_700_000_000_123_456_789  # [ns] a ROS-like epoch stamp


@pytest.fixture(scope="module")
def run() -> SimResult:
    robot = preset("mecanum")
    return simulate(Controller(robot, Circle(1.0, 12.0, heading="tangent")), duration=1.5,
                    plant="realistic", seed=2)


def read_all(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message by topic, as (bag timestamp [ns], message), read with rosbags alone."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([bag], default_typestore=STORE) as reader:
        for connection, stamp, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            out.setdefault(connection.topic, []).append((stamp, message))
    return out


def yaw(q: Any) -> float:
    """Yaw of a z-rotation quaternion from its rotation matrix (an independent formula)."""
    r10 = 2 * (q.x * q.y + q.w * q.z)
    r00 = 1 - 2 * (q.y * q.y + q.z * q.z)
    return math.atan2(r10, r00)


def wrapped(angles: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * angles))


def test_written_bag_has_the_topics_types_and_counts(tmp_path: Path, run: SimResult) -> None:
    bag = tmp_path / "run"
    written = write_bag(run, bag)
    ticks = len(run.time)
    expected = {
        "/odom": ("nav_msgs/msg/Odometry", ticks), "/tf": ("tf2_msgs/msg/TFMessage", ticks),
        "/mpc/reference_path": ("nav_msgs/msg/Path", 1),
        "/mpc/reference_pose": ("geometry_msgs/msg/PoseStamped", ticks),
        "/mpc/cmd_vel": ("geometry_msgs/msg/TwistStamped", ticks),
        "/mpc/wheel_command": ("sensor_msgs/msg/JointState", ticks),
        "/mpc/wheel_actual": ("sensor_msgs/msg/JointState", ticks),
        "/mpc/wheel_limit": ("sensor_msgs/msg/JointState", ticks),
    }
    assert written == expected and set(TOPICS.values()) == set(expected)
    with AnyReader([bag], default_typestore=STORE) as reader:
        assert {c.topic: (c.msgtype, c.msgcount) for c in reader.connections} == expected
    assert sorted(p.suffix for p in bag.iterdir()) == [".mcap", ".yaml"]
    metadata = (bag / "metadata.yaml").read_text()
    assert "storage_identifier: mcap" in metadata and "holonomic_mpc.wheel_names" in metadata
    mcap = next(bag.glob("*.mcap"))
    assert bag_topics(mcap) == expected  # the bare MCAP file reads too


def test_values_stamps_and_frames_round_trip(tmp_path: Path, run: SimResult) -> None:
    bag = tmp_path / "run"
    write_bag(run, bag, start_stamp_ns=EPOCH)
    topics = read_all(bag)
    stamps = EPOCH + np.round(run.time * 1e9).astype(np.int64)
    for topic in set(TOPICS.values()) - {"/mpc/reference_path"}:
        assert [s for s, _ in topics[topic]] == stamps.tolist(), topic
    odometry = [m for _, m in topics["/odom"]]
    assert all(m.header.frame_id == "odom" and m.child_frame_id == "base_link" for m in odometry)
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in odometry] == (
        stamps.tolist())
    pose = np.array([(m.pose.pose.position.x, m.pose.pose.position.y,
                      yaw(m.pose.pose.orientation)) for m in odometry])
    np.testing.assert_allclose(pose[:, :2], run.pose[:, :2], atol=1e-15)
    np.testing.assert_allclose(wrapped(pose[:, 2] - run.pose[:, 2]), 0.0, atol=1e-12)
    reference = np.array([(m.pose.position.x, m.pose.position.y, yaw(m.pose.orientation))
                          for _, m in topics["/mpc/reference_pose"]])
    np.testing.assert_allclose(reference[:, :2], run.reference[:, :2], atol=1e-15)
    commands = [m for _, m in topics["/mpc/cmd_vel"]]
    assert all(m.header.frame_id == "base_link" for m in commands)
    twist = np.array([(m.twist.linear.x, m.twist.linear.y, m.twist.angular.z) for m in commands])
    np.testing.assert_array_equal(twist, run.twist_command)
    for topic, values in (("/mpc/wheel_command", run.wheel_command),
                          ("/mpc/wheel_actual", run.wheel_actual),
                          ("/mpc/wheel_limit", np.tile(run.wheel_limit, (len(run.time), 1)))):
        messages = [m for _, m in topics[topic]]
        assert all(list(m.name) == list(FOUR_WHEEL_NAMES) for m in messages)
        np.testing.assert_array_equal([m.velocity for m in messages], values)
    transforms = [m.transforms[0] for _, m in topics["/tf"]]
    assert {(t.header.frame_id, t.child_frame_id) for t in transforms} == {("odom", "base_link")}
    np.testing.assert_allclose([t.transform.translation.x for t in transforms], run.pose[:, 0])
    ((stamp, path),) = topics["/mpc/reference_path"]
    assert stamp == stamps[0] and path.header.frame_id == "odom"
    along = np.array([(p.pose.position.x, p.pose.position.y) for p in path.poses])
    np.testing.assert_allclose(along, run.trajectory.sample(run.time).pose[:, :2], atol=1e-15)


def test_odometry_twist_is_the_exact_motion_between_poses() -> None:
    rng = np.random.default_rng(7)
    twists = rng.uniform(-1.0, 1.0, (30, 3)) * [1.0, 1.0, 4.0]
    twists[5] = [0.3, -0.2, 0.0]  # straight
    twists[6] = [0.2, 0.1, 1e-7]  # nearly straight (series branch)
    poses = [np.array([0.5, -1.0, 3.0])]
    for twist in twists:
        poses.append(integrate(poses[-1], twist, 0.05))
    recovered = body_twists(np.array(poses), 0.05)
    np.testing.assert_allclose(recovered[:-1], twists, atol=1e-9)
    np.testing.assert_array_equal(recovered[-1], recovered[-2])
    assert body_twists(np.zeros((1, 3)), 0.05).shape == (1, 3)


def path_bag(directory: Path, poses: np.ndarray, storage: StoragePlugin, frame: str = "map",
             topic: str = "/plan", extra: bool = False) -> Path:
    """A bag with one nav_msgs/Path (and optionally a TwistStamped topic), written here."""
    bag = directory / "plan"
    stamp = types.builtin_interfaces__msg__Time(sec=1_700_000_000, nanosec=0)
    header = types.std_msgs__msg__Header(stamp=stamp, frame_id=frame)
    stamped = []
    for x, y, theta in poses:
        orientation = types.geometry_msgs__msg__Quaternion(
            x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2))
        stamped.append(types.geometry_msgs__msg__PoseStamped(
            header=header, pose=types.geometry_msgs__msg__Pose(
                position=types.geometry_msgs__msg__Point(x=x, y=y, z=0.0),
                orientation=orientation)))
    message = types.nav_msgs__msg__Path(header=header, poses=stamped)
    with Writer(bag, version=9, storage_plugin=storage) as writer:
        connection = writer.add_connection(topic, message.__msgtype__, typestore=STORE)
        writer.write(connection, 1_700_000_000 * 10**9,
                     STORE.serialize_cdr(message, message.__msgtype__))
        if extra:
            twist = types.geometry_msgs__msg__TwistStamped(
                header=header, twist=types.geometry_msgs__msg__Twist(
                    linear=types.geometry_msgs__msg__Vector3(x=0.0, y=0.0, z=0.0),
                    angular=types.geometry_msgs__msg__Vector3(x=0.0, y=0.0, z=0.0)))
            other = writer.add_connection("/cmd_vel", twist.__msgtype__, typestore=STORE)
            writer.write(other, 1_700_000_000 * 10**9,
                         STORE.serialize_cdr(twist, twist.__msgtype__))
    return bag


def s_curve(count: int = 60) -> np.ndarray:
    s = np.linspace(0.0, 1.0, count)
    return np.stack([3.0 * s, 0.8 * np.sin(2 * np.pi * s), 1.5 * s], axis=1)


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP])
def test_path_from_a_bag_becomes_a_feasible_timed_reference(tmp_path: Path,
                                                            storage: StoragePlugin) -> None:
    poses = s_curve()
    robot = preset("swerve")
    reference = read_bag_reference(path_bag(tmp_path, poses, storage), "/plan", robot=robot)
    report = feasibility(reference, robot, samples=4001)
    assert report.peak_ratio <= 1.0 + 1e-6 and report.peak_ratio > 0.98  # time-optimal
    assert reference.start_time == 0.0 and reference.end_time is not None
    ends = reference.sample(np.array([0.0, reference.end_time]))
    np.testing.assert_allclose(ends.pose, poses[[0, -1]], atol=1e-12)
    np.testing.assert_allclose(ends.velocity, 0.0, atol=1e-6)  # rest to rest
    dense = reference.sample(np.linspace(0.0, reference.end_time, 20001)).pose
    gaps = np.hypot(*(dense[None, :, :2] - poses[:, None, :2]).transpose(2, 0, 1)).min(axis=1)
    assert gaps.max() < 2e-3  # passes through every pose (to the sampling of `dense`)


def test_path_at_constant_speed_and_heading_choice(tmp_path: Path) -> None:
    line = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    reference = path_reference(line, speed=0.5, heading="fixed")
    assert reference.end_time == pytest.approx(6.0)  # 3 m at 0.5 m/s, the duplicate dropped
    t = np.linspace(0.0, 6.0, 13)
    np.testing.assert_allclose(reference.sample(t).velocity[:, 0], 0.5, atol=1e-12)
    np.testing.assert_allclose(reference.sample(t).pose[:, 0], 0.5 * t, atol=1e-12)
    turn = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, math.pi / 2]])  # in place: 0.5 m/rad
    assert path_reference(turn, speed=0.25).end_time == pytest.approx(math.pi)
    bag = path_bag(tmp_path, s_curve(), StoragePlugin.MCAP)
    tangent = read_bag_reference(bag, speed=1.0, heading="tangent")
    velocity = tangent.sample(1.0).velocity
    assert tangent.sample(1.0).pose[2] == pytest.approx(math.atan2(velocity[1], velocity[0]))


@pytest.mark.parametrize("gap", [0.0, 1e-6, 0.05])
def test_a_path_that_ends_by_turning_in_place_stops_at_its_goal(gap: float) -> None:
    """nav2's last pose often only turns to the goal's yaw (at the last pose, or a little
    past it). The splines through a 3 m line and that turn swung 14 cm past the goal and
    back (measured); the position is held where a step mostly turns, so the robot stops at
    the goal and turns there."""
    line = np.stack([np.linspace(0.0, 3.0 - gap, 61), np.zeros(61), np.zeros(61)], axis=1)
    poses = np.vstack([line, [3.0, 0.0, math.pi / 2]])
    robot = preset("mecanum")
    reference = path_reference(poses, robot=robot, max_speed=1.0, samples=128)
    assert reference.end_time is not None
    dense = reference.sample(np.linspace(0.0, reference.end_time, 20001))
    assert dense.pose[:, 0].max() <= 3.0 + 1e-12 and np.abs(dense.pose[:, 1]).max() < 1e-12
    np.testing.assert_allclose(dense.pose[-1], [3.0, 0.0, math.pi / 2], atol=1e-12)
    assert feasibility(reference, robot, samples=4001).peak_ratio <= 1.0 + 1e-6
    turning = dense.pose[:, 2] > 1e-6  # from where the yaw moves, the position holds
    assert dense.pose[turning, 0].min() >= 3.0 - gap - 1e-12


def test_odometry_stream_becomes_a_timed_reference(tmp_path: Path, run: SimResult) -> None:
    bag = tmp_path / "run"
    write_bag(run, bag, start_stamp_ns=EPOCH)
    reference = read_bag_reference(bag, "/odom")
    assert reference.start_time == 0.0
    assert reference.end_time == pytest.approx(run.time[-1] - run.time[0], abs=1e-9)
    at = reference.sample(run.time - run.time[0])
    np.testing.assert_allclose(at.pose[:, :2], run.pose[:, :2], atol=1e-12)
    np.testing.assert_allclose(wrapped(at.pose[:, 2] - run.pose[:, 2]), 0.0, atol=1e-12)
    twists = body_twists(run.pose, run.dt)
    c, s = np.cos(run.pose[:, 2]), np.sin(run.pose[:, 2])
    np.testing.assert_allclose(at.velocity[:, 0], c * twists[:, 0] - s * twists[:, 1],
                               atol=1e-9)
    differenced = read_bag_reference(bag, "/odom", use_twist=False)
    np.testing.assert_allclose(differenced.sample(0.5).pose, reference.sample(0.5).pose,
                               atol=1e-3)


def test_missing_topic_lists_what_the_bag_has(tmp_path: Path) -> None:
    bag = path_bag(tmp_path, s_curve(), StoragePlugin.MCAP, extra=True)
    with pytest.raises(TrajectoryError) as error:
        read_bag_reference(bag, "/global_plan", speed=1.0)
    message = str(error.value)
    assert message == (f"ROS bag {str(bag)!r} has no topic '/global_plan'; topics: /cmd_vel "
                       "(geometry_msgs/msg/TwistStamped, 1 message), /plan (nav_msgs/msg/Path, "
                       "1 message)")
    with pytest.raises(TrajectoryError, match=r"topic '/cmd_vel' is geometry_msgs/msg/"
                                              r"TwistStamped, a reference needs nav_msgs/msg/"
                                              r"Path or nav_msgs/msg/Odometry"):
        read_bag_reference(bag, "/cmd_vel", speed=1.0)
    assert read_bag_reference(bag, speed=1.0).end_time is not None  # the only Path topic


def test_files_that_are_not_bags(tmp_path: Path, run: SimResult) -> None:
    text = tmp_path / "notes.txt"
    text.write_text("not a bag")
    with pytest.raises(TrajectoryError, match="not a readable ROS 1 or ROS 2 bag"):
        read_bag_reference(text, speed=1.0)
    (tmp_path / "empty").mkdir()
    with pytest.raises(TrajectoryError, match="not a readable ROS 1 or ROS 2 bag"):
        read_bag_reference(tmp_path / "empty", speed=1.0)
    with pytest.raises(TrajectoryError, match="does not exist"):
        read_bag_reference(tmp_path / "nothing", speed=1.0)
    write_bag(run, tmp_path / "run")
    with pytest.raises(TrajectoryError, match="2 Path or Odometry topics, give topic="):
        read_bag_reference(tmp_path / "run")


def test_bad_paths_and_timing_choices(tmp_path: Path) -> None:
    single = path_bag(tmp_path, np.array([[1.0, 2.0, 0.0], [1.0, 2.0, 0.0]]), StoragePlugin.MCAP)
    with pytest.raises(TrajectoryError, match=r"topic '/plan': a path needs at least 2 "
                                              "distinct poses"):
        read_bag_reference(single, "/plan", speed=1.0)
    with pytest.raises(TrajectoryError, match="give exactly one of robot="):
        path_reference(s_curve(), robot=preset("swerve"), speed=1.0)
    with pytest.raises(TrajectoryError, match="give exactly one of robot="):
        path_reference(s_curve())
    with pytest.raises(TrajectoryError, match="message 3 does not exist"):
        read_bag_reference(single, "/plan", speed=1.0, message=3)


def test_writing_refuses_bad_arguments(tmp_path: Path, run: SimResult) -> None:
    write_bag(run, tmp_path / "run")
    with pytest.raises(SimulationError, match="cannot write the bag"):
        write_bag(run, tmp_path / "run")
    with pytest.raises(SimulationError, match="wheel_names must be 4 non-empty strings"):
        write_bag(run, tmp_path / "other", wheel_names=["a", "b"])
    with pytest.raises(SimulationError, match="start_stamp_ns must be an integer"):
        write_bag(run, tmp_path / "other", start_stamp_ns=-1)
    names = ("w1", "w2", "w3", "w4")
    write_bag(run, tmp_path / "named", wheel_names=names)
    ((_, message), *_) = read_all(tmp_path / "named")["/mpc/wheel_limit"]
    assert tuple(message.name) == names


def test_without_rosbags_the_error_names_the_extra(tmp_path: Path, run: SimResult,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rosbags", None)  # as if not installed
    with pytest.raises(ImportError, match=r"pip install 'holonomic-mpc\[ros\]'"):
        read_bag_reference(tmp_path / "any", speed=1.0)
    with pytest.raises(ImportError, match=r"pip install 'holonomic-mpc\[ros\]'"):
        write_bag(run, tmp_path / "bag")
    assert not (tmp_path / "bag").exists()


def test_odometry_needs_increasing_stamps() -> None:
    def odometry(sec: int, nanosec: int, x: float) -> Any:
        return types.nav_msgs__msg__Odometry(
            header=types.std_msgs__msg__Header(
                stamp=types.builtin_interfaces__msg__Time(sec=sec, nanosec=nanosec),
                frame_id="odom"),
            child_frame_id="base_link",
            pose=types.geometry_msgs__msg__PoseWithCovariance(
                pose=types.geometry_msgs__msg__Pose(
                    position=types.geometry_msgs__msg__Point(x=x, y=0.0, z=0.0),
                    orientation=types.geometry_msgs__msg__Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
                covariance=np.zeros(36)),
            twist=types.geometry_msgs__msg__TwistWithCovariance(
                twist=types.geometry_msgs__msg__Twist(
                    linear=types.geometry_msgs__msg__Vector3(x=0.1, y=0.0, z=0.0),
                    angular=types.geometry_msgs__msg__Vector3(x=0.0, y=0.0, z=0.0)),
                covariance=np.zeros(36)))

    messages = [odometry(1_700_000_000, 0, 0.0), odometry(1_700_000_001, 0, 0.1),
                odometry(1_700_000_001, 0, 0.1)]
    with pytest.raises(TrajectoryError, match="odometry message 2: header.stamp "
                                              "1700000001000000000 ns is not after message 1's"):
        odometry_reference(messages)
    with pytest.raises(TrajectoryError, match="at least 2 messages, got 1"):
        odometry_reference(messages[:1])
    reference = odometry_reference(messages[:2])
    assert reference.end_time == 1.0
    np.testing.assert_allclose(reference.sample(0.5).pose, [0.05, 0.0, 0.0], atol=1e-15)
