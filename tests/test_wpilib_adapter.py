"""The WPILib adapter against WPILib itself (robotpy-wpimath; skipped without it)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("wpimath")

from wpimath.geometry import Pose2d, Rotation2d, Translation2d, Twist2d  # noqa: E402
from wpimath.kinematics import (  # noqa: E402
    ChassisSpeeds,
    MecanumDriveKinematics,
    MecanumDriveWheelSpeeds,
    SwerveDrive3Kinematics,
    SwerveDrive4Kinematics,
    SwerveModuleState,
)
from wpimath.trajectory import Trajectory as WpilibTrajectory  # noqa: E402
from wpimath.trajectory import TrajectoryConfig, TrajectoryGenerator  # noqa: E402
from wpimath.trajectory.constraint import CentripetalAccelerationConstraint  # noqa: E402

from mpc import Controller  # noqa: E402
from mpc.adapters.wpilib import (  # noqa: E402
    MpcFollower,
    WpilibReference,
    chassis_speeds_from_twist,
    mecanum_wheel_speeds,
    pose2d_from_pose,
    pose_from_pose2d,
    reference_from_wpilib_trajectory,
    robot_from_mecanum_kinematics,
    robot_from_swerve_kinematics,
    swerve_module_states,
    twist_from_chassis_speeds,
)
from mpc.errors import ControllerError, RobotError, TrajectoryError  # noqa: E402
from mpc.robots import SwedishRobot, SwerveRobot, mecanum, preset  # noqa: E402
from trajectories import Circle, Trajectory  # noqa: E402

CORNERS = [(0.3, 0.3), (0.3, -0.3), (-0.3, 0.3), (-0.3, -0.3)]  # [m] FL, FR, RL, RR
MECANUM_CORNERS = [(0.15, 0.125), (0.15, -0.125), (-0.15, 0.125), (-0.15, -0.125)]
RADIUS = 0.05  # [m]


def translations(points: list[tuple[float, float]] | np.ndarray) -> list[Translation2d]:
    return [Translation2d(float(x), float(y)) for x, y in points]


def swerve_robot(points: list[tuple[float, float]] | np.ndarray = CORNERS) -> SwerveRobot:
    kinematics = SwerveDrive4Kinematics(*translations(points))
    return robot_from_swerve_kinematics(kinematics, wheel_radius=RADIUS, max_wheel_speed=30.0,
                                        max_steer_rate=12.0, max_wheel_accel=60.0)


def mecanum_robot(points: list[tuple[float, float]] | np.ndarray = MECANUM_CORNERS
                  ) -> SwedishRobot:
    kinematics = MecanumDriveKinematics(*translations(points))
    return robot_from_mecanum_kinematics(kinematics, wheel_radius=RADIUS, max_wheel_speed=20.0,
                                         max_wheel_accel=40.0)


def velocities(states: list[SwerveModuleState] | tuple[SwerveModuleState, ...]) -> np.ndarray:
    """Module velocity vectors (n, 2) [m/s]: comparable whatever the flip."""
    return np.array([(s.speed * s.angle.cos(), s.speed * s.angle.sin()) for s in states])


def mecanum_array(speeds: MecanumDriveWheelSpeeds) -> np.ndarray:
    return np.array([speeds.frontLeft, speeds.frontRight, speeds.rearLeft, speeds.rearRight])


def random_twists(rng: np.random.Generator, n: int, scale: float = 1.0) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, (n, 3)) * np.array([1.5, 1.5, 3.0]) * scale


# ---------------------------------------------------------------- conversions


def test_pose_and_speeds_round_trip() -> None:
    rng = np.random.default_rng(1)
    for x, y, theta in rng.uniform(-4.0, 4.0, (50, 3)):
        pose = pose_from_pose2d(Pose2d(x, y, Rotation2d(theta)))
        wrapped = math.remainder(theta, 2.0 * math.pi)
        np.testing.assert_array_equal(pose, [x, y, theta])  # Rotation2d keeps its angle
        back = pose2d_from_pose(pose)
        assert (back.X(), back.Y(), back.rotation().radians()) == (x, y, theta)
        composed = pose_from_pose2d(Pose2d().transformBy(back - Pose2d()))  # via cos, sin
        np.testing.assert_allclose(composed, [x, y, wrapped], rtol=0.0, atol=1e-12)
    for twist in random_twists(rng, 50):
        speeds = chassis_speeds_from_twist(twist)
        assert (speeds.vx, speeds.vy, speeds.omega) == tuple(twist)
        np.testing.assert_array_equal(twist_from_chassis_speeds(speeds), twist)


def test_conversions_refuse_wrong_types() -> None:
    with pytest.raises(ControllerError, match="Pose2d"):
        pose_from_pose2d((1.0, 2.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match="ChassisSpeeds"):
        twist_from_chassis_speeds((1.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match=r"3 finite numbers \(x, y, theta\)"):
        pose2d_from_pose([1.0, math.nan, 0.0])
    with pytest.raises(ControllerError, match="vx, vy, omega"):
        chassis_speeds_from_twist([1.0, 2.0])


# ---------------------------------------------------------------- kinematics


def test_swerve_kinematics_agree_with_wpilib() -> None:
    rng = np.random.default_rng(2)
    for _ in range(10):
        points = rng.uniform(-0.5, 0.5, (4, 2))
        kinematics = SwerveDrive4Kinematics(*translations(points))
        robot = swerve_robot(points)
        np.testing.assert_array_equal(robot.module_positions, points)
        for twist in random_twists(rng, 20):
            theirs = velocities(kinematics.toSwerveModuleStates(ChassisSpeeds(*twist)))
            ours = robot.wheel_velocities(twist) * RADIUS
            np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-12)
            # forward kinematics: both least squares over the module velocities
            speeds, angles = robot.module_states(twist)
            states = [SwerveModuleState(float(s * RADIUS), Rotation2d(float(a)))
                      for s, a in zip(speeds, angles, strict=True)]
            four = (states[0], states[1], states[2], states[3])
            back = twist_from_chassis_speeds(kinematics.toChassisSpeeds(four))
            np.testing.assert_allclose(back, twist, rtol=1e-9, atol=1e-12)


def test_swerve_from_three_modules_and_plain_translations() -> None:
    points = [(0.3, 0.0), (-0.2, 0.25), (-0.2, -0.25)]
    robot = robot_from_swerve_kinematics(SwerveDrive3Kinematics(*translations(points)),
                                         wheel_radius=RADIUS, max_wheel_speed=20.0,
                                         max_steer_rate=10.0)
    assert robot.n_wheels == 3
    again = robot_from_swerve_kinematics(points, wheel_radius=RADIUS, max_wheel_speed=20.0,
                                         max_steer_rate=10.0)
    np.testing.assert_array_equal(robot.module_positions, again.module_positions)
    with pytest.raises(RobotError, match="Translation2d"):
        robot_from_swerve_kinematics("modules", wheel_radius=RADIUS, max_wheel_speed=20.0,
                                     max_steer_rate=10.0)


def test_flip_rule_is_wpilibs_optimize() -> None:
    rng = np.random.default_rng(3)
    robot = swerve_robot()
    for twist in random_twists(rng, 100):
        current = rng.uniform(-math.pi, math.pi, 4)
        speeds, angles = robot.module_states(twist, current)
        plain, plain_angles = robot.module_states(twist)
        for i in range(4):
            state = SwerveModuleState(float(plain[i] * RADIUS), Rotation2d(float(plain_angles[i])))
            state.optimize(Rotation2d(float(current[i])))
            assert speeds[i] * RADIUS == pytest.approx(state.speed, abs=1e-12)
            difference = math.remainder(angles[i] - state.angle.radians(), 2.0 * math.pi)
            assert difference == pytest.approx(0.0, abs=1e-9)


def test_mecanum_kinematics_agree_with_wpilib() -> None:
    rng = np.random.default_rng(4)
    layouts = [np.array(MECANUM_CORNERS)] + [rng.uniform(-0.4, 0.4, (4, 2)) for _ in range(10)]
    for points in layouts:
        kinematics = MecanumDriveKinematics(*translations(points))
        robot = mecanum_robot(points)
        for twist in random_twists(rng, 20):
            theirs = mecanum_array(kinematics.toWheelSpeeds(ChassisSpeeds(*twist)))
            np.testing.assert_allclose(robot.wheel_speeds(twist) * RADIUS, theirs,
                                       rtol=1e-12, atol=1e-12)
            wheels = MecanumDriveWheelSpeeds(*(robot.wheel_speeds(twist) * RADIUS))
            back = twist_from_chassis_speeds(kinematics.toChassisSpeeds(wheels))
            np.testing.assert_allclose(back, twist, rtol=1e-9, atol=1e-12)


def test_rectangular_mecanum_is_our_factory_and_the_documented_values() -> None:
    robot = mecanum_robot()
    ours = mecanum(wheelbase=0.30, track=0.25, wheel_radius=RADIUS, max_wheel_speed=20.0,
                   max_wheel_accel=40.0)
    np.testing.assert_allclose(robot.jacobian, ours.jacobian, rtol=1e-15, atol=1e-15)
    # kinematics.md's check values (surface speeds, m/s)
    np.testing.assert_allclose(robot.wheel_speeds([0.0, 0.0, 1.0]) * RADIUS,
                               [-0.275, 0.275, -0.275, 0.275], atol=1e-12)
    with pytest.raises(RobotError, match="4 positions"):
        robot_from_mecanum_kinematics(CORNERS[:3], wheel_radius=RADIUS, max_wheel_speed=20.0)


def test_desaturation_agrees_with_wpilib() -> None:
    rng = np.random.default_rng(5)
    swerve = swerve_robot()
    swedish = mecanum_robot()
    swerve_kinematics = SwerveDrive4Kinematics(*translations(CORNERS))
    mecanum_kinematics = MecanumDriveKinematics(*translations(MECANUM_CORNERS))
    for twist in random_twists(rng, 100, scale=2.0):
        states = swerve_kinematics.toSwerveModuleStates(ChassisSpeeds(*twist))
        limited = SwerveDrive4Kinematics.desaturateWheelSpeeds(states, 30.0 * RADIUS)
        ours = swerve.wheel_velocities(swerve.desaturate(twist)) * RADIUS
        np.testing.assert_allclose(ours, velocities(limited), rtol=1e-12, atol=1e-12)
        wheels = mecanum_kinematics.toWheelSpeeds(ChassisSpeeds(*twist))
        wheels.desaturate(20.0 * RADIUS)
        ours_mecanum = swedish.wheel_speeds(swedish.desaturate(twist)) * RADIUS
        np.testing.assert_allclose(ours_mecanum, mecanum_array(wheels), rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------- commands and the follower


def test_commands_as_wpilib_module_states_and_wheel_speeds() -> None:
    reference = Circle(1.0, 12.0, heading="tangent")
    for robot in (swerve_robot(), mecanum_robot()):
        follower = MpcFollower(robot, reference)
        speeds = follower.calculate(pose2d_from_pose([1.05, 0.02, 1.5]), 0.0)
        command = follower.last_command
        np.testing.assert_array_equal(twist_from_chassis_speeds(speeds), command.twist)
        if isinstance(robot, SwerveRobot):
            states = follower.module_states()
            swerve_kinematics = SwerveDrive4Kinematics(*translations(CORNERS))
            theirs = swerve_kinematics.toSwerveModuleStates(speeds)
            np.testing.assert_allclose(velocities(states), velocities(theirs), atol=1e-12)
            assert command.steer_angles is not None
            np.testing.assert_allclose(np.array([s.angle.radians() for s in states]),
                                       command.steer_angles, atol=1e-12)
            with pytest.raises(RobotError, match="Mecanum"):
                follower.wheel_speeds()
        else:
            mecanum_kinematics = MecanumDriveKinematics(*translations(MECANUM_CORNERS))
            np.testing.assert_allclose(mecanum_array(follower.wheel_speeds()),
                                       mecanum_array(mecanum_kinematics.toWheelSpeeds(speeds)),
                                       atol=1e-12)
            assert mecanum_array(mecanum_wheel_speeds(robot, command)) == pytest.approx(
                mecanum_array(follower.wheel_speeds()))
            with pytest.raises(RobotError, match="swerve"):
                swerve_module_states(robot, command)
            with pytest.raises(RobotError, match="Mecanum"):  # four omni wheels are not
                mecanum_wheel_speeds(preset("omni4"), command)


def test_follower_clock() -> None:
    reference = Circle(1.0, 12.0, heading=0.0)
    follower = MpcFollower(swerve_robot(), reference)
    with pytest.raises(ControllerError, match="calculate"):
        _ = follower.last_command
    pose = pose2d_from_pose(reference.sample(0.0).pose)
    follower.calculate(pose, 5000.0)  # a new follower's clock starts at its first t
    assert follower.last_command.reference_time == 0.0
    follower.calculate(pose, 5000.5)
    assert follower.last_command.reference_time == pytest.approx(0.5)
    follower.reset(pose, ChassisSpeeds(), timestamp=100.0, start_time=3.0)
    assert follower.reference_time(101.25) == pytest.approx(4.25)
    follower.calculate(pose, 101.0)
    assert follower.last_command.reference_time == pytest.approx(4.0)
    follower.reset(pose, ChassisSpeeds())  # no timestamp: the next calculate is the start
    follower.calculate(pose, 7.0)
    assert follower.last_command.reference_time == 0.0
    assert not follower.is_finished(1e6)  # a circle never ends
    np.testing.assert_array_equal(follower.reset_pose, pose_from_pose2d(pose))
    with pytest.raises(ControllerError, match="timestamp"):
        follower.reset(pose, ChassisSpeeds(), timestamp=math.inf)
    with pytest.raises(ControllerError, match="ChassisSpeeds"):
        follower.reset(pose, (0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match=r"t \[s\] must be a finite number"):
        follower.calculate(pose, math.nan)


def test_reset_speeds_are_the_controllers_last_twist() -> None:
    """reset(pose, speeds) starts the acceleration limit from ``speeds``, as
    Controller.reset(last_twist=...) does."""
    robot, reference = mecanum_robot(), Circle(1.0, 12.0, heading=0.0)
    start = reference.sample(0.0).pose
    moving = reference.body_twist(0.0)
    follower = MpcFollower(robot, reference, horizon=10)
    follower.reset(pose2d_from_pose(start), chassis_speeds_from_twist(moving), timestamp=42.0)
    controller = Controller(robot, reference, horizon=10, dt=0.02)
    controller.reset(last_twist=moving)
    for k in range(3):
        follower.calculate(pose2d_from_pose(start), 42.0 + 0.02 * k)
        expected = controller.step(start, 0.02 * k)
        np.testing.assert_allclose(follower.last_command.twist, expected.twist, atol=1e-9)


# ---------------------------------------------------------------- WPILib trajectories


def wpilib_trajectory(reversed_: bool = False) -> WpilibTrajectory:
    """An S through (1, 1) and (2, -1) at up to 1 m/s, 1 m/s^2 and 1.5 m/s^2 sideways."""
    config = TrajectoryConfig(1.0, 1.0)
    config.addConstraint(CentripetalAccelerationConstraint(1.5))
    config.setReversed(reversed_)
    start, end = Pose2d(0.0, 0.0, Rotation2d(0.0)), Pose2d(3.0, 0.0, Rotation2d(0.0))
    inner = [Translation2d(1.0, 1.0), Translation2d(2.0, -1.0)]
    if reversed_:
        start, end, inner = end, start, inner[::-1]
    return TrajectoryGenerator.generateTrajectory(start, inner, end, config)


@pytest.mark.parametrize("reversed_", [False, True])
def test_reference_reproduces_wpilib_sample(reversed_: bool) -> None:
    trajectory = wpilib_trajectory(reversed_)
    reference = reference_from_wpilib_trajectory(trajectory)
    assert isinstance(reference, WpilibReference)
    assert reference.end_time == trajectory.totalTime()
    rng = np.random.default_rng(6)
    times = np.concatenate([rng.uniform(-1.0, trajectory.totalTime() + 1.0, 400),
                            [s.t for s in trajectory.states()]])
    sample = reference.sample(times)
    for t, pose, velocity in zip(times, sample.pose, sample.velocity, strict=True):
        state = trajectory.sample(float(t))
        assert pose[:2] == pytest.approx([state.pose.X(), state.pose.Y()], abs=1e-12)
        turn = math.remainder(pose[2] - state.pose.rotation().radians(), 2.0 * math.pi)
        assert turn == pytest.approx(0.0, abs=1e-12)
        inside = 0.0 <= t <= trajectory.totalTime()
        assert math.hypot(*velocity[:2]) == pytest.approx(abs(state.velocity) if inside else 0.0,
                                                          abs=1e-12)


def test_reference_derivatives_are_consistent() -> None:
    """Velocity and acceleration are the time derivatives of the pose (central differences
    inside the segments)."""
    reference = reference_from_wpilib_trajectory(wpilib_trajectory())
    knots = np.array([s.t for s in wpilib_trajectory().states()])
    times = (knots[:-1] + knots[1:]) / 2.0
    h = 1e-6
    ahead, behind, here = (reference.sample(times + h), reference.sample(times - h),
                           reference.sample(times))
    np.testing.assert_allclose((ahead.pose - behind.pose) / (2 * h), here.velocity, atol=1e-6)
    np.testing.assert_allclose((ahead.velocity - behind.velocity) / (2 * h), here.acceleration,
                               atol=1e-5)


def test_reference_heading_override_and_errors() -> None:
    reference = reference_from_wpilib_trajectory(wpilib_trajectory(), heading=0.0)
    assert np.all(reference.sample(np.linspace(0.0, 6.0, 50)).pose[:, 2] == 0.0)
    with pytest.raises(TrajectoryError, match="at least 2 states"):
        reference_from_wpilib_trajectory("path.json")  # type: ignore[arg-type]


# ---------------------------------------------------------------- closed loops, WPILib plant


def wpilib_loop(follower: MpcFollower, pose: Pose2d, ticks: int, clock: float,
                reference: Trajectory) -> np.ndarray:
    """The plant is WPILib's Pose2d.exp of the commanded ChassisSpeeds over each tick.
    Returns the position error [m] after every tick."""
    dt = follower.controller.dt
    errors = np.empty(ticks)
    for k in range(ticks):
        speeds = follower.calculate(pose, clock + k * dt)
        assert follower.controller.robot.is_feasible(twist_from_chassis_speeds(speeds))
        pose = pose.exp(Twist2d(speeds.vx * dt, speeds.vy * dt, speeds.omega * dt))
        target = reference.sample((k + 1) * dt).pose
        errors[k] = math.hypot(pose.X() - target[0], pose.Y() - target[1])
    return errors


@pytest.mark.parametrize("kind", ["swerve", "mecanum"])
def test_wpilib_closed_loop_tracks_a_circle_within_a_millimetre(kind: str) -> None:
    """A circle inside the limits (peak wheel ratio 0.35 swerve, 0.74 Mecanum), one lap at
    20 ms on an FPGA-like clock. Measured: 0.015 mm RMS swerve, 0.002 mm Mecanum when
    started moving on the reference; from rest, 0.010 and 0.007 mm after 2 s."""
    robot = swerve_robot() if kind == "swerve" else mecanum_robot()
    reference = Circle(1.0, 12.0, heading=0.0)
    start = pose2d_from_pose(reference.sample(0.0).pose)
    follower = MpcFollower(robot, reference)
    ticks = round(12.0 / follower.controller.dt)
    follower.reset(start, chassis_speeds_from_twist(reference.body_twist(0.0)), timestamp=873.2)
    moving = wpilib_loop(follower, start, ticks, 873.2, reference)
    assert np.sqrt(np.mean(moving**2)) < 1e-3
    follower.reset(start, ChassisSpeeds())
    from_rest = wpilib_loop(follower, start, ticks, 0.0, reference)
    assert np.sqrt(np.mean(from_rest[100:] ** 2)) < 1e-3  # after the first 2 s


def test_wpilib_closed_loop_follows_a_wpilib_trajectory() -> None:
    """Fixed heading on WPILib's S (peak wheel ratio 0.67), 20 ms ticks, from rest at the
    start. Measured: 0.17 mm RMS, 0.51 mm at most (the residual comes from the corners of
    WPILib's piecewise-straight interpolation)."""
    trajectory = wpilib_trajectory()
    reference = reference_from_wpilib_trajectory(trajectory, heading=0.0)
    follower = MpcFollower(swerve_robot(), reference)
    start = pose2d_from_pose(reference.sample(0.0).pose)
    ticks = round(trajectory.totalTime() / follower.controller.dt) + 25
    errors = wpilib_loop(follower, start, ticks, 12.0, reference)
    assert np.sqrt(np.mean(errors**2)) < 1e-3
    assert not follower.is_finished(12.0 + trajectory.totalTime() - 0.02)
    assert follower.is_finished(12.0 + trajectory.totalTime() + 0.02)


def test_core_does_not_import_the_adapter() -> None:
    code = ("import sys, mpc, mpc.control, mpc.sim, mpc.robots, trajectories; "
            "mpc.Controller; "
            "assert 'mpc.adapters.wpilib' not in sys.modules and 'wpimath' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


# ------------------------------------------------------------ per-module feedforward
def _wrench_of_step(robot, last: np.ndarray, twist: np.ndarray, dt: float) -> np.ndarray:
    """``(m a_x, m a_y, I alpha)`` of the step ``last -> twist`` (Coriolis at its middle)."""
    dyn = robot.dynamics
    middle = 0.5 * (last + twist)
    accel = (twist - last) / dt + np.array([-middle[2] * middle[1], middle[2] * middle[0], 0.0])
    return accel * [dyn.mass, dyn.mass, dyn.yaw_inertia]


def _kinematics_matrix(to_wheels, count: int) -> np.ndarray:
    """The (count rows, 3) linear map wpimath's inverse kinematics applies, read off it by
    feeding it unit ChassisSpeeds."""
    columns = [to_wheels(ChassisSpeeds(*unit)) for unit in np.eye(3)]
    return np.array(columns).T.reshape(count, 3)


def test_swerve_module_feedforwards_against_wpimath() -> None:
    """The minimum-norm force split is wpimath's inverse kinematics of the speeds
    ``(A^T A)^-1 wrench``: each module's force vector must be the module state wpimath
    gives for them (speed along its angle), and along the commanded angle the linear force."""
    from mpc.robots import motor_preset
    from trajectories import FigureEight

    shipped = motor_preset("swerve")
    points = [(0.3, 0.25), (0.3, -0.25), (-0.35, 0.25), (-0.35, -0.25)]  # not centred
    kinematics = SwerveDrive4Kinematics(*translations(points))
    robot = robot_from_swerve_kinematics(
        kinematics, wheel_radius=0.05, max_wheel_speed=float(shipped.max_wheel_speed[0]),
        max_steer_rate=12.0).with_dynamics(shipped.dynamics)
    follower = MpcFollower(robot, FigureEight(1.5, 6.0, heading=0.0), dt=0.05, horizon=12)
    reference = follower.controller.trajectory
    a = np.array([[1.0, 0.0, -y] for _, y in points] + [[0.0, 1.0, x] for x, _ in points])
    last = np.zeros(3)
    checked = 0
    for k in range(8):
        pose = reference.sample(np.array([0.05 * k])).pose[0]
        follower.calculate(pose2d_from_pose(pose), 0.05 * k)
        command = follower.last_command
        feed = follower.feedforwards()
        speeds = np.linalg.solve(a.T @ a, _wrench_of_step(robot, last, command.twist, 0.05))
        states = kinematics.toSwerveModuleStates(ChassisSpeeds(*speeds))
        want = np.array([[s.speed * s.angle.cos(), s.speed * s.angle.sin()] for s in states])
        got = np.stack([feed.forces_x, feed.forces_y], axis=1)
        scale = max(1.0, np.abs(want).max())
        np.testing.assert_allclose(got, want, atol=1e-6 * scale)
        along = (got[:, 0] * np.cos(command.steer_angles)
                 + got[:, 1] * np.sin(command.steer_angles))
        np.testing.assert_allclose(feed.linear_forces, along, atol=1e-6 * scale)
        checked += int(np.abs(want).max() > 1.0)
        last = np.asarray(command.twist, dtype=float)
    assert checked >= 4
    dyn = robot.dynamics
    motor = dyn.wheel_motor
    # torque-current: the linear force's torque at the wheel (plus the wheel's inertia)
    # through the gearbox's kt; a swerve module's wheel inertia is small next to it
    np.testing.assert_allclose(np.asarray(feed.torque_currents) * motor.kt,
                               np.asarray(feed.linear_forces) * 0.05,
                               atol=0.1 * np.abs(feed.linear_forces).max() * 0.05)


def test_mecanum_module_feedforwards_against_wpimath() -> None:
    """Mecanum: the rim forces ``linear_forces`` are wpimath's wheel speeds of
    ``(K^T K)^-1 wrench`` (``K`` wpimath's own inverse kinematics); the x/y forces lie
    along the rollers' axes and sum, with their moments, to the wrench."""
    from mpc.adapters.wpilib import module_feedforwards
    from mpc.robots import motor_preset
    from trajectories import FigureEight

    shipped = motor_preset("mecanum")
    points = [(0.15, 0.125), (0.15, -0.125), (-0.15, 0.125), (-0.15, -0.125)]
    kinematics = MecanumDriveKinematics(*translations(points))
    robot = robot_from_mecanum_kinematics(
        kinematics, wheel_radius=0.05,
        max_wheel_speed=float(shipped.max_wheel_speed[0])).with_dynamics(shipped.dynamics)
    controller = Controller(robot, FigureEight(1.0, 8.0, heading=0.0), horizon=12, dt=0.05)

    def wheels(speeds):
        w = kinematics.toWheelSpeeds(speeds)
        return [w.frontLeft, w.frontRight, w.rearLeft, w.rearRight]

    k_map = _kinematics_matrix(wheels, 4)
    last = np.zeros(3)
    for k in range(6):
        pose = controller.trajectory.sample(np.array([0.05 * k])).pose[0]
        command = controller.step(pose, 0.05 * k)
        feed = module_feedforwards(robot, command)
        wrench = _wrench_of_step(robot, last, np.asarray(command.twist), 0.05)
        want = k_map @ np.linalg.solve(k_map.T @ k_map, wrench)
        scale = max(1.0, np.abs(want).max())
        np.testing.assert_allclose(feed.linear_forces, want, atol=1e-6 * scale)
        vectors = np.stack([feed.forces_x, feed.forces_y], axis=1)
        p = np.array(points)
        total = np.r_[vectors.sum(axis=0),
                      np.sum(p[:, 0] * vectors[:, 1] - p[:, 1] * vectors[:, 0])]
        np.testing.assert_allclose(total, wrench, atol=1e-6 * scale)
        last = np.asarray(command.twist, dtype=float)


def test_module_feedforwards_need_dynamics() -> None:
    from mpc.adapters.wpilib import module_feedforwards
    from mpc.errors import RobotError
    from trajectories import Circle

    robot = robot_from_swerve_kinematics(SwerveDrive4Kinematics(*translations(
        [(0.3, 0.3), (0.3, -0.3), (-0.3, 0.3), (-0.3, -0.3)])), wheel_radius=0.05,
        max_wheel_speed=60.0, max_steer_rate=12.0)
    command = Controller(robot, Circle(1.0, 8.0), horizon=10, dt=0.05).step(
        np.array([1.0, 0.0, 0.0]), 0.0)
    with pytest.raises(RobotError, match="dynamics"):
        module_feedforwards(robot, command)
