"""Robot descriptions: Swedish-wheel (omni, Mecanum) and swerve layouts.

Conventions (binding, from ``kinematics.md``): REP-103 body frame (x forward,
y left), twists ``(vx, vy, omega)`` in m/s and rad/s, wheel speeds in rad/s.
"""

from mpc.robots.base import Robot
from mpc.robots.files import PRESETS, from_dict, load, preset
from mpc.robots.swedish import SwedishRobot, SwedishWheel, mecanum, omni
from mpc.robots.swerve import SwerveRobot, swerve, wrap_angle

__all__ = [
    "PRESETS",
    "Robot",
    "SwedishRobot",
    "SwedishWheel",
    "SwerveRobot",
    "from_dict",
    "load",
    "mecanum",
    "omni",
    "preset",
    "swerve",
    "wrap_angle",
]
