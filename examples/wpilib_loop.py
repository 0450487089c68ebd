"""A control loop with WPILib types: kinematics, a WPILib trajectory, module states.

Shows, with robotpy-wpimath (``pip install 'holonomic-mpc[wpilib]'``):

- the robot built from a ``SwerveDrive4Kinematics`` (:func:`robot_from_swerve_kinematics`;
  module speed limits in rad/s of the wheel: rim speed [m/s] / wheel radius [m]);
- a ``Trajectory`` from WPILib's ``TrajectoryGenerator`` as the reference
  (:func:`reference_from_wpilib_trajectory`, which reproduces its ``sample(t)``);
- :class:`MpcFollower` in a 20 ms loop as a ``TimedRobot`` would run it: ``reset`` with
  an FPGA-style timestamp, ``calculate(Pose2d, t)`` returning ``ChassisSpeeds``, and
  ``module_states()`` giving the ``SwerveModuleState`` s to send to the modules;
- the robot simulated with WPILib's own forward kinematics (``toChassisSpeeds`` of the
  module states) and ``Pose2d.exp``, recorded with :class:`mpc.sim.Recorder` and plotted.

Run::

    python examples/wpilib_loop.py                   # the trajectory and 1 s after it
    python examples/wpilib_loop.py --duration 3 --out figures/

Prints the trajectory's length, the RMS and final position errors, and the fastest module
speed [m/s] against the modules' limit.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from wpimath.geometry import Pose2d, Rotation2d, Translation2d, Twist2d
from wpimath.kinematics import ChassisSpeeds, SwerveDrive4Kinematics
from wpimath.trajectory import TrajectoryConfig, TrajectoryGenerator

import mpc.plot
from mpc.adapters.wpilib import (
    MpcFollower,
    pose_from_pose2d,
    reference_from_wpilib_trajectory,
    robot_from_swerve_kinematics,
)
from mpc.sim import Recorder

WHEEL_RADIUS = 0.0508      # [m] 4-inch wheels
MODULE_SPEED = 4.5         # [m/s] the modules' top rim speed
LOOP = 0.02                # [s] TimedRobot's period
SKIP = 0.2                 # [s] start-up left out of the metrics


def run(duration: float | None, out: Path) -> dict[str, float]:
    """Follow a WPILib S-curve with a WPILib-described swerve; write ``out/wpilib_loop.png``."""
    kinematics = SwerveDrive4Kinematics(Translation2d(0.28, 0.28), Translation2d(0.28, -0.28),
                                        Translation2d(-0.28, 0.28), Translation2d(-0.28, -0.28))
    robot = robot_from_swerve_kinematics(kinematics, wheel_radius=WHEEL_RADIUS,
                                         max_wheel_speed=MODULE_SPEED / WHEEL_RADIUS,
                                         max_steer_rate=12.0)
    config = TrajectoryConfig(3.0, 3.0)        # [m/s], [m/s^2]
    config.setKinematics(kinematics)
    trajectory = TrajectoryGenerator.generateTrajectory(
        Pose2d(0.0, 0.0, Rotation2d(0.0)), [Translation2d(1.5, 1.0), Translation2d(3.0, -1.0)],
        Pose2d(4.5, 0.0, Rotation2d(0.0)), config)
    reference = reference_from_wpilib_trajectory(trajectory)
    follower = MpcFollower(robot, reference, dt=LOOP)
    recorder = Recorder(robot, reference, LOOP)

    fpga = 1234.5                              # [s] since boot: not the reference's clock
    pose = trajectory.initialPose()
    follower.reset(pose, ChassisSpeeds(), timestamp=fpga)
    seconds = trajectory.totalTime() + 1.0 if duration is None else duration
    fastest = 0.0
    for k in range(int(round(seconds / LOOP))):
        now = fpga + k * LOOP
        follower.calculate(pose, now)          # ChassisSpeeds, robot-relative
        states = follower.module_states()      # send these to the four modules
        recorder.record(k * LOOP, pose_from_pose2d(pose), follower.last_command)
        fastest = max(fastest, *(abs(state.speed) for state in states))
        fl, fr, rl, rr = states
        moved = kinematics.toChassisSpeeds((fl, fr, rl, rr))  # the modules drive the robot
        pose = pose.exp(Twist2d(moved.vx * LOOP, moved.vy * LOOP, moved.omega * LOOP))

    result = recorder.result()
    out.mkdir(parents=True, exist_ok=True)
    mpc.plot.plot_run(result, skip=SKIP).savefig(out / "wpilib_loop.png", dpi=100)
    metrics = result.metrics(skip=min(SKIP, seconds / 2))
    end = trajectory.sample(min(seconds, trajectory.totalTime())).pose  # where it should be
    metrics["final_position_error"] = math.hypot(pose.X() - end.X(), pose.Y() - end.Y())
    metrics["fastest_module"] = fastest
    metrics["end_time"] = trajectory.totalTime()
    return metrics


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=None,
                        help="seconds to run (default: the trajectory + 1 s)")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the figure")
    args = parser.parse_args(argv)
    metrics = run(args.duration, args.out)
    print(f"WPILib trajectory: {metrics['end_time']:.2f} s")
    print(f"rms position error: {metrics['rms_position_error'] * 1e3:.1f} mm")
    print(f"rms heading error: {np.degrees(metrics['rms_heading_error']):.2f} deg")
    print(f"final position error: {metrics['final_position_error'] * 1e3:.1f} mm")
    print(f"fastest module: {metrics['fastest_module']:.2f} m/s (limit {MODULE_SPEED} m/s)")
    print(f"figure: {args.out / 'wpilib_loop.png'}")


if __name__ == "__main__":
    main()
