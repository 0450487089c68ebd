"""Steered drive modules (swerve), centred or axle-offset (MPO-700 style): the robot
(:mod:`.robot`), its limit rows (:mod:`.limits`), module states and the flip rule
(:mod:`.states`), the axle offset's kinematics (:mod:`.axle`)."""

from mpc.robots.wheels.swerve.robot import SwerveRobot, swerve

__all__ = ["SwerveRobot", "swerve"]
