"""Powered offset casters, whose steer angles are states the motion sets: the robot
(:mod:`.robot`), its joint kinematics (:mod:`.kinematics`), its limit rows and steer-angle
prediction (:mod:`.limits`) and its checks (:mod:`.checks`)."""

from mpc.robots.wheels.caster.robot import CasterRobot, caster

__all__ = ["CasterRobot", "caster"]
