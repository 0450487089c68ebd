"""The founding documents' robots (docs/guide/adapters.md) as presets: our wheel
commands, converted to each source's order, signs and units, against the source's own
equations, written out here from the documents (not from our kinematics)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from benchmarks.scenarios import reference
from mpc import Controller
from mpc.errors import RobotError
from mpc.robots import CONVENTIONS, SwedishRobot, WheelConvention, preset, wheel_convention
from mpc.sim import simulate
from trajectories import FigureEight

TWISTS = np.random.default_rng(41).uniform(-2.0, 2.0, size=(100, 3))  # (vx, vy, omega)


def test_jetauto_driver_equations() -> None:
    # JetAuto's controller/mecanum.py: wheelbase 0.216 m, track 0.195 m, 97 mm wheels.
    robot = preset("jetauto")
    wheelbase, track, diameter = 0.216, 0.195, 0.097
    k = (wheelbase + track) / 2.0
    vx, vy, wz = TWISTS.T
    v1 = vx - vy - k * wz  # left front
    v2 = vx + vy - k * wz  # left rear
    v3 = vx + vy + k * wz  # right front
    v4 = vx - vy + k * wz  # right rear
    rps = np.stack([v1, v2, -v3, -v4], axis=1) / (math.pi * diameter)
    ours = robot.wheel_speeds(TWISTS)
    np.testing.assert_allclose(CONVENTIONS["jetauto"].from_ours(ours), rps, rtol=0, atol=1e-12)
    assert CONVENTIONS["jetauto"].ids == (1, 2, 3, 4)
    # The motor limit: 1.5 rps by default, another by override.
    np.testing.assert_allclose(np.abs(CONVENTIONS["jetauto"].from_ours(robot.max_wheel_speed)),
                               1.5)
    faster = preset("jetauto", max_wheel_speed=2.0 * 2.0 * math.pi)
    np.testing.assert_allclose(faster.max_wheel_speed, 4.0 * math.pi)


def test_kosen_mecanum_notes() -> None:
    # Wheels 1 = front right, then counter-clockwise; phi is the front-right wheel's angle
    # from the centre and R its distance, in the notes' frame (x right, y forward).
    robot = preset("kosen-mecanum")
    lx, ly = 0.15, 0.125  # half wheelbase, half track [m]
    radius_r, phi = math.hypot(lx, ly), math.atan2(lx, ly)
    spin = radius_r * (math.sin(phi) + math.cos(phi))
    vx_notes, vy_notes = -TWISTS[:, 1], TWISTS[:, 0]  # x right = -our y, y forward = our x
    omega = TWISTS[:, 2]
    vw = np.stack([-vx_notes + vy_notes + spin * omega,
                   vx_notes + vy_notes - spin * omega,
                   -vx_notes + vy_notes - spin * omega,
                   vx_notes + vy_notes + spin * omega], axis=1)
    convention = CONVENTIONS["kosen-mecanum"]
    ours = robot.wheel_speeds(TWISTS)
    np.testing.assert_allclose(convention.from_ours(ours, wheel_radius=0.05), vw, rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(convention.twist_to_source(TWISTS),
                               np.stack([vx_notes, vy_notes, omega], axis=1), atol=0)


def test_kosen_omni_notes() -> None:
    # Vw = -sin(theta) Vx + cos(theta) Vy + R omega, wheels at 45, 135, 225, 315 deg in the
    # notes' frame (x right, y forward), wheel 1 front right.
    robot = preset("kosen-omni4")
    base = 0.20
    theta = np.radians([45.0, 135.0, 225.0, 315.0])
    vx_notes, vy_notes, omega = -TWISTS[:, 1], TWISTS[:, 0], TWISTS[:, 2]
    vw = (-np.sin(theta) * vx_notes[:, None] + np.cos(theta) * vy_notes[:, None]
          + base * omega[:, None])
    ours = robot.wheel_speeds(TWISTS)
    np.testing.assert_allclose(CONVENTIONS["kosen-omni4"].from_ours(ours, wheel_radius=0.05),
                               vw, rtol=0, atol=1e-12)
    # Wheel 1 is at the front right: its centre in REP-103 has x > 0, y < 0.
    x, y = robot.wheel_positions[0]
    assert x > 0 > y


def _siegwart_rotation(theta: float) -> np.ndarray:
    """Siegwart's R(theta): world velocities into the robot frame."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def test_swedish3_tutorial_rolling_constraints() -> None:
    robot = preset("swedish3")
    r, length = 0.03, 0.15
    alphas = np.radians([60.0, -60.0, 180.0])
    beta = gamma = 0.0
    rng = np.random.default_rng(7)
    for world_rate in TWISTS:
        theta = rng.uniform(-math.pi, math.pi)
        body = _siegwart_rotation(theta) @ world_rate
        phidot = robot.wheel_speeds(body)
        for alpha, rate in zip(alphas, phidot, strict=True):
            row = np.array([math.sin(alpha + beta + gamma), -math.cos(alpha + beta + gamma),
                            -length * math.cos(beta + gamma)])
            residual = row @ _siegwart_rotation(theta) @ world_rate - r * rate * math.cos(gamma)
            assert abs(residual) < 1e-12


def _swedish3() -> SwedishRobot:
    robot = preset("swedish3")
    assert isinstance(robot, SwedishRobot)
    return robot


def test_swedish3_tutorial_forward_kinematics() -> None:
    robot = _swedish3()
    r, length = 0.03, 0.15
    rng = np.random.default_rng(8)
    phidot = rng.uniform(-30.0, 30.0, size=(100, 3))
    v = CONVENTIONS["swedish3"].from_ours(phidot, wheel_radius=r)  # v_i = r phidot_i
    v1, v2, v3 = v.T
    expected = np.stack([(v1 - v2) / math.sqrt(3.0), (2.0 * v3 - v1 - v2) / 3.0,
                         -(v1 + v2 + v3) / (3.0 * length)], axis=1)
    np.testing.assert_allclose(robot.twist(phidot), expected, rtol=0, atol=1e-12)


def test_swedish3_tutorial_misprinted_row_is_not_followed() -> None:
    # The tutorial's instantaneous-centre method prints y_dot_R's row as
    # (-v1/sqrt(3), -v2/sqrt(3), 2 v3/3); its own per-wheel components (v_y2 = -v2/3) and
    # the rolling constraints give (-v1/3, -v2/3, 2 v3/3). The preset follows the latter.
    robot = _swedish3()
    v = np.array([0.4, -0.2, 0.3])
    y_rate = robot.twist(v / 0.03)[1]
    assert y_rate == pytest.approx((2 * v[2] - v[0] - v[1]) / 3.0, abs=1e-12)
    misprint = -v[0] / math.sqrt(3.0) - v[1] / math.sqrt(3.0) + 2.0 * v[2] / 3.0
    assert abs(y_rate - misprint) > 1e-2


@pytest.mark.parametrize("name", sorted(CONVENTIONS))
def test_conventions_round_trip(name: str) -> None:
    convention = CONVENTIONS[name]
    speeds = np.random.default_rng(3).uniform(-20, 20, size=(5, convention.n_wheels))
    source = convention.from_ours(speeds, wheel_radius=0.05)
    np.testing.assert_allclose(convention.to_ours(source, wheel_radius=0.05), speeds,
                               rtol=1e-14, atol=1e-12)
    assert preset(name).n_wheels == convention.n_wheels


def test_convention_errors() -> None:
    with pytest.raises(RobotError, match="unknown wheel convention 'jetuato'"):
        wheel_convention("jetuato")
    with pytest.raises(RobotError, match="m/s at the rim: pass wheel_radius"):
        CONVENTIONS["kosen-mecanum"].from_ours(np.zeros(4))
    with pytest.raises(RobotError, match=r"shape \(4,\) or \(k, 4\), got \(3,\)"):
        CONVENTIONS["jetauto"].from_ours(np.zeros(3))
    with pytest.raises(RobotError, match="finite"):
        CONVENTIONS["jetauto"].from_ours([0.0, math.nan, 0.0, 0.0])
    with pytest.raises(RobotError, match="permutation"):
        WheelConvention("bad", ("a", "b"), order=(0, 0), signs=(1.0, 1.0), unit="rad/s")
    with pytest.raises(RobotError, match="unit must be one of"):
        WheelConvention("bad", ("a", "b"), order=(0, 1), signs=(1.0, 1.0), unit="rpm")


def test_jetauto_closed_loop_inside_and_beyond() -> None:
    robot = preset("jetauto")
    inside = reference("figure8", "fixed", robot, 0.8)
    assert isinstance(inside, FigureEight)
    controller = Controller(robot, inside, horizon=20, dt=0.05)
    result = simulate(controller, duration=inside.period)
    assert result.metrics()["rms_position_error"] <= 2e-3
    beyond = reference("figure8", "fixed", robot, 1.3)
    assert isinstance(beyond, FigureEight)
    controller = Controller(robot, beyond, horizon=20, dt=0.05)
    command_rps = []
    pose = beyond.sample(0.0).pose
    for k in range(round(beyond.period / 0.05)):
        command = controller.step(pose, k * 0.05)
        command_rps.append(command.wheel_speeds_as("jetauto"))
        pose = pose + 0.05 * _world(pose[2]) @ command.twist
    assert np.max(np.abs(command_rps)) <= 1.5 * (1.0 + 1e-9)
    assert np.max(np.abs(command_rps)) >= 1.5 * 0.99  # the run does reach the limit


def _world(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# --------------------------------------------------------------------------- JetAuto on ROS 2

EPOCH = 1_700_000_000_000_000_000  # [ns] ROS stamps are epoch time


def _readme_block(marker: str) -> str:
    """The python block after ``marker`` in the adapters guide (it was the README's)."""
    text = (Path(__file__).parents[1] / "docs" / "guide" / "adapters.md").read_text("utf-8")
    start = text.index("```python\n", text.index(marker)) + len("```python\n")
    return text[start:text.index("```", start)]


def _driver_twist(rps: dict[int, float]) -> np.ndarray:
    """The body twist JetAuto's wheels drive for motor speeds [rev/s] by id, from its
    driver's own equations run backwards (independent of our kinematics)."""
    k, diameter = (0.216 + 0.195) / 2.0, 0.097
    v1, v2 = rps[1] * math.pi * diameter, rps[2] * math.pi * diameter
    v3, v4 = -rps[3] * math.pi * diameter, -rps[4] * math.pi * diameter
    return np.array([(v1 + v2 + v3 + v4) / 4.0, (-v1 + v2 + v3 - v4) / 4.0,
                     (-v1 - v2 + v3 + v4) / (4.0 * k)])


class _SimulatedJetAuto:
    """rclpy's few calls the README's node makes, over a JetAuto simulated from its motor
    messages: each spin tick publishes /odom, fires the timer, then drives the published
    rev/s for the timer's period (ten Euler substeps)."""

    def __init__(self, ticks: int) -> None:
        self.ticks = ticks
        self.subscriptions: dict[str, Any] = {}
        self.timer: tuple[float, Any] | None = None
        self.sent: list[tuple[str, Any]] = []
        self.poses: list[np.ndarray] = []
        self.rps: list[list[float]] = []

    # rclpy
    def init(self) -> None:
        pass

    def create_node(self, name: str) -> _SimulatedJetAuto:
        return self

    def spin(self, node: object) -> None:
        assert self.timer is not None
        period, tick = self.timer
        pose = np.zeros(3)
        for k in range(self.ticks):
            self.subscriptions["/odom"](_odometry(pose, EPOCH + round(k * period * 1e9)))
            tick()
            topic, message = self.sent[-1]
            assert topic == "/ros_robot_controller/set_motor"
            speeds = {motor.id: motor.rps for motor in message.data}
            self.poses.append(pose.copy())
            self.rps.append(list(speeds.values()))
            twist = _driver_twist(speeds)
            for _ in range(10):
                pose = pose + period / 10 * _world(pose[2]) @ twist

    # the node
    def create_publisher(self, kind: type, topic: str, depth: int) -> Any:
        return SimpleNamespace(publish=lambda message: self.sent.append((topic, message)))

    def create_subscription(self, kind: type, topic: str, callback: Any, depth: int) -> None:
        self.subscriptions[topic] = callback

    def create_timer(self, period: float, callback: Any) -> None:
        self.timer = (period, callback)


def _odometry(pose: np.ndarray, stamp: int) -> Any:
    from rosbags.typesys.stores import ros2_humble as types

    from mpc.adapters.ros import quaternion_from_yaw, time_message

    header = types.std_msgs__msg__Header(stamp=time_message(stamp), frame_id="odom")
    point = types.geometry_msgs__msg__Point(x=float(pose[0]), y=float(pose[1]), z=0.0)
    covariance = np.zeros(36)
    x, y, z, w = quaternion_from_yaw(pose[2])
    orientation = types.geometry_msgs__msg__Quaternion(x=x, y=y, z=z, w=w)
    pose_message = types.geometry_msgs__msg__PoseWithCovariance(
        pose=types.geometry_msgs__msg__Pose(position=point, orientation=orientation),
        covariance=covariance)
    zero = types.geometry_msgs__msg__Vector3(x=0.0, y=0.0, z=0.0)
    twist = types.geometry_msgs__msg__TwistWithCovariance(
        twist=types.geometry_msgs__msg__Twist(linear=zero, angular=zero), covariance=covariance)
    return types.nav_msgs__msg__Odometry(header=header, child_frame_id="base_footprint",
                                         pose=pose_message, twist=twist)


def test_readme_jetauto_node_tracks_from_odometry(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("rosbags")
    from rosbags.typesys.stores import ros2_humble as types

    from mpc.adapters.ros import jetauto_typestore
    from mpc.adapters.ros.jetauto import MOTOR_STATE, MOTORS_STATE

    robot_io = _SimulatedJetAuto(ticks=800)  # 40 s: one lap
    store = jetauto_typestore()
    monkeypatch.setitem(sys.modules, "rclpy", robot_io)
    monkeypatch.setitem(sys.modules, "nav_msgs.msg",
                        SimpleNamespace(Odometry=types.nav_msgs__msg__Odometry))
    monkeypatch.setitem(sys.modules, "ros_robot_controller_msgs.msg",
                        SimpleNamespace(MotorState=store.types[MOTOR_STATE],
                                        MotorsState=store.types[MOTORS_STATE]))
    monkeypatch.setitem(sys.modules, "nav_msgs", SimpleNamespace())
    monkeypatch.setitem(sys.modules, "ros_robot_controller_msgs", SimpleNamespace())
    exec(compile(_readme_block("<!-- jetauto-node -->"), "adapters.md", "exec"), {})
    poses = np.array(robot_io.poses)
    reference = FigureEight(0.5, 40.0).sample(0.05 * np.arange(len(poses))).pose
    error = np.hypot(*(poses[:, :2] - reference[:, :2]).T)
    assert np.sqrt(np.mean(error**2)) < 1e-3
    assert np.max(np.abs(robot_io.rps)) <= 1.5 * (1 + 1e-9)
    assert [motor.id for motor in robot_io.sent[-1][1].data] == [1, 2, 3, 4]


def test_motors_state_message_serialises() -> None:
    pytest.importorskip("rosbags")
    from mpc.adapters.ros import jetauto_motors, jetauto_typestore, motors_state
    from mpc.adapters.ros.jetauto import MOTORS_STATE
    from mpc.errors import ControllerError

    speeds = preset("jetauto").wheel_speeds([0.2, 0.1, 0.5])
    message = motors_state(speeds)
    store = jetauto_typestore()
    back = store.deserialize_cdr(store.serialize_cdr(message, MOTORS_STATE), MOTORS_STATE)
    assert [(m.id, m.rps) for m in back.data] == jetauto_motors(speeds)
    np.testing.assert_allclose([m.rps for m in back.data],
                               CONVENTIONS["jetauto"].from_ours(speeds), atol=0)
    with pytest.raises(ControllerError, match=r"4 wheel speeds \[rad/s\] expected"):
        jetauto_motors(np.zeros((2, 4)))


def test_benchmark_runs_jetauto(tmp_path: Path) -> None:
    from benchmarks.cli import main

    out = tmp_path / "out"
    # in this process: two short runs take less than starting worker processes (the
    # process pool has tests of its own: test_executor.py, test_cli.py's Choreo run)
    assert main(["--layouts", "jetauto", "--trajectories", "figure8", "--speeds", "beyond",
                 "--controllers", "mpc-daqp,ff-p-clip", "--duration", "3", "--no-report",
                 "--workers", "1", "--out", str(out)]) == 0
    runs = json.loads((out / "results.json").read_text())["runs"]
    assert {run["layout"] for run in runs} == {"jetauto"}
    assert {run["controller"] for run in runs} == {"mpc-daqp", "ff-p-clip"}
    assert all(run["metrics"]["max_wheel_speed_ratio"] <= 1.0 + 1e-6 for run in runs)
