"""The ROS 2 adapter on rosbags' message types: conversions, clock, wheel order, nav2 shape."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.typesys.stores import ros2_humble as types  # noqa: E402

from mpc import Controller  # noqa: E402
from mpc.adapters.ros import (  # noqa: E402
    ROS2_MECANUM_ORDER,
    Nav2Controller,
    ReferenceClock,
    copy_message,
    from_ros2_mecanum,
    joint_group_command,
    pose_from_message,
    quaternion_from_yaw,
    time_message,
    to_ros2_mecanum,
    twist_from_message,
    twist_message,
    twist_stamped,
    yaw_from_quaternion,
)
from mpc.errors import ControllerError  # noqa: E402
from mpc.robots import mecanum, preset  # noqa: E402
from mpc.sim import Plant, PlantConfig  # noqa: E402
from trajectories import Circle  # noqa: E402

EPOCH = 1_700_000_000_000_000_000  # [ns] ROS stamps are epoch time
DT = 0.05  # [s]


def quaternion(roll: float, pitch: float, yaw: float) -> Any:
    """ZYX Euler angles to a quaternion (the textbook formula, independent of the adapter)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return types.geometry_msgs__msg__Quaternion(
        x=sr * cp * cy - cr * sp * sy, y=cr * sp * cy + sr * cp * sy,
        z=cr * cp * sy - sr * sp * cy, w=cr * cp * cy + sr * sp * sy)


def pose_stamped(x: float, y: float, yaw: float, stamp_ns: int, frame: str = "map") -> Any:
    header = types.std_msgs__msg__Header(stamp=time_message(stamp_ns), frame_id=frame)
    return types.geometry_msgs__msg__PoseStamped(header=header, pose=types.geometry_msgs__msg__Pose(
        position=types.geometry_msgs__msg__Point(x=x, y=y, z=0.0),
        orientation=quaternion(0.0, 0.0, yaw)))


def path_message(poses: np.ndarray, frame: str = "map") -> Any:
    header = types.std_msgs__msg__Header(stamp=time_message(EPOCH), frame_id=frame)
    return types.nav_msgs__msg__Path(header=header, poses=[
        pose_stamped(float(x), float(y), float(t), EPOCH, frame) for x, y, t in poses])


def test_yaw_and_quaternion_agree_with_the_euler_formula() -> None:
    rng = np.random.default_rng(1)
    for angle in rng.uniform(-math.pi, math.pi, 50):
        assert yaw_from_quaternion(quaternion(0.0, 0.0, angle)) == pytest.approx(angle, abs=1e-12)
        x, y, z, w = quaternion_from_yaw(angle)
        q = quaternion(0.0, 0.0, angle)
        np.testing.assert_allclose([x, y, z, w], [q.x, q.y, q.z, q.w], atol=1e-15)
    # a small roll and pitch do not change the yaw (ZYX convention)
    assert yaw_from_quaternion(quaternion(0.02, -0.03, 1.0)) == pytest.approx(1.0, abs=1e-12)
    # a quaternion off unit length (a hand-written message) stands for its direction
    q = quaternion(0.02, -0.03, 2.5)
    scaled = types.geometry_msgs__msg__Quaternion(x=3 * q.x, y=3 * q.y, z=3 * q.z, w=3 * q.w)
    assert yaw_from_quaternion(scaled) == pytest.approx(2.5, abs=1e-12)
    # the zero quaternion (an unset orientation) is no rotation: refused, not yaw 0
    from trajectories import TrajectoryError

    zero = types.geometry_msgs__msg__Quaternion(x=0.0, y=0.0, z=0.0, w=0.0)
    with pytest.raises(TrajectoryError, match="quaternion must not be zero"):
        yaw_from_quaternion(zero)


def test_poses_and_twists_in_and_out() -> None:
    stamped = pose_stamped(1.5, -2.0, 2.5, EPOCH)
    np.testing.assert_allclose(pose_from_message(stamped), [1.5, -2.0, 2.5], atol=1e-12)
    np.testing.assert_allclose(pose_from_message(stamped.pose), [1.5, -2.0, 2.5], atol=1e-12)
    covariance = np.zeros(36)
    odometry = types.nav_msgs__msg__Odometry(
        header=stamped.header, child_frame_id="base_link",
        pose=types.geometry_msgs__msg__PoseWithCovariance(pose=stamped.pose,
                                                          covariance=covariance),
        twist=types.geometry_msgs__msg__TwistWithCovariance(
            twist=twist_message([0.3, -0.1, 0.7]), covariance=covariance))
    np.testing.assert_allclose(pose_from_message(odometry), [1.5, -2.0, 2.5], atol=1e-12)
    np.testing.assert_allclose(twist_from_message(odometry.twist.twist), [0.3, -0.1, 0.7])
    command = twist_stamped([0.3, -0.1, 0.7], stamped.header.stamp)
    assert command.header.frame_id == "base_link"
    assert (command.header.stamp.sec, command.header.stamp.nanosec) == (1_700_000_000, 0)
    np.testing.assert_allclose(twist_from_message(command), [0.3, -0.1, 0.7])
    target = SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(), frame_id=""),
                             twist=SimpleNamespace(linear=SimpleNamespace(),
                                                   angular=SimpleNamespace()))
    copied = copy_message(command, target)
    assert copied.header.frame_id == "base_link" and copied.twist.angular.z == 0.7
    assert copied.header.stamp.sec == 1_700_000_000


def test_mecanum_order_matches_the_ros2_controllers_kinematics() -> None:
    lx, ly, r = 0.2, 0.15, 0.05
    robot = mecanum(wheelbase=2 * lx, track=2 * ly, wheel_radius=r, max_wheel_speed=30.0)
    rng = np.random.default_rng(4)
    for vx, vy, wz in rng.uniform(-1.0, 1.0, (20, 3)):
        # mecanum_drive_controller's inverse kinematics, in its order FL, FR, RR, RL
        theirs = np.array([vx - vy - (lx + ly) * wz, vx + vy + (lx + ly) * wz,
                           vx - vy + (lx + ly) * wz, vx + vy - (lx + ly) * wz]) / r
        ours = robot.wheel_speeds(np.array([vx, vy, wz]))
        np.testing.assert_allclose(to_ros2_mecanum(ours), theirs, atol=1e-12)
        np.testing.assert_allclose(from_ros2_mecanum(theirs), ours, atol=1e-12)
    values = np.array([1.0, 2.0, 3.0, 4.0])  # ours FL, FR, RL, RR
    np.testing.assert_array_equal(to_ros2_mecanum(values), [1.0, 2.0, 4.0, 3.0])
    np.testing.assert_array_equal(from_ros2_mecanum(to_ros2_mecanum(values)), values)
    command = joint_group_command(values, ROS2_MECANUM_ORDER)
    np.testing.assert_array_equal(command.data, [1.0, 2.0, 4.0, 3.0])
    np.testing.assert_array_equal(joint_group_command(values).data, values)
    with pytest.raises(ControllerError, match="permutation"):
        joint_group_command(values, (0, 0, 1, 2))
    with pytest.raises(ControllerError, match="4 Mecanum wheel values"):
        to_ros2_mecanum([1.0, 2.0, 3.0])


def test_reference_clock_counts_from_its_start_in_exact_nanoseconds() -> None:
    clock = ReferenceClock()
    assert not clock.started
    assert clock(time_message(EPOCH + 123)) == 0.0
    assert clock(time_message(EPOCH + 123 + 1)) == 1e-9  # exact: no 1.7e9 s float rounding
    assert clock(time_message(EPOCH + 123 + 2_500_000_000)) == 2.5
    fixed = ReferenceClock(time_message(EPOCH), reference_start=4.0)
    assert fixed(time_message(EPOCH + 500_000_000)) == 4.5
    # epoch stamps through the clock give the commands of the reference's own time
    robot = preset("mecanum")
    reference = Circle(1.0, 12.0, heading=0.0)
    direct, through = Controller(robot, reference), Controller(robot, reference)
    clock = ReferenceClock()
    pose = reference.sample(0.0).pose + [0.05, 0.0, 0.0]
    for k in range(5):
        expected = direct.step(pose, k * DT).twist
        got = through.step(pose, clock(time_message(EPOCH + k * 50_000_000))).twist
        np.testing.assert_array_equal(got, expected)


def s_poses(count: int = 50) -> np.ndarray:
    s = np.linspace(0.0, 1.0, count)
    return np.stack([2.0 * s, 0.6 * np.sin(np.pi * s), 0.5 * s], axis=1)


def drive(follower: Nav2Controller, start: np.ndarray, ticks: int,
          first_tick: int = 0) -> tuple[Plant, list[float], np.ndarray]:
    """Closed loop with the ideal plant: PoseStamped in, TwistStamped out, epoch stamps.
    Returns the plant, the position errors [m] and the poses given to the follower."""
    robot = follower.robot
    plant = Plant(robot, DT, start, PlantConfig(), np.random.default_rng(0))
    errors, poses = [], []
    for k in range(first_tick, first_tick + ticks):
        pose = plant.pose
        stamp = EPOCH + k * 50_000_000
        x, y, theta = (float(v) for v in pose)
        out = follower.compute_velocity_commands(pose_stamped(x, y, theta, stamp), None)
        assert out.header.frame_id == "base_link" and out.header.stamp.nanosec == stamp % 10**9
        assert follower.last_command is not None
        np.testing.assert_array_equal(twist_from_message(out), follower.last_command.twist)
        plant.apply(follower.last_command)
        reference = follower.trajectory.sample(follower.clock.at(time_message(stamp)))
        errors.append(float(np.hypot(*(pose[:2] - reference.pose[:2]))))
        poses.append(pose)
    return plant, errors, np.array(poses)


def test_nav2_controller_follows_a_plan_within_limits() -> None:
    robot = preset("mecanum")
    follower = Nav2Controller(robot, dt=DT)
    assert not follower.has_plan
    follower.set_plan(path_message(s_poses()))
    duration = follower.trajectory.end_time
    assert duration is not None
    plant, errors, _ = drive(follower, s_poses()[0], int(duration / DT) + 10)
    # The plan is timed time-optimally, at the wheel limits all along: measured 5.0 mm at
    # worst with the default 0.1 s stages of the plan.
    assert max(errors) < 7e-3
    np.testing.assert_allclose(plant.pose, s_poses()[-1], atol=2e-3)
    assert follower.is_finished(time_message(EPOCH + int((duration + 0.1) * 1e9)))
    assert not follower.is_finished(time_message(EPOCH + int(0.5 * duration * 1e9)))


def path_speeds(reference: Any, start: float) -> np.ndarray:
    velocity = reference.sample(np.linspace(start, reference.end_time, 4001)).velocity
    return np.hypot(velocity[:, 0], velocity[:, 1])


def test_speed_limit_slows_the_plan_where_it_is() -> None:
    robot = preset("mecanum")
    follower = Nav2Controller(robot, dt=DT, max_speed=0.8)
    follower.set_plan(path_message(s_poses()))
    plan = follower.trajectory
    peak = float(path_speeds(plan, 0.0).max())
    assert 0.5 < peak <= 0.8 + 1e-6  # time-optimal within max_speed
    plant, _, _ = drive(follower, s_poses()[0], 20)
    now = follower.clock.at(time_message(EPOCH + 19 * 50_000_000))
    follower.set_speed_limit(50.0, percentage=True)  # 0.4 m/s
    slowed = follower.trajectory
    np.testing.assert_allclose(slowed.sample(now).pose, plan.sample(now).pose, atol=1e-12)
    np.testing.assert_allclose(slowed.sample(now).velocity[:2],
                               plan.sample(now).velocity[:2] * 0.4 / peak, rtol=1e-3)
    assert path_speeds(slowed, now).max() <= 0.4 * (1 + 1e-3)
    assert slowed.end_time is not None
    np.testing.assert_allclose(slowed.sample(slowed.end_time).pose, s_poses()[-1], atol=1e-12)
    _, errors, poses = drive(follower, plant.pose, 60, first_tick=20)
    speeds = np.hypot(*np.diff(poses[:, :2], axis=0).T) / DT
    assert speeds[20:].max() <= 0.4 * 1.01  # braked to the limit within a second
    assert max(errors[20:]) < 2e-3
    follower.set_speed_limit(0.0, percentage=False)  # no limit: the plan's own pace again
    assert follower.speed_limit is None
    later = follower.clock.at(time_message(EPOCH + 79 * 50_000_000))
    assert path_speeds(follower.trajectory, later).max() > 0.4 * 1.2


def test_nav2_controller_at_constant_speed_and_its_errors() -> None:
    robot = preset("mecanum")
    follower = Nav2Controller(robot, dt=DT, speed=0.3)
    with pytest.raises(ControllerError, match="no plan yet"):
        follower.compute_velocity_commands(pose_stamped(0.0, 0.0, 0.0, EPOCH))
    follower.set_plan(path_message(np.array([[0.0, 0.0, 0.0], [0.6, 0.0, 0.0]])))
    assert follower.trajectory.end_time == pytest.approx(2.0)
    with pytest.raises(ControllerError, match="the pose is in frame 'odom' but the plan in "
                                              "'map'"):
        follower.compute_velocity_commands(pose_stamped(0.0, 0.0, 0.0, EPOCH, "odom"))
    moving = twist_message([0.3, 0.0, 0.0])
    out = follower.compute_velocity_commands(pose_stamped(0.0, 0.0, 0.0, EPOCH), moving)
    assert twist_from_message(out)[0] == pytest.approx(0.3, abs=0.05)
    with pytest.raises(ControllerError, match="percentage speed limit needs max_speed"):
        follower.set_speed_limit(50.0, percentage=True)
    follower.set_speed_limit(0.1, percentage=False)
    assert follower.trajectory.end_time == pytest.approx(6.0)  # from t = 0 at a third
    follower.set_plan(path_message(np.array([[0.0, 0.0, 0.0], [0.6, 0.0, 0.0]])))
    assert follower.trajectory.end_time == pytest.approx(6.0)  # new plans within the limit


def straight_poses(start: float, end: float = 6.0) -> np.ndarray:
    count = max(2, int(round((end - start) / 0.05)) + 1)
    return np.stack([np.linspace(start, end, count), np.zeros(count), np.zeros(count)], axis=1)


@pytest.mark.parametrize("mode", ["time", "path"])
def test_plans_again_every_second_keep_the_robot_at_speed(mode: str) -> None:
    """nav2 plans again about once a second from a robot pose a moment old: each new plan
    starts at the pose nearest the robot and at its speed along it, so the robot keeps its
    pace (it fell to 0.40 m/s after each plan when every plan was timed from rest, and
    arrived 1.8 s late on 6 m)."""
    robot = preset("mecanum")
    follower = Nav2Controller(robot, dt=DT, max_speed=1.0, mode=mode)
    plant = Plant(robot, DT, np.zeros(3), PlantConfig(), np.random.default_rng(0))
    follower.set_plan(path_message(straight_poses(0.0)))
    seen: list[np.ndarray] = []
    speeds: list[float] = []
    for k in range(140):
        if k and k % 20 == 0 and len(seen) > 4:  # a plan from the pose 4 ticks (0.2 s) old
            follower.set_plan(path_message(straight_poses(float(seen[-5][0]))))
        pose = plant.pose
        seen.append(pose)
        x, y, theta = (float(v) for v in pose)
        follower.compute_velocity_commands(pose_stamped(x, y, theta, EPOCH + k * 50_000_000))
        assert follower.last_command is not None
        plant.apply(follower.last_command)
        speeds.append(float(follower.last_command.twist[0]))
    assert min(speeds[30:110]) > 0.97  # at the cap between the first second and the goal
    assert plant.pose[0] == pytest.approx(6.0, abs=0.01)  # there by 7 s (6.5 s from rest)


def test_raising_a_speed_limit_speeds_up_a_plan_timed_under_it() -> None:
    """A plan timed within a limit is timed again, from where its reference is, when the
    limit is raised or removed: nav2's speed zones end."""
    robot = preset("mecanum")
    follower = Nav2Controller(robot, dt=DT, max_speed=1.0)
    follower.set_speed_limit(0.3, percentage=False)
    follower.set_plan(path_message(straight_poses(0.0)))
    assert path_speeds(follower.trajectory, 0.0).max() == pytest.approx(0.3, rel=1e-3)
    plant, _, _ = drive(follower, np.zeros(3), 40)
    now = follower.clock.at(time_message(EPOCH + 39 * 50_000_000))
    where = follower.trajectory.sample(now)
    follower.set_speed_limit(0.0, percentage=False)
    faster = follower.trajectory
    assert faster.start_time == 0.0  # timed again, from the reference's pose and speed
    np.testing.assert_allclose(faster.sample(0.0).pose, where.pose, atol=1e-9)
    assert float(np.hypot(*faster.sample(0.0).velocity[:2])) == pytest.approx(
        float(np.hypot(*where.velocity[:2])), rel=1e-3)
    assert path_speeds(faster, 0.0).max() == pytest.approx(1.0, rel=1e-3)
    _, errors, _ = drive(follower, plant.pose, 60, first_tick=40)
    assert max(errors) < 0.02


def test_copy_message_fills_messages_with_slots_only() -> None:
    """rclpy messages have slots for their own fields: rosbags' ``__msgtype__`` is not one,
    and a ``float64[]`` takes a sequence, not a NumPy array."""

    def slotted(name: str, fields: dict[str, Any]) -> Any:
        cls = type(name, (), {"__slots__": list(fields)})
        item = cls()
        for field, value in fields.items():
            setattr(item, field, value)
        return item

    time = slotted("Time", {"sec": 0, "nanosec": 0})
    header = slotted("Header", {"stamp": time, "frame_id": ""})
    vector = [slotted("Vector3", {"x": 0.0, "y": 0.0, "z": 0.0}) for _ in range(2)]
    twist = slotted("Twist", {"linear": vector[0], "angular": vector[1]})
    target = copy_message(twist_stamped([0.3, -0.1, 0.7], time_message(EPOCH)),
                          slotted("TwistStamped", {"header": header, "twist": twist}))
    assert (target.twist.linear.x, target.twist.angular.z) == (0.3, 0.7)
    assert target.header.frame_id == "base_link" and target.header.stamp.sec == EPOCH // 10**9
    array = slotted("Float64MultiArray", {
        "layout": slotted("MultiArrayLayout", {"dim": [], "data_offset": 0}), "data": []})
    copied = copy_message(joint_group_command([1.0, 2.0, 3.0, 4.0]), array)
    assert copied.data == [1.0, 2.0, 3.0, 4.0] and isinstance(copied.data, list)
    with pytest.raises(ControllerError, match="twist must have shape"):
        twist_message([1.0, 2.0])


def test_a_plan_after_a_pause_starts_from_rest(monkeypatch: pytest.MonkeyPatch) -> None:
    """A command older than STALE_TICKS periods (a cancelled goal: the robot stopped) says
    nothing of the robot now: the next plan starts from rest at its own first pose."""
    import mpc.adapters.ros.nav2 as nav2

    robot = preset("mecanum")
    follower = Nav2Controller(robot, dt=DT, max_speed=1.0)
    follower.set_plan(path_message(straight_poses(0.0)))
    drive(follower, np.zeros(3), 40)  # under way at ~1 m/s
    now = nav2.time.monotonic()
    monkeypatch.setattr(nav2.time, "monotonic", lambda: now + nav2.STALE_TICKS * DT + 1.0)
    follower.set_plan(path_message(straight_poses(1.0)))
    start = follower.trajectory.sample(0.0)
    assert float(np.hypot(*start.velocity[:2])) == 0.0
    np.testing.assert_allclose(start.pose, [1.0, 0.0, 0.0], atol=1e-12)


def test_a_first_plan_for_a_robot_under_way_takes_its_measured_speed() -> None:
    """A Nav2Controller switched in while the robot moves: its first plan has no command to
    read the speed from and is timed from rest; the first measured velocity along it times
    it again from that speed, so the robot keeps its pace (with no velocity given, the plan
    stays timed from rest and the robot is braked to its start)."""
    robot = preset("mecanum")
    speeds: dict[bool, list[float]] = {}
    for given in (True, False):
        follower = Nav2Controller(robot, dt=DT, max_speed=1.0)
        plant = Plant(robot, DT, np.zeros(3), PlantConfig(), np.random.default_rng(0))
        follower.set_plan(path_message(straight_poses(0.0)))
        assert float(np.hypot(*follower.trajectory.sample(0.0).velocity[:2])) == 0.0
        speeds[given] = []
        twist = np.array([1.0, 0.0, 0.0])  # under way at 1 m/s along the path
        for k in range(30):
            x, y, theta = (float(v) for v in plant.pose)
            moving = twist_message(twist) if given else None
            follower.compute_velocity_commands(pose_stamped(x, y, theta, EPOCH + k * 50_000_000),
                                               moving)
            assert follower.last_command is not None
            plant.apply(follower.last_command)  # the ideal plant: at the command at once
            twist = follower.last_command.twist
            speeds[given].append(float(twist[0]))
        if given:
            start = follower.trajectory.sample(0.0)
            assert float(np.hypot(*start.velocity[:2])) == pytest.approx(1.0, rel=1e-3)
    assert min(speeds[True]) > 0.97
    assert min(speeds[False]) < 0.5
    backwards = Nav2Controller(robot, dt=DT, max_speed=1.0)  # moving away from the path
    backwards.set_plan(path_message(straight_poses(0.0)))
    backwards.compute_velocity_commands(pose_stamped(0.0, 0.0, 0.0, EPOCH),
                                        twist_message([-0.5, 0.0, 0.0]))
    assert float(np.hypot(*backwards.trajectory.sample(0.0).velocity[:2])) == 0.0
