"""Runs the benchmark's scenarios and packs the results as plain data (JSON-ready)."""

from __future__ import annotations

import csv
import datetime
import functools
import math
import os
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.scenarios import ALL_TRAJECTORIES, ScenarioError, reference
from benchmarks.table import Column, format_table
from mpc.errors import MpcError, RobotError
from mpc.plot.record import run_record
from mpc.robots import (
    MOTOR_ROBOT_PRESETS,
    Robot,
    motor_preset,
)
from mpc.sim import SimResult
from trajectories import SampledTrajectory, Trajectory, Waypoints, feasibility, time_optimal
from trajectories.sampled import _SampledHeading  # a sampled theta is described by the samples


@dataclass(frozen=True)
class Scenario:
    """One robot on one reference; every controller runs it."""

    layout: str
    robot: Robot
    trajectory_name: str
    trajectory: Trajectory
    speed: str
    heading: str

    @property
    def peak_ratio(self) -> float:
        return float(feasibility(self.trajectory, self.robot).peak_ratio)

    @functools.cached_property
    def optimal_lap(self) -> float | None:
        """The time-optimal lap of the reference's path under the robot's wheel limits [s]
        (the yardstick of path following), None for a reference that is not periodic."""
        if self.trajectory.period is None:
            return None
        try:
            return float(time_optimal(self.trajectory, self.robot).lap_time)
        except MpcError:  # a path the retimer cannot time: report no yardstick
            return None

    @property
    def target_lap(self) -> float | None:
        """The fastest lap a controller that never runs ahead of the reference can drive:
        ``max(period, optimal lap)`` [s]."""
        period, optimal = self.trajectory.period, self.optimal_lap
        if period is None:
            return None
        return max(period, optimal) if optimal is not None else period


def build_scenarios(robots: dict[str, Robot], trajectories: list[str], speeds: dict[str, float],
                    headings: list[str], csv_trajectory: Trajectory | None) -> list[Scenario]:
    """Every layout x trajectory x heading x speed (a CSV reference runs as given, once per
    layout)."""
    scenarios = []
    for layout, robot in robots.items():
        for name in trajectories:
            for heading in headings:
                for label, ratio in speeds.items():
                    trajectory = reference(name, heading, robot, ratio)
                    scenarios.append(Scenario(layout, robot, name, trajectory, label, heading))
        if csv_trajectory is not None:
            scenarios.append(Scenario(layout, robot, "csv", csv_trajectory, "as-given", "csv"))
    return scenarios


def machine() -> dict[str, Any]:
    """What the numbers were measured on."""
    processor = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                processor = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"platform": platform.platform(), "python": platform.python_version(),
            "cpu_count": os.cpu_count(), "processor": processor}


def default_duration(scenario: Scenario, skip: float) -> float:
    """Two laps at the fastest pace a path follower can keep (or the waypoints' span) after
    the settling time, at least 6 s [s]: a steady lap for path mode to be timed on."""
    trajectory = scenario.trajectory
    if trajectory.period is not None:
        return max(6.0, 2.2 * (scenario.target_lap or trajectory.period) + skip)
    return max(6.0, float(trajectory.duration or 10.0) + skip)


def describe_robot(robot: Robot) -> dict[str, Any]:
    """A description :func:`mpc.robots.from_dict` rebuilds ``robot`` from, exactly."""
    if robot.derating is not None:
        raise ScenarioError(f"robot {robot.name!r} is derated; describe the healthy robot")
    if getattr(robot, "dynamics", None) is not None:
        return _describe_motor_preset(robot)
    try:  # the robot was accepted once: its copies in the workers are not checked again
        return {**robot.description(), "allow_unusual": True}
    except RobotError as error:
        raise ScenarioError(f"robot {robot.name!r}: {error}") from None


def _describe_motor_preset(robot: Robot) -> dict[str, Any]:
    """A robot with motors as ``{"motor_preset": layout}`` when it is that shipped preset."""
    layout = robot.name.removesuffix("-motors")
    if layout in MOTOR_ROBOT_PRESETS:
        shipped = motor_preset(layout)
        if (shipped.name == robot.name and shipped.dynamics == robot.dynamics
                and describe_robot(shipped.with_dynamics(None))
                == describe_robot(robot.with_dynamics(None))):
            return {"motor_preset": layout}
    raise ScenarioError(f"robot {robot.name!r} has a motor model that is not a shipped motor "
                        "preset; runs on other processes describe those and kinematic robots "
                        "only (use --workers 1)")


def describe_trajectory(scenario: Scenario) -> dict[str, Any]:
    """The trajectory spec of a benchmark scenario (its period, or its waypoints)."""
    trajectory = scenario.trajectory
    if isinstance(trajectory, Waypoints):
        return {"times": trajectory.times.tolist(), "poses": trajectory.poses.tolist()}
    if (isinstance(trajectory, SampledTrajectory)
            and isinstance(trajectory.heading, _SampledHeading)):  # its own theta, not a spec
        accelerations = trajectory.accelerations
        return {"samples": {"times": trajectory.times.tolist(),
                            "poses": trajectory.poses.tolist(),
                            "velocities": trajectory.velocities.tolist(),
                            "accelerations": None if accelerations is None
                            else accelerations.tolist()}}
    if scenario.trajectory_name in ALL_TRAJECTORIES and trajectory.period is not None:
        return {"shape": scenario.trajectory_name, "heading": scenario.heading,
                "period": trajectory.period}
    raise ScenarioError(f"cannot describe trajectory {scenario.trajectory_name!r} as plain data")


def _violations(metrics: dict[str, Any]) -> int:
    """Ticks over a speed, acceleration or steering-rate limit, all kinds together."""
    return int(sum(metrics.get(key, 0) for key in
                   ("limit_violations", "accel_violations", "steer_violations")))


def _ratio(value: object) -> str:
    """A peak ratio in 6 characters, ``-`` when there is none."""
    return f"{value:6.3f}" if isinstance(value, (int, float)) else f"{'-':>6s}"


def run_pace(run: dict[str, Any]) -> float | None:
    """A run's steady lap time over the fastest lap it could keep (1 = as fast as the
    wheels and the reference's own timing allow); None without a lap or a yardstick."""
    lap, target = run["metrics"].get("lap_time"), run.get("target_lap")
    if not isinstance(lap, (int, float)) or not isinstance(target, (int, float)):
        return None
    return float(lap) / float(target)


def pack_run(scenario: Scenario, name: str, metrics: dict[str, Any], result: SimResult,
             skip: float) -> dict[str, Any]:
    """One run as plain data (:func:`mpc.plot.run_record`, as a run of your own is packed):
    the scenario's labels, the metrics over the ticks after ``skip`` [s], the time series,
    the robot's outline, the reference's peak ratio and lap yardsticks."""
    return run_record(result, skip=skip, controller=name, metrics=metrics,
                      layout=scenario.layout, trajectory=scenario.trajectory_name,
                      heading=scenario.heading, speed=scenario.speed,
                      peak_ratio=round(scenario.peak_ratio, 4),
                      optimal_lap=scenario.optimal_lap, target_lap=scenario.target_lap)


def results_document(runs: list[dict[str, Any]], command: str,
                     settings: dict[str, Any]) -> dict[str, Any]:
    created = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return {
        "meta": {"command": command,
                 "created": created,
                 "machine": machine(), "settings": settings},
        "runs": runs,
    }


CSV_METRICS = ("rms_position_error", "max_position_error", "rms_cross_track_error",
               "max_cross_track_error", "rms_heading_error", "max_heading_error",
               "max_wheel_speed_ratio", "limit_violations", "accel_violations", "control_effort",
               "tick_time_p50", "tick_time_p95", "tick_time_p99", "tick_time_max",
               "solve_time_p50", "solve_time_p99", "deadline_misses", "failures",
               "steer_violations", "max_steer_rate_ratio", "lap_time",
               "max_lag", "mean_lag")


def write_csv(runs: list[dict[str, Any]], path: Path) -> None:
    """One row per run: scenario columns then the metrics (SI units)."""
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["layout", "trajectory", "heading", "speed", "peak_ratio", "period",
                         "optimal_lap", "controller", *CSV_METRICS, "failures_by_status"])
        for run in runs:
            metrics = run["metrics"]
            failures = sorted(metrics["failures_by_status"].items())
            by_status = ";".join(f"{k}:{v}" for k, v in failures)
            writer.writerow([run["layout"], run["trajectory"], run["heading"], run["speed"],
                             run["peak_ratio"], run["period"], run["optimal_lap"],
                             run["controller"],
                             *(metrics[key] for key in CSV_METRICS), by_status])


#: The summary table's columns (every column as wide as its widest cell).
SUMMARY_COLUMNS: tuple[Column, ...] = (
    Column("layout", align="<"), Column("traj", align="<"), Column("heading", align="<"),
    Column("speed", align="<"), Column("controller", align="<"), Column("rms pos", "[mm]"),
    Column("max path", "[mm]"), Column("rms head", "[deg]"), Column("lap/target"),
    Column("max lag", "[s]"), Column("peak", "[lim]"), Column("steer", "[lim]"),
    Column("viol"), Column("fail"), Column("tick p50", "[ms]"), Column("tick p99", "[ms]"))


def summary_table(runs: list[dict[str, Any]]) -> str:
    """A text table of the headline numbers, one row per run (:data:`SUMMARY_COLUMNS`)."""
    rows = []
    for run in runs:
        m, pace = run["metrics"], run_pace(run)
        rows.append([
            str(run["layout"]), str(run["trajectory"]), str(run["heading"]), str(run["speed"]),
            str(run["controller"]), f"{m['rms_position_error'] * 1e3:.3g}",
            f"{m['max_cross_track_error'] * 1e3:.3g}",
            f"{math.degrees(m['rms_heading_error']):.3g}",
            "-" if pace is None else f"{pace:.3f}", f"{m['max_lag']:.3f}",
            f"{m['max_wheel_speed_ratio']:.3f}", _ratio(m.get("max_steer_rate_ratio")).strip(),
            str(_violations(m)), str(m["failures"]), f"{m['tick_time_p50'] * 1e3:.3f}",
            f"{m['tick_time_p99'] * 1e3:.3f}"])
    return format_table(SUMMARY_COLUMNS, rows)
