"""Reference trajectories for holonomic robots (pure NumPy/SciPy).

A trajectory gives, at times t [s], the world-frame reference pose
(x, y, theta), velocity and acceleration, and the body twist (vx, vy, omega)
a controller tracks. The path and the heading are independent: any path
(:class:`Circle`, :class:`FigureEight`, :class:`Waypoints`) takes any heading
profile (fixed, tangent, spinning, or a function of time)::

    from trajectories import Circle, body_twist

    reference = Circle.with_speed(1.0, 0.8, heading="tangent")  # 1 m radius at 0.8 m/s
    sample = reference.sample(t0 + dt * np.arange(21))  # arrays of shape (21, 3)
    twists = body_twist(sample)  # (vx, vy, omega) in the body frame, (21, 3)

References also come from files: :func:`read_waypoint_csv`, Choreo ``.traj`` files
(:func:`read_choreo`, with the robot they were planned for) and ROS 2 bags
(:func:`read_bag_reference`: a ``nav_msgs/Path`` timed for a robot, or an odometry log;
needs the ``ros`` extra).
"""

from mpc.errors import TrajectoryError as _Error
from mpc.validation import checked_public as _checked_public

from .base import Trajectory, TrajectorySample, body_twist
from .choreo import (
    CHOREO_TO_OURS,
    ChoreoConfig,
    ChoreoEvent,
    ChoreoTrajectory,
    choreo_robot,
    read_choreo,
)
from .errors import TrajectoryError
from .feasibility import FeasibilityReport, WheelLimitedRobot, feasibility
from .heading import (
    FixedHeading,
    FunctionHeading,
    HeadingDerivatives,
    HeadingProfile,
    HeadingSpec,
    SpinHeading,
    TangentHeading,
    make_heading,
)
from .path import PathDerivatives, TimedPath
from .retiming import PhaseGrid, RetimedTrajectory, RetimingInfo, RetimingRobot, time_optimal
from .rosbag import bag_topics, odometry_reference, path_reference, read_bag_reference
from .sampled import SampledTrajectory
from .shapes import Circle, FigureEight, OutAndBack
from .waypoints import Waypoints, read_waypoint_csv

__all__ = [
    "CHOREO_TO_OURS",
    "ChoreoConfig",
    "ChoreoEvent",
    "ChoreoTrajectory",
    "Circle",
    "FeasibilityReport",
    "FigureEight",
    "FixedHeading",
    "FunctionHeading",
    "HeadingDerivatives",
    "HeadingProfile",
    "HeadingSpec",
    "PathDerivatives",
    "PhaseGrid",
    "OutAndBack",
    "RetimedTrajectory",
    "RetimingInfo",
    "RetimingRobot",
    "SampledTrajectory",
    "SpinHeading",
    "TangentHeading",
    "TimedPath",
    "Trajectory",
    "TrajectoryError",
    "TrajectorySample",
    "Waypoints",
    "WheelLimitedRobot",
    "bag_topics",
    "body_twist",
    "choreo_robot",
    "feasibility",
    "make_heading",
    "odometry_reference",
    "path_reference",
    "read_bag_reference",
    "read_choreo",
    "read_waypoint_csv",
    "time_optimal",
]

# Arguments that do not fit a public callable's signature raise TrajectoryError, not TypeError.
_checked_public(globals(), _Error)
