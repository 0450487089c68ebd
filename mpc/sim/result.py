"""The record of one closed-loop run and its metrics."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mpc.angles import wrap_angle
from mpc.arrays import FloatArray, IntArray
from mpc.errors import SimulationError
from mpc.robots.base import Robot
from mpc.validation import is_finite_number, shown
from trajectories import Trajectory

#: Relative tolerance when counting wheel-limit violations.
LIMIT_RTOL = 1e-6


@dataclass(frozen=True, eq=False)
class SimResult:
    """Time series of one closed-loop run; row k is tick k at ``time[k]``.

    Attributes:
        time: tick start times (K,) [s].
        pose: true pose at each tick (K, 3) [m, m, rad].
        measured: the pose the controller saw (K, 3).
        reference: the reference pose the controller tracked at each tick (K, 3): at
            ``time`` in time mode, at ``time - lag`` (its progress) in path mode.
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
        lag: how far the tracked reference time trailed ``time`` (K,) [s]; None: never.
        wheel_velocity_command: the wheel velocity vectors the commands asked for
            (K, n, d) [rad/s] (what the acceleration limits bound); None: measured from
            the commanded twists instead.
        steer_command: commanded steer angles (K, n) [rad] of steered wheels, else None.
        steer_rate_limit: their steering rate limits (n,) [rad/s], else None.
        steer_rate_command: commanded steer rates (K, n) [rad/s] of robots whose steer
            angles are states (casters), else None.
        plant_events: per-tick series of a motor plant (:meth:`MotorPlant.events`:
            voltage and current violations, slips, peak ratios, bus voltage), else None.
        predicted_ticks: the ticks whose plan was kept (M,) (every
            :attr:`Recorder.predict_every`-th), else None.
        predicted_poses: those plans' predicted poses (M, P, 3) [m, m, rad], row m from
            tick ``predicted_ticks[m]`` (shorter plans padded with NaN), else None.
        robot: the controller's robot (its outline and limits, for reports), else None.
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
    lag: FloatArray | None = None
    wheel_velocity_command: FloatArray | None = None
    steer_command: FloatArray | None = None
    steer_rate_limit: FloatArray | None = None
    steer_rate_command: FloatArray | None = None
    plant_events: dict[str, FloatArray] | None = field(default=None, repr=False)
    predicted_ticks: IntArray | None = field(default=None, repr=False)
    predicted_poses: FloatArray | None = field(default=None, repr=False)
    robot: Robot | None = field(default=None, repr=False)

    @property
    def reference_time(self) -> FloatArray:
        """The reference time tracked at each tick (K,) [s]: ``time - lag``."""
        return self.time if self.lag is None else self.time - self.lag

    def lap_times(self, skip: float = 0.0) -> FloatArray:
        """Durations of the complete laps of a periodic reference after ``skip`` [s]:
        between the ticks at which the tracked reference time passes whole periods
        (interpolated). Empty for a non-periodic reference, fewer than two passes, or
        ticks too far apart to time laps (more passes than ticks)."""
        period = self.trajectory.period
        progress = self.reference_time
        if period is None or progress[-1] <= progress[0]:
            return np.zeros(0)
        first = math.floor(progress[0] / period) + 1
        last = math.floor(progress[-1] / period)
        if last - first + 1 > progress.size:  # laps shorter than the ticks between them
            return np.zeros(0)
        marks = period * np.arange(first, last + 1)
        # progress never decreases, so np.interp inverts it (ties: the first tick)
        passes = np.interp(marks, progress, self.time)
        passes = passes[passes >= self.time[0] + skip - 1e-12]
        return np.diff(passes)

    def position_error(self) -> FloatArray:
        """Distance to the time-indexed reference position (K,) [m]."""
        return np.hypot(*(self.pose[:, :2] - self.reference[:, :2]).T)

    def heading_error(self) -> FloatArray:
        """Wrapped heading error (K,) [rad]."""
        return wrap_angle(self.pose[:, 2] - self.reference[:, 2])

    def cross_track_error(self, resolution: int = 4000) -> FloatArray:
        """Distance to the nearest point of the reference path (K,) [m].

        The path is a polyline through ``resolution`` samples over the run
        (one period more for periodic references): each pose's nearest segment gives the
        time of its nearest path point, which Newton steps on the reference itself then
        refine (the polyline's chord error, microns on these paths, would otherwise
        exceed the distance of a robot that tracks closer than that; the distance never
        exceeds the polyline's).
        """
        end = float(self.time[-1]) + self.dt + (self.trajectory.period or 0.0)
        times = np.linspace(0.0, end, resolution)
        path = self.trajectory.sample(times).pose[:, :2]
        start, step = path[:-1], np.diff(path, axis=0)  # segments start + s step, s in [0, 1]
        length2 = np.maximum((step * step).sum(axis=1), 1e-300)
        out = np.empty(len(self.pose))
        nearest = np.empty(len(self.pose))  # the time of each pose's nearest polyline point
        for first in range(0, len(self.pose), 64):
            points = self.pose[first : first + 64, None, :2]
            along = np.clip(((points - start) * step).sum(-1) / length2, 0.0, 1.0)
            gap = points - (start + along[..., None] * step)
            distance2 = (gap * gap).sum(-1)
            segment = distance2.argmin(axis=1)
            rows = np.arange(len(segment))
            out[first : first + 64] = np.sqrt(distance2[rows, segment])
            nearest[first : first + 64] = (times[segment]
                                           + along[rows, segment] * (times[1] - times[0]))
        return np.minimum(out, self._refined_distance(nearest, times[1] - times[0], end))

    def _refined_distance(self, guess: FloatArray, spacing: float, end: float) -> FloatArray:
        """Distance from each pose to the reference at the time that minimises it near
        ``guess`` (K,) [s]: Newton steps on ``(p(t) - x) . v(t) = 0``, kept within a
        polyline spacing of the guess and within [0, ``end``]."""
        points = self.pose[:, :2]
        t = guess.copy()
        for _ in range(3):
            sample = self.trajectory.sample(t)
            offset = sample.pose[:, :2] - points
            velocity, accel = sample.velocity[:, :2], sample.acceleration[:, :2]
            slope = (velocity * velocity).sum(-1) + (offset * accel).sum(-1)
            change = np.where(slope > 0.0, -(offset * velocity).sum(-1)
                              / np.where(slope > 0.0, slope, 1.0), 0.0)
            t = np.clip(t + change, np.maximum(guess - spacing, 0.0),
                        np.minimum(guess + spacing, end))
        gap = self.trajectory.sample(t).pose[:, :2] - points
        return np.sqrt((gap * gap).sum(-1))

    def metrics(self, skip: float = 0.0) -> dict[str, Any]:
        """Summary numbers; tracking errors only after ``skip`` seconds.

        Keys (units): ``rms_position_error``, ``max_position_error``,
        ``rms_cross_track_error``, ``max_cross_track_error`` [m];
        ``rms_heading_error``, ``max_heading_error`` [rad, wrapped];
        ``max_wheel_speed_ratio`` (peak |command| / limit after ``skip``, 1 = at the limit);
        ``limit_violations`` (ticks with a wheel above its speed limit by
        more than 1e-6 relative); ``accel_violations`` (the same for the
        acceleration limit); ``control_effort`` (RMS over ticks and wheels of
        command / limit); ``tick_time_p50/p95/p99/max`` and
        ``solve_time_p50/p99`` [s]; ``deadline_misses`` (ticks longer than
        dt); ``failures`` (ticks not solved) and ``failures_by_status``;
        ``max_lag`` and ``mean_lag`` [s] (how far the tracked reference time trailed
        the clock); ``lap_time`` [s] (the last complete lap after ``skip``, None if
        there is none); ``steer_violations`` (ticks on which a steered wheel's commanded
        angle turned faster than its limit, modulo a half turn: the flip rule; casters:
        ticks with a commanded steer rate beyond its limit); ``max_steer_rate_ratio`` (peak
        steer rate / limit of steered wheels, from the commanded rates of casters or the
        commanded angles' turn per tick of swerve modules; None without steered wheels).
        Errors and the peak ratios cover the ticks after ``skip``; violations count every
        tick. On a motor plant also ``voltage_violations``, ``current_violations`` and
        ``slip_events`` (ticks), ``unplanned_slip_events`` (slip ticks whose command's
        own step needed at most ``mu N`` of every contact), ``peak_voltage_ratio``,
        ``peak_current_ratio`` and ``min_bus_voltage`` [V] (every tick).
        """
        if not is_finite_number(skip) or skip < 0:
            raise SimulationError(f"skip must be a finite number of seconds >= 0, "
                                  f"got {shown(skip)}")
        keep = self.time >= self.time[0] + skip - 1e-12
        if not keep.any():
            raise SimulationError(f"skip={skip} s leaves no ticks of a {self.duration:.3g} s run")
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
        lag = np.zeros(len(self.time)) if self.lag is None else self.lag
        laps = self.lap_times(skip)
        return {
            "rms_position_error": _rms(position),
            "max_position_error": float(position.max()),
            "rms_cross_track_error": _rms(cross),
            "max_cross_track_error": float(cross.max()),
            "rms_heading_error": _rms(heading),
            "max_heading_error": float(heading.max()),
            "max_wheel_speed_ratio": float(ratio[keep].max()),
            "limit_violations": int(violations.sum()),
            "accel_violations": self._accel_violations(),
            "steer_violations": self._steer_violations(),
            "max_steer_rate_ratio": self._steer_rate_ratio(keep),
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
            "max_lag": float(lag[keep].max()),
            "mean_lag": float(lag[keep].mean()),
            "lap_time": float(laps[-1]) if laps.size else None,
            **self._plant_metrics(),
        }

    def _plant_metrics(self) -> dict[str, Any]:
        """A motor plant's counts and peaks (empty for other plants)."""
        events = self.plant_events
        if events is None:
            return {}
        return {"voltage_violations": int(events["voltage_violation"].sum()),
                "current_violations": int(events["current_violation"].sum()),
                "slip_events": int(events["slip"].sum()),
                "unplanned_slip_events": int(np.sum((events["slip"] > 0) & (
                    events["planned_traction_ratio"] <= 1.0))),
                "peak_voltage_ratio": float(events["peak_voltage_ratio"].max()),
                "peak_current_ratio": float(events["peak_current_ratio"].max()),
                "min_bus_voltage": float(events["bus_voltage"].min())}

    def _accel_violations(self) -> int:
        """Ticks whose command changed a wheel faster than its acceleration limit."""
        if self.wheel_accel_limit is None:
            return 0
        if self.wheel_velocity_command is not None:  # what was sent, wheel by wheel
            velocities = self.wheel_velocity_command
            steps = np.diff(velocities, axis=0, prepend=np.zeros_like(velocities[:1]))
            change = np.linalg.norm(steps, axis=-1)
        else:
            twists = np.vstack([np.zeros((1, 3)), self.twist_command])
            steps = np.diff(twists, axis=0)
            change = np.linalg.norm(np.einsum("ndj,kj->knd", self.wheel_blocks, steps), axis=-1)
        bound = self.wheel_accel_limit * self.dt
        return int((change > bound * (1 + LIMIT_RTOL) + 1e-12).any(axis=1).sum())

    def steer_rates(self) -> FloatArray | None:
        """Steered wheels' rates (K, n) [rad/s]: casters' commanded rates; swerve modules' turn
        of the commanded angle per tick, modulo a half turn (from 0 before the first tick)."""
        if self.steer_rate_command is not None:
            return self.steer_rate_command
        if self.steer_command is None:
            return None
        angles = np.vstack([np.zeros((1, self.steer_command.shape[1])), self.steer_command])
        turn = np.mod(np.diff(angles, axis=0) + math.pi / 2, math.pi) - math.pi / 2
        return turn / self.dt

    def steer_flips(self, moving: float = 1e-3, aligned: float = 0.1,
                    hold: int = 3) -> IntArray | None:
        """Flips per steered module (n,), None without steered modules: how often a module
        settled along its direction of travel drives the other way round (backwards after
        forwards or the reverse) from the last time it was settled: it chose
        ``angle + pi`` with ``-v`` over turning on. A module turning through a whole turn
        relative to its direction passes the reversed sense for a tick or two: no flip.

        A module's direction on a tick is that of its velocity in the commanded twist; it
        is settled when it moves faster than ``moving`` of its speed limit with its
        commanded angle within ``aligned`` [rad] of that direction or its opposite, for at
        least ``hold`` ticks in a row in the same sense.
        """
        if self.steer_command is None or self.wheel_blocks.shape[1] != 2:
            return None
        velocities = np.einsum("ndj,kj->knd", self.wheel_blocks, self.twist_command)
        angles = self.steer_command
        off = np.arctan2(velocities[..., 1], velocities[..., 0]) - angles
        backwards = np.cos(off) < 0.0
        misaligned = np.abs(np.mod(off + math.pi / 2, math.pi) - math.pi / 2)
        settled = ((np.hypot(velocities[..., 0], velocities[..., 1])
                    > moving * self.wheel_limit) & (misaligned <= aligned))
        flips = np.zeros(angles.shape[1], dtype=int)
        for i in range(angles.shape[1]):
            last, run, sense = None, 0, None
            for here, back in zip(settled[:, i].tolist(), backwards[:, i].tolist(),
                                  strict=True):
                run = run + 1 if here and back == sense else (1 if here else 0)
                sense = back if here else None
                if run == hold:  # a settled stretch long enough to count
                    if last is not None and back != last:
                        flips[i] += 1
                    last = back
        return flips

    def steer_range_exits(self) -> int | None:
        """Ticks on which a commanded steer angle lay outside the robot's steering range
        (:meth:`~mpc.robots.Robot.steer_angle_range`); None without a range."""
        bounds = None if self.robot is None else self.robot.steer_angle_range()
        if bounds is None or self.steer_command is None:
            return None
        lo, hi = bounds
        outside = (self.steer_command < lo) | (self.steer_command > hi)
        return int(outside.any(axis=1).sum())

    def _steer_rate_ratio(self, keep: np.ndarray) -> float | None:
        rates, limit = self.steer_rates(), self.steer_rate_limit
        if rates is None or limit is None:
            return None
        return float((np.abs(rates[keep]) / limit).max())

    def _steer_violations(self) -> int:
        """Ticks whose commanded steer angles turned faster than the steering rate allows
        (from rest at angle 0 on the first tick); casters: commanded rates beyond it."""
        if self.steer_rate_command is not None and self.steer_rate_limit is not None:
            over = np.abs(self.steer_rate_command) > (
                self.steer_rate_limit * (1 + LIMIT_RTOL) + 1e-12)
            return int(over.any(axis=1).sum())
        if self.steer_command is None or self.steer_rate_limit is None:
            return 0
        angles = np.vstack([np.zeros((1, self.steer_command.shape[1])), self.steer_command])
        turn = np.abs(np.mod(np.diff(angles, axis=0) + math.pi / 2, math.pi) - math.pi / 2)
        bound = self.steer_rate_limit * self.dt
        return int((turn > bound * (1 + LIMIT_RTOL) + 1e-12).any(axis=1).sum())

    @property
    def duration(self) -> float:
        return float(len(self.time) * self.dt)


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.square(values))))
