"""Can a robot follow a reference at all? Peak wheel speed against the wheel limits, and
for steered modules (swerve, casters) the steering rate (:mod:`trajectories.steering`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from ._validation import FloatArray, positive_number, samples_in, shown
from .base import Trajectory
from .errors import TrajectoryError
from .retiming_problem import path_geometry
from .steering import steer_demand

#: Most times :func:`feasibility` samples (a bound of this library: 10^6 twists and
#: wheel speeds take a few hundred MB).
MAX_SAMPLES = 1_000_000
_AT_REST = 1e-12  # [rad/s] a wheel with limit 0 may turn this fast (rounding)


class WheelLimitedRobot(Protocol):
    """What :func:`feasibility` needs from a robot (duck-typed)."""

    @property
    def max_wheel_speed(self) -> npt.ArrayLike:
        """Wheel speed limits, shape (n_wheels,) (or one shared number) [rad/s], >= 0.

        A limit of 0 marks a failed wheel: any motion of it gives ratio inf.
        """
        ...

    def wheel_speeds(self, twists: FloatArray) -> npt.ArrayLike:
        """Wheel speeds (k, n_wheels) [rad/s] (signed) for body twists (k, 3)."""
        ...


@dataclass(frozen=True, eq=False)
class FeasibilityReport:
    """Peak wheel-speed demand of a reference relative to the wheel limits.

    ``peak_ratio`` is the largest |wheel speed| / limit over all samples and
    wheels (1.0 = exactly at the limit); ``time`` [s] and ``wheel`` (index
    into the robot's wheel order) say where it occurs; ``ratios`` (k,) is the
    peak ratio over wheels at each sample time ``times`` (k,) [s]. ``steer_ratio`` is
    the peak steering demand over steered modules (:func:`~trajectories.steering.steer_demand`:
    the turn rate / limit, or the speed / :data:`~trajectories.steering.STEER_FLOOR` of the
    speed limit where that is lower; 0 without steering limits), at ``steer_time``.
    """

    peak_ratio: float
    time: float  # [s]
    wheel: int
    ratios: FloatArray
    times: FloatArray  # [s]
    steer_ratio: float = 0.0
    steer_time: float = 0.0  # [s]

    @property
    def is_feasible(self) -> bool:
        """True if no wheel exceeds its speed limit and no steered module its steering
        rate at any sample (peak_ratio <= 1 and steer_ratio <= 1)."""
        return self.peak_ratio <= 1.0 and self.steer_ratio <= 1.0


def feasibility(
    trajectory: Trajectory,
    robot: WheelLimitedRobot,
    duration: float | None = None,
    samples: int = 2001,
) -> FeasibilityReport:
    """Wheel speeds the reference body twist needs, relative to the robot's limits.

    Samples ``trajectory.body_twist`` at ``samples`` evenly spaced times over
    [start_time, start_time + duration] (start_time is 0 except for waypoints
    starting later), maps them through ``robot.wheel_speeds`` and divides by
    ``robot.max_wheel_speed`` (a wheel with limit 0 gives ratio 0 at rest,
    inf otherwise). A robot with ``wheel_blocks`` (n, 2, 3) and ``max_steer_rates`` (an
    :class:`mpc.robots.Robot` with steered wheels) is also measured against its steering
    rates (``steer_ratio``). ``duration`` [s] defaults to one period, or to
    the trajectory's duration (waypoints: their span). This is the
    open-loop demand of the reference; tracking corrections come on top.
    """
    if not isinstance(trajectory, Trajectory):
        raise TrajectoryError(f"trajectory must be a Trajectory, got {shown(trajectory)}")
    if not callable(getattr(robot, "wheel_speeds", None)) or not hasattr(
            robot, "max_wheel_speed"):
        raise TrajectoryError("robot must be a robot with wheel_speeds(twists) and "
                              f"max_wheel_speed (an mpc.robots Robot), got {shown(robot)}")
    if duration is None:
        duration = trajectory.period if trajectory.period is not None else trajectory.duration
        if duration is None:
            raise TrajectoryError(
                "feasibility needs a duration [s] for a trajectory that is neither periodic "
                "nor finite, got duration=None"
            )
        if duration <= 0.0:
            raise TrajectoryError(
                f"feasibility needs a trajectory of positive duration, got {shown(duration)} s"
            )
    else:
        duration = positive_number("duration [s]", duration)
    count = samples_in(samples, 2, MAX_SAMPLES, "times checked")

    times = trajectory.start_time + np.linspace(0.0, duration, count)
    twists = trajectory.body_twist(times)
    speeds = np.asarray(robot.wheel_speeds(twists), dtype=np.float64)
    if speeds.ndim != 2 or speeds.shape[0] != times.size:
        raise TrajectoryError(
            f"robot.wheel_speeds must return an array of shape ({times.size}, n_wheels) for "
            f"twists of shape {twists.shape}, got shape {speeds.shape}"
        )
    limits = np.asarray(robot.max_wheel_speed, dtype=np.float64)
    if limits.ndim == 0:  # one limit shared by every wheel
        limits = np.full(speeds.shape[1], limits)
    if limits.shape != (speeds.shape[1],) or not (np.isfinite(limits) & (limits >= 0.0)).all():
        raise TrajectoryError(
            f"robot.max_wheel_speed must be {speeds.shape[1]} finite limits >= 0 [rad/s] "
            f"(one per wheel), got {shown(limits)}"
        )
    magnitudes = np.abs(speeds)
    working = limits > 0.0
    if working.all():
        wheel_ratios = magnitudes / limits
    else:
        # a failed wheel (limit 0) is fine at rest and infinitely over its limit otherwise
        wheel_ratios = np.where(
            working,
            magnitudes / np.where(working, limits, 1.0),
            np.where(magnitudes > _AT_REST, np.inf, 0.0),
        )
    sample, wheel = np.unravel_index(int(np.argmax(wheel_ratios)), wheel_ratios.shape)
    ratios = wheel_ratios.max(axis=1)
    steer = _steer_ratios(trajectory, robot, times, limits)
    turn = int(np.argmax(steer)) if steer is not None else 0
    times.flags.writeable = False
    ratios.flags.writeable = False
    return FeasibilityReport(
        peak_ratio=float(wheel_ratios[sample, wheel]),
        time=float(times[sample]),
        wheel=int(wheel),
        ratios=ratios,
        times=times,
        steer_ratio=float(steer[turn]) if steer is not None else 0.0,
        steer_time=float(times[turn]) if steer is not None else 0.0,
    )


def _steer_ratios(trajectory: Trajectory, robot: object, times: FloatArray,
                  speed_limits: FloatArray) -> FloatArray | None:
    """Peak steering demand at each of ``times`` (k,) for a robot with steered
    modules (``max_steer_rates`` not None and ``wheel_blocks`` (n, 2, 3)), else None."""
    rates = getattr(robot, "max_steer_rates", None)
    blocks = getattr(robot, "wheel_blocks", None)
    if rates is None or blocks is None:
        return None
    blocks = np.asarray(blocks, dtype=np.float64)
    rates = np.broadcast_to(np.asarray(rates, dtype=np.float64), speed_limits.shape)
    if blocks.shape != (speed_limits.size, 2, 3) or not (np.isfinite(rates)
                                                         & (rates > 0.0)).all():
        raise TrajectoryError(f"robot.max_steer_rates must be {speed_limits.size} finite "
                              f"numbers > 0 [rad/s] for its modules' velocity maps "
                              f"wheel_blocks ({speed_limits.size}, 2, 3), got {shown(rates)} "
                              f"and wheel_blocks of shape {blocks.shape}")
    geometry = path_geometry(trajectory, times)
    return steer_demand(blocks, speed_limits, rates, geometry.twist, geometry.twist_rate)
