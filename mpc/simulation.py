"""Closed-loop simulation of a controller on a :class:`~mpc.plant.Plant`, and its metrics."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from mpc.command import Command
from mpc.errors import MpcInputError, is_finite_number
from mpc.plant import PLANT_PRESETS, Plant, PlantConfig
from mpc.robots.base import FloatArray, Robot
from mpc.robots.swerve import wrap_angle
from trajectories import Trajectory

#: Relative tolerance when counting wheel-limit violations.
LIMIT_RTOL = 1e-6


class TrackingController(Protocol):
    """What :func:`simulate` needs: the MPC and the baselines all fit."""

    robot: Robot
    dt: float

    @property
    def trajectory(self) -> Trajectory: ...

    def reset(self) -> None: ...

    def step(self, pose: ArrayLike, t: float) -> Command: ...


@dataclass(frozen=True, eq=False)
class SimResult:
    """Time series of one closed-loop run; row k is tick k at ``time[k]``.

    Attributes:
        time: tick start times (K,) [s].
        pose: true pose at each tick (K, 3) [m, m, rad].
        measured: the pose the controller saw (K, 3).
        reference: reference pose at each tick (K, 3).
        wheel_command: commanded wheel speeds (K, n) [rad/s].
        wheel_actual: wheel speeds reached at the end of each tick (K, n) [rad/s].
        wheel_limit: per-wheel speed limit (n,) [rad/s].
        wheel_accel_limit: per-wheel acceleration limit (n,) [rad/s^2] or None.
        twist_command: commanded body twists (K, 3).
        status: each tick's :class:`~mpc.command.Status` value (K,).
        tick_time: whole ``step()`` times (K,) [s].
        solve_time: solver times (K,) [s].
        iterations: solver iterations (K,).
        dt: control tick [s].
        trajectory: the reference (for cross-track error).
        wheel_blocks: the robot's wheel velocity maps, to measure command changes.
    """

    time: FloatArray
    pose: FloatArray
    measured: FloatArray
    reference: FloatArray
    wheel_command: FloatArray
    wheel_actual: FloatArray
    wheel_limit: FloatArray
    wheel_accel_limit: FloatArray | None
    twist_command: FloatArray
    status: tuple[str, ...]
    tick_time: FloatArray
    solve_time: FloatArray
    iterations: FloatArray
    dt: float
    trajectory: Trajectory = field(repr=False)
    wheel_blocks: FloatArray = field(repr=False)

    def position_error(self) -> FloatArray:
        """Distance to the time-indexed reference position (K,) [m]."""
        return np.hypot(*(self.pose[:, :2] - self.reference[:, :2]).T)

    def heading_error(self) -> FloatArray:
        """Wrapped heading error (K,) [rad]."""
        return wrap_angle(self.pose[:, 2] - self.reference[:, 2])

    def cross_track_error(self, resolution: int = 4000) -> FloatArray:
        """Distance to the nearest point of the reference path (K,) [m].

        The path is a polyline through ``resolution`` samples over the run
        (one period more for periodic references); the distance is to its
        nearest segment, so it is exact up to the polyline's chord error.
        """
        end = float(self.time[-1]) + self.dt + (self.trajectory.period or 0.0)
        path = self.trajectory.sample(np.linspace(0.0, end, resolution)).pose[:, :2]
        start, step = path[:-1], np.diff(path, axis=0)  # segments start + s step, s in [0, 1]
        length2 = np.maximum((step * step).sum(axis=1), 1e-300)
        out = np.empty(len(self.pose))
        for first in range(0, len(self.pose), 64):
            points = self.pose[first : first + 64, None, :2]
            along = np.clip(((points - start) * step).sum(-1) / length2, 0.0, 1.0)
            gap = points - (start + along[..., None] * step)
            out[first : first + 64] = np.sqrt((gap * gap).sum(-1).min(axis=1))
        return out

    def metrics(self, skip: float = 0.0) -> dict[str, Any]:
        """Summary numbers; tracking errors only after ``skip`` seconds.

        Keys (units): ``rms_position_error``, ``max_position_error``,
        ``rms_cross_track_error``, ``max_cross_track_error`` [m];
        ``rms_heading_error``, ``max_heading_error`` [rad, wrapped];
        ``max_wheel_speed_ratio`` (peak |command| / limit, 1 = at the limit);
        ``limit_violations`` (ticks with a wheel above its speed limit by
        more than 1e-6 relative); ``accel_violations`` (the same for the
        acceleration limit); ``control_effort`` (RMS over ticks and wheels of
        command / limit); ``tick_time_p50/p95/p99/max`` and
        ``solve_time_p50/p99`` [s]; ``deadline_misses`` (ticks longer than
        dt); ``failures`` (ticks not solved) and ``failures_by_status``.
        """
        if not is_finite_number(skip) or skip < 0:
            raise MpcInputError(f"skip must be a finite number of seconds >= 0, got {skip!r}")
        keep = self.time >= self.time[0] + skip - 1e-12
        if not keep.any():
            raise MpcInputError(f"skip={skip} s leaves no ticks of a {self.duration:.3g} s run")
        position = self.position_error()[keep]
        heading = np.abs(self.heading_error()[keep])
        cross = self.cross_track_error()[keep]
        limit = self.wheel_limit
        magnitude = np.abs(self.wheel_command)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(limit > 0, magnitude / np.where(limit > 0, limit, 1.0),
                             np.where(magnitude > 1e-12, np.inf, 0.0))
        violations = (magnitude > limit * (1 + LIMIT_RTOL) + 1e-12).any(axis=1)
        failures = Counter(s for s in self.status if s != "solved")
        ticks = self.tick_time
        return {
            "rms_position_error": _rms(position),
            "max_position_error": float(position.max()),
            "rms_cross_track_error": _rms(cross),
            "max_cross_track_error": float(cross.max()),
            "rms_heading_error": _rms(heading),
            "max_heading_error": float(heading.max()),
            "max_wheel_speed_ratio": float(ratio.max()),
            "limit_violations": int(violations.sum()),
            "accel_violations": self._accel_violations(),
            "control_effort": _rms(np.where(np.isfinite(ratio), ratio, 0.0)),
            "tick_time_p50": float(np.percentile(ticks, 50)),
            "tick_time_p95": float(np.percentile(ticks, 95)),
            "tick_time_p99": float(np.percentile(ticks, 99)),
            "tick_time_max": float(ticks.max()),
            "solve_time_p50": float(np.percentile(self.solve_time, 50)),
            "solve_time_p99": float(np.percentile(self.solve_time, 99)),
            "deadline_misses": int((ticks > self.dt).sum()),
            "failures": int(sum(failures.values())),
            "failures_by_status": dict(failures),
        }

    def _accel_violations(self) -> int:
        """Ticks whose command changed a wheel faster than its acceleration limit."""
        if self.wheel_accel_limit is None:
            return 0
        twists = np.vstack([np.zeros((1, 3)), self.twist_command])
        steps = np.diff(twists, axis=0)
        change = np.linalg.norm(np.einsum("ndj,kj->knd", self.wheel_blocks, steps), axis=-1)
        bound = self.wheel_accel_limit * self.dt
        return int((change > bound * (1 + LIMIT_RTOL) + 1e-12).any(axis=1).sum())

    @property
    def duration(self) -> float:
        return float(len(self.time) * self.dt)


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def simulate(
    controller: TrackingController,
    duration: float,
    initial_pose: ArrayLike | None = None,
    plant: PlantConfig | str | None = None,
    seed: int | None = None,
    robot: Robot | None = None,
    on_tick: Callable[[int, int], None] | None = None,
) -> SimResult:
    """Run ``controller`` in closed loop for ``duration`` seconds.

    Args:
        controller: anything with ``step(pose, t) -> Command`` (resets first).
        duration: simulated time [s] (> 0), ``round(duration / dt)`` ticks.
        initial_pose: true start pose; default the reference at t = 0.
        plant: a :class:`~mpc.plant.PlantConfig`, a preset name from
            :data:`~mpc.plant.PLANT_PRESETS`, or None for the ideal plant.
        seed: seeds measurement noise and slip.
        robot: the true robot, if it differs from the controller's (e.g. a
            wheel the controller does not know has failed); default the same.
        on_tick: called as ``on_tick(k, ticks)`` after each tick (progress).
    """
    if not is_finite_number(duration) or duration <= 0:
        raise MpcInputError(f"duration must be a finite number of seconds > 0, got {duration!r}")
    config = _plant_config(plant)
    dt = controller.dt
    ticks = max(1, round(duration / dt))
    trajectory = controller.trajectory
    true_robot = robot or controller.robot
    if initial_pose is None:
        start = trajectory.sample(0.0).pose
    else:
        start = np.asarray(initial_pose, dtype=float)
        if start.shape != (3,) or not np.all(np.isfinite(start)):
            raise MpcInputError(f"initial_pose must be a finite (3,) pose, got {initial_pose!r}")
    sim = Plant(true_robot, dt, start, config, np.random.default_rng(seed))
    controller.reset()
    n = true_robot.n_wheels
    time: FloatArray = dt * np.arange(ticks, dtype=np.float64)
    poses, measured = np.empty((ticks, 3)), np.empty((ticks, 3))
    commands, actual = np.empty((ticks, n)), np.empty((ticks, n))
    twists = np.empty((ticks, 3))
    tick_time, solve_time, iterations = np.empty(ticks), np.empty(ticks), np.empty(ticks)
    status: list[str] = []
    for k in range(ticks):
        poses[k] = sim.pose
        measured[k] = sim.measure()
        command = controller.step(measured[k], float(time[k]))
        commands[k] = command.wheel_speeds
        twists[k] = command.twist
        tick_time[k], solve_time[k] = command.tick_time, command.solve_time
        iterations[k] = command.iterations
        status.append(command.status.value)
        actual[k] = sim.apply(command)
        if on_tick is not None:
            on_tick(k, ticks)
    reference = trajectory.sample(time).pose
    return SimResult(
        time=time, pose=poses, measured=measured, reference=reference,
        wheel_command=commands, wheel_actual=actual,
        wheel_limit=controller.robot.max_wheel_speed.copy(),
        wheel_accel_limit=controller.robot.max_wheel_accel,
        twist_command=twists, status=tuple(status), tick_time=tick_time,
        solve_time=solve_time, iterations=iterations, dt=dt, trajectory=trajectory,
        wheel_blocks=controller.robot.wheel_blocks,
    )


def _plant_config(plant: PlantConfig | str | None) -> PlantConfig:
    if plant is None:
        return PlantConfig()
    if isinstance(plant, PlantConfig):
        return plant
    if isinstance(plant, str) and plant in PLANT_PRESETS:
        return PLANT_PRESETS[plant]
    raise MpcInputError(
        f"plant must be a PlantConfig or one of {sorted(PLANT_PRESETS)}, got {plant!r}"
    )
