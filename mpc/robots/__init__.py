"""Robot descriptions: Swedish-wheel (omni, Mecanum), swerve (centred or axle-offset modules),
driven-ball, powered-caster and slider (SWOM) layouts, and wheel sets by type (refused unless
omnidirectional).

Conventions: REP-103 body frame (x forward, y left, yaw counter-clockwise),
twists ``(vx, vy, omega)`` in m/s and rad/s, wheel speeds in rad/s. Wheel
orders: Mecanum FL, FR, RL, RR; omni counter-clockwise from
``first_wheel_angle``; swerve as ``module_positions`` lists them; driven
balls ball by ball, the actuator about +x then the one about +y; casters as ``positions``
lists them (steer angles measured each tick: they are states); another source's order,
signs and units through :data:`CONVENTIONS` (``Command.wheel_speeds_as``). A new
wheel type is one module in :mod:`mpc.robots.wheels` (imported with the package): a
:class:`Robot` subclass answering for itself (``description``, ``mobility_wheels``,
``drive_radii``, ``with_wheel_limits``) and a factory passed to :func:`register` (a
wheel-set builder and a sweep sampler too, if it has them), plus a preset file in
``description/presets``. Motors: :class:`DCMotor` (WPILib's DC motor model and
presets) and :class:`SysIdMotor` (``kS, kV, kA`` per wheel); :class:`RobotDynamics`
(mass, motors, battery, traction) through :meth:`Robot.with_dynamics` adds motor-aware
limits (:mod:`mpc.robots.drive.motor_limits`); :func:`motor_preset` ships them per layout.
Slider units (:func:`slider`) in ``rail_angles`` order; their steer angles and slider
positions are measured each tick.
"""

from mpc.angles import wrap_angle
from mpc.errors import RobotError as _Error
from mpc.robots.base import Robot, SpeedRows, WheelCommands
from mpc.robots.description.conventions import CONVENTIONS, WheelConvention, wheel_convention
from mpc.robots.description.files import (
    MOTOR_ROBOT_PRESETS,
    PRESETS,
    SEED_PRESETS,
    from_dict,
    load,
    motor_preset,
    preset,
    shipped_presets,
)
from mpc.robots.description.mobility import (
    Mobility,
    WheelSpec,
    mobility,
    require_omnidirectional,
    robot_description,
    robot_mobility,
)
from mpc.robots.description.registry import register, robot_types
from mpc.robots.description.wheel_set import wheel_set
from mpc.robots.drive.dynamics import RobotDynamics, choreo_dynamics, dynamics
from mpc.robots.drive.motor import MOTOR_PRESETS, DCMotor, SysIdMotor
from mpc.robots.wheels.caster.robot import CasterRobot, caster
from mpc.robots.wheels.slider.robot import SliderRobot, slider
from mpc.robots.wheels.spherical import SphericalRobot, spherical
from mpc.robots.wheels.swedish import SwedishRobot, SwedishWheel, mecanum, omni
from mpc.robots.wheels.swerve.robot import SwerveRobot, swerve
from mpc.validation import checked_public as _checked_public

__all__ = [
    "CONVENTIONS",
    "CasterRobot",
    "MOTOR_PRESETS",
    "MOTOR_ROBOT_PRESETS",
    "Mobility",
    "PRESETS",
    "DCMotor",
    "Robot",
    "RobotDynamics",
    "SEED_PRESETS",
    "SpeedRows",
    "SliderRobot",
    "SphericalRobot",
    "SwedishRobot",
    "SwedishWheel",
    "SwerveRobot",
    "SysIdMotor",
    "WheelCommands",
    "WheelConvention",
    "WheelSpec",
    "caster",
    "choreo_dynamics",
    "dynamics",
    "from_dict",
    "load",
    "mecanum",
    "mobility",
    "motor_preset",
    "omni",
    "preset",
    "register",
    "require_omnidirectional",
    "robot_description",
    "robot_mobility",
    "robot_types",
    "shipped_presets",
    "slider",
    "spherical",
    "swerve",
    "wheel_convention",
    "wheel_set",
    "wrap_angle",
]

# Arguments that do not fit a public callable's signature raise RobotError, not TypeError.
_checked_public(globals(), _Error)
