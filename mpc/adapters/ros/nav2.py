""":class:`Nav2Controller`: the MPC with the shape of a nav2 controller plugin (plans from
``nav_msgs/Path``, commands as ``TwistStamped``, speed limits that slow the present plan)."""

from __future__ import annotations

import inspect
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from mpc.adapters.ros.clock import ReferenceClock
from mpc.adapters.ros.messages import twist_stamped
from mpc.arrays import FloatArray
from mpc.control import Command, Controller
from mpc.control.settings import check_step
from mpc.errors import ControllerError
from mpc.model.se2 import integrate_unchecked as integrate
from mpc.robots import Robot
from mpc.validation import MAX_HORIZON, integer_in, non_negative, positive, shown
from trajectories import FunctionHeading, HeadingSpec, Trajectory
from trajectories.path import PathDerivatives
from trajectories.rosbag import (
    path_reference,
    pose_from_message,
    poses_from_path,
    twist_from_message,
)


class _Slowed(Trajectory):
    """``source`` played ``rate`` times as fast from time ``start`` on, where it is at its
    own time ``pivot``: source time = pivot + rate (t - start); velocities scale by rate,
    accelerations by rate^2, jerks by rate^3 (a speed limit on a planned reference)."""

    def __init__(self, source: Trajectory, rate: float, start: float, pivot: float) -> None:
        self.source, self.rate, self.start, self.pivot = source, rate, start, pivot
        super().__init__(FunctionHeading(*(self._heading_derivative(k) for k in range(3))))

    def source_time(self, t: FloatArray) -> FloatArray:
        return self.pivot + self.rate * (t - self.start)

    def _heading_derivative(self, order: int) -> Callable[[FloatArray], FloatArray]:
        def derivative(t: FloatArray) -> FloatArray:
            sample = self.source.sample(self.source_time(t))
            field = (sample.pose, sample.velocity, sample.acceleration)[order]
            return self.rate**order * field[..., 2]
        return derivative

    @property
    def start_time(self) -> float:
        return self.start + (self.source.start_time - self.pivot) / self.rate

    @property
    def end_time(self) -> float | None:
        end = self.source.end_time
        return None if end is None else self.start + (end - self.pivot) / self.rate

    def _path(self, t: FloatArray) -> PathDerivatives:
        p, r = self.source.path(self.source_time(t)), self.rate
        return PathDerivatives(p.position, r * p.velocity, r * r * p.acceleration,
                               r**3 * p.jerk)


#: How far along a new plan [m] its start may be moved to the pose nearest the robot.
CATCH_UP = 1.0

#: A command older than this many control periods (wall clock) says nothing of where the
#: robot is or how fast it goes (a cancelled goal, a pause): a new plan starts from rest.
STALE_TICKS = 5

#: Re-solves of a plan's timing where its check finds cells over a limit
#: (:func:`~trajectories.time_optimal`'s ``max_repairs``): one, as a plan is timed on the
#: control thread; it makes a grid planner's laps much quicker, smooth paths need none
#: (docs/design/nav2-plan-repairs.md).
PLAN_REPAIRS = 1

#: [m/s] A plan timed from rest is timed again from the first measured velocity along it
#: (:meth:`Nav2Controller.compute_velocity_commands`) above this speed.
START_SPEED = 0.01

#: The Controller's own options a Nav2Controller passes through (``**options``).
_CONTROLLER_OPTIONS = frozenset(inspect.signature(Controller.__init__).parameters) - {
    "self", "robot", "trajectory", "horizon", "dt"}


def _speed_along(poses: FloatArray, pose: FloatArray, twist: FloatArray) -> float:
    """The speed [m/s] along the path's first direction of a robot at world ``pose`` moving
    with body ``twist``; 0 backwards, or for a path that starts by turning in place."""
    steps = np.diff(poses[:, :2], axis=0)
    lengths = np.hypot(steps[:, 0], steps[:, 1])
    moving = np.flatnonzero(lengths > 1e-9)
    if moving.size == 0:
        return 0.0
    direction = steps[moving[0]] / lengths[moving[0]]
    vx, vy = twist[:2]
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return max(0.0, float(direction @ np.array([c * vx - s * vy, s * vx + c * vy])))


class Nav2Controller:
    """The MPC with the shape of a nav2 controller plugin, on ROS messages.

    Args:
        robot: the drive layout and its wheel limits.
        dt: control period [s] (the controller server's rate), also the MPC tick.
        horizon: MPC ticks planned ahead.
        speed: None: time each plan time-optimally within the wheel limits; a number:
            drive plans at this constant path speed [m/s].
        max_speed: cap on the time-optimal path speed [m/s]; also the 100 % of
            percentage speed limits.
        heading: None: the plan's yaw; else a heading spec (``"tangent"``, an angle...).
        base_frame: frame of the commands (REP-105 ``base_link``).
        position_tolerance, yaw_tolerance: smooth each plan within these of its poses
            [m, rad] before timing it (:func:`~trajectories.path_reference`): for a grid
            planner's path not smoothed upstream, e.g. half a cell and 0.4 rad; 0 (the
            default): through every pose.
        **options: further :class:`~mpc.control.Controller` options.
    """

    def __init__(self, robot: Robot, *, dt: float = 0.05, horizon: int = 20,
                 speed: float | None = None, max_speed: float | None = None,
                 heading: HeadingSpec | None = None, base_frame: str = "base_link",
                 position_tolerance: float = 0.0, yaw_tolerance: float = 0.0,
                 **options: Any) -> None:
        if not isinstance(robot, Robot):
            raise ControllerError(f"robot must be an mpc.robots.Robot, got {shown(robot)}")
        # checked now, not in the first set_plan (inside a subscription callback)
        unknown = sorted(set(options) - _CONTROLLER_OPTIONS)
        if unknown:
            raise ControllerError(
                f"Nav2Controller(): unknown option(s) {', '.join(map(repr, unknown))} for the "
                f"Controller; its options are {', '.join(sorted(_CONTROLLER_OPTIONS))}")
        self.robot, self._options = robot, options
        self.dt = check_step("dt", dt)
        self.horizon = integer_in("horizon", horizon, 1, MAX_HORIZON, ControllerError)
        self.speed = None if speed is None else positive("speed [m/s]", speed, ControllerError)
        self.max_speed = None if max_speed is None else positive("max_speed [m/s]", max_speed,
                                                                  ControllerError)
        self.heading, self.base_frame = heading, base_frame
        self.tolerances = (non_negative("position_tolerance [m]", position_tolerance,
                                        ControllerError),
                           non_negative("yaw_tolerance [rad]", yaw_tolerance, ControllerError))
        self.clock = ReferenceClock()
        self.controller: Controller | None = None
        self.speed_limit: float | None = None  # [m/s] from set_speed_limit
        self._frame = ""
        self._plan: Trajectory | None = None  # as timed by set_plan
        self._peak_speed = 0.0  # [m/s] its peak path speed
        self._now: float | None = None  # [s] reference time of the last command
        self._pose: FloatArray | None = None  # the last pose commanded from [m, m, rad]
        self._moving: FloatArray | None = None  # the twist it moved with then (body frame)
        self._commanded_at = -math.inf  # [s] wall clock (time.monotonic) of that command
        self._poses: FloatArray | None = None  # the present plan's poses (n, 3)
        self._plan_cap: float | None = None  # [m/s] the cap it was timed within
        self._velocity_pending = True
        self._timed_blind = False  # the plan was timed from rest, the robot's speed unknown
        self.last_command: Command | None = None

    @property
    def has_plan(self) -> bool:
        """Whether :meth:`set_plan` has been given a plan."""
        return self.controller is not None

    @property
    def trajectory(self) -> Trajectory:
        """The timed reference of the current plan."""
        if self.controller is None:
            raise ControllerError("no plan yet: call set_plan(path) first")
        return self.controller.trajectory

    def set_plan(self, path: Any) -> None:
        """Follow a ``nav_msgs/Path`` from the next :meth:`compute_velocity_commands` on,
        timed within ``max_speed`` and the present speed limit. A robot already under way
        (nav2 plans again every second or so, from where the robot is) starts the new plan
        at the speed it has along it, not from rest."""
        recent = self._recent()  # once: the three uses below see the same answer
        poses = self._from_robot(poses_from_path(path), recent)
        speed = self._speed_along(poses, recent)
        self._install(poses, str(path.header.frame_id), speed)
        # nothing recent said how fast the robot moves: timed from rest until the first
        # command's measured velocity (compute_velocity_commands) says otherwise
        self._timed_blind = not recent

    def _from_robot(self, poses: FloatArray, recent: bool) -> FloatArray:
        """The path from its pose nearest where the robot will be at the next command (its
        last pose moved one tick by its last command; within the path's first
        :data:`CATCH_UP` metres): a plan made from a pose a moment old starts behind a
        robot under way, and the reference would hold it back to there (``recent``:
        :meth:`_recent`; the path as it is if not)."""
        if not recent or self.last_command is None or len(poses) < 3:
            return poses
        assert self._pose is not None
        ahead = integrate(self._pose, self.last_command.twist, self.dt)
        along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))))
        near = np.flatnonzero(along <= CATCH_UP)
        nearest = int(near[np.argmin(np.hypot(*(poses[near, :2] - ahead[:2]).T))])
        return poses[min(nearest, len(poses) - 2):]

    def _cap(self) -> float | None:
        """The path speed cap [m/s] plans are timed within: ``max_speed`` and the limit."""
        return min((c for c in (self.max_speed, self.speed_limit) if c is not None),
                   default=None)

    def _recent(self) -> bool:
        """Whether the last command is recent enough to say where the robot is and how
        fast it moves (:data:`STALE_TICKS`)."""
        return (self._pose is not None and self._moving is not None
                and time.monotonic() - self._commanded_at <= STALE_TICKS * self.dt)

    def _speed_along(self, poses: FloatArray, recent: bool) -> float:
        """The robot's speed [m/s] along the path's first direction: its measured twist at
        the last command if one came with it, else that command's (0 without a ``recent``
        command, :meth:`_recent`, or for a path that starts by turning in place)."""
        if not recent or len(poses) < 2:
            return 0.0
        assert self._pose is not None and self._moving is not None
        return _speed_along(poses, self._pose, self._moving)

    def _install(self, poses: FloatArray, frame: str, start_speed: float) -> None:
        """Time ``poses`` (n, 3) from ``start_speed`` [m/s] and follow them from the next
        command on (the clock starts again at the next stamp)."""
        cap = self._cap()
        if self.speed is None:
            # a retiming grid of 2 cells a pose (nav2 paths: a pose every few cm) within
            # 128..1000: set_plan runs on the control thread
            samples = int(np.clip(2 * len(poses), 128, 1000))
            reference = path_reference(poses, robot=self.robot, heading=self.heading,
                                       max_speed=cap, samples=samples,
                                       start_speed=min(start_speed, cap or start_speed),
                                       max_repairs=PLAN_REPAIRS,
                                       position_tolerance=self.tolerances[0],
                                       yaw_tolerance=self.tolerances[1])
        else:
            reference = path_reference(poses, speed=min(self.speed, cap or self.speed),
                                       heading=self.heading,
                                       position_tolerance=self.tolerances[0],
                                       yaw_tolerance=self.tolerances[1])
        self._poses, self._plan_cap = poses, cap
        if self.controller is None:
            self.controller = Controller(self.robot, reference, horizon=self.horizon,
                                         dt=self.dt, **self._options)
        else:
            self.controller.trajectory = reference
        self._plan, self._now = reference, None
        end = reference.end_time or reference.start_time
        velocity = reference.sample(np.linspace(reference.start_time, end, 2001)).velocity
        self._peak_speed = float(np.hypot(velocity[:, 0], velocity[:, 1]).max())
        self._frame = frame
        self.clock.restart()
        self._velocity_pending = True

    def compute_velocity_commands(self, pose: Any, velocity: Any | None = None) -> Any:
        """The ``TwistStamped`` to send now, in ``base_frame``, stamped with the pose's stamp.

        Args:
            pose: the robot's ``PoseStamped`` (or ``Odometry``) in the plan's frame.
            velocity: its present ``Twist`` (body frame), or None; used once after each new
                plan so that the acceleration limits count from the actual motion, and, if
                the plan was timed from rest for want of a recent command (the first plan,
                one after a pause) while the robot moves along it faster than
                :data:`START_SPEED`, to time it again from that speed (not with ``speed=``,
                whose plans are not timed by the limits). That retiming runs in this call
                and lasts as long as ``set_plan`` (see :data:`PLAN_REPAIRS`).
        """
        if self.controller is None:
            raise ControllerError("no plan yet: call set_plan(path) first")
        frame = str(pose.header.frame_id)
        if frame and self._frame and frame != self._frame:
            raise ControllerError(f"the pose is in frame {shown(frame)} but the plan in "
                                  f"{shown(self._frame)}: transform one into the other first")
        measured = pose_from_message(pose)  # bad messages fail here, before the clock starts
        twist = None if velocity is None else twist_from_message(velocity)
        if self._velocity_pending and twist is not None:
            if self._timed_blind and self.speed is None and self._poses is not None:
                # a plan timed from rest for want of anything recent (the first plan, or one
                # after a pause) while the robot moves along it: timed again from its speed
                self._timed_blind = False
                speed = _speed_along(self._poses, measured, twist)
                if speed > START_SPEED:
                    self._install(self._poses, self._frame, speed)
            self.controller.reset(last_twist=twist)
        self._velocity_pending = False
        self._now = self.clock(pose.header.stamp)
        self.last_command = self.controller.step(measured, self._now)
        self._pose = measured
        self._moving = self.last_command.twist if twist is None else twist
        self._commanded_at = time.monotonic()
        return twist_stamped(self.last_command.twist, pose.header.stamp, self.base_frame)

    def set_speed_limit(self, speed_limit: float, percentage: bool) -> None:
        """nav2's speed limit: ``speed_limit`` [m/s], or [%] of ``max_speed`` if
        ``percentage``; 0 removes it. The present plan keeps its path and its place and
        is played slower from now on, by ``limit / its peak path speed`` (speeds scale by
        that, accelerations by its square: still within the wheel limits). Later plans are
        timed within the limit."""
        limit = non_negative("speed_limit", speed_limit, ControllerError)
        if percentage and limit > 0.0:
            if self.max_speed is None:
                raise ControllerError("a percentage speed limit needs max_speed= [m/s]")
            limit = self.max_speed * limit / 100.0
        self.speed_limit = limit if limit > 0.0 else None
        if self.controller is None or self._plan is None:
            return
        if self._raised_above_plan():  # a plan timed under a lower cap: time the rest again
            self._retime_rest()
            return
        rate = 1.0 if limit == 0.0 or self._peak_speed <= limit else limit / self._peak_speed
        now = self._now if self._now is not None else self._plan.start_time
        current = self.controller.trajectory
        pivot = float(current.source_time(np.array(now))) if isinstance(current, _Slowed) \
            else now
        self.controller.trajectory = _Slowed(self._plan, rate, now, pivot)

    def _raised_above_plan(self) -> bool:
        """Whether the cap now is above the one the present plan was timed within."""
        if self.speed is not None or self._plan_cap is None:
            return False
        cap = self._cap()
        return cap is None or cap > self._plan_cap * (1.0 + 1e-9)

    def _retime_rest(self) -> None:
        """Time the present plan again from where its reference is now (its pose and
        speed there) to its end, within the cap now."""
        assert self._poses is not None and self.controller is not None
        trajectory = self.controller.trajectory  # slowed by a limit or not: as driven now
        sample = trajectory.sample(self._now if self._now is not None
                                   else trajectory.start_time)
        poses = self._poses
        nearest = int(np.argmin(np.hypot(*(poses[:, :2] - sample.pose[:2]).T)))
        rest = np.vstack([sample.pose[None, :], poses[nearest + 1:]])
        speed = float(np.hypot(*sample.velocity[:2]))
        if len(rest) < 2:  # at the end already: nothing left to speed up
            return
        self._install(rest, self._frame, speed)

    def is_finished(self, stamp: Any) -> bool:
        """Whether the reference time at ``stamp`` has reached the plan's end."""
        end = self.trajectory.end_time
        return end is not None and self.clock.started and self.clock.at(stamp) >= end
