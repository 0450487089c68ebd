"""Runs the benchmark's scenarios and packs the results as plain data (JSON-ready)."""

from __future__ import annotations

import csv
import datetime
import math
import os
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.scenarios import Settings, controller, reference
from mpc.robots import Robot
from mpc.sim import SimResult, simulate
from trajectories import Trajectory, feasibility


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


def build_scenarios(robots: dict[str, Robot], trajectories: list[str], speeds: dict[str, float],
                    heading: str, csv_trajectory: Trajectory | None) -> list[Scenario]:
    """Every layout x trajectory x speed (a CSV reference runs as given, once per layout)."""
    scenarios = []
    for layout, robot in robots.items():
        for name in trajectories:
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


def default_duration(trajectory: Trajectory, skip: float) -> float:
    """One lap (or the waypoints' span) after the settling time, at least 6 s [s]."""
    span = trajectory.period or trajectory.duration or 10.0
    return max(6.0, float(span) + skip)


def run_all(
    scenarios: list[Scenario],
    controllers: list[str],
    settings: Settings,
    duration: float | None,
    skip: float,
    plant: str,
    seed: int,
    log: Callable[[str], None],
) -> list[dict[str, Any]]:
    """Simulate every scenario with every controller; print one line per run."""
    runs = []
    total = len(scenarios) * len(controllers)
    for scenario in scenarios:
        for name in controllers:
            started = time.perf_counter()
            control = controller(name, scenario.robot, scenario.trajectory, settings)
            length = duration or default_duration(scenario.trajectory, skip)
            result = simulate(control, length, plant=plant, seed=seed)
            metrics = result.metrics(skip=min(skip, 0.5 * length))
            runs.append(pack_run(scenario, name, metrics, result))
            log(f"[{len(runs):3d}/{total}] {scenario.layout:8s} {scenario.trajectory_name:8s} "
                f"{scenario.speed:8s} {name:10s} rms {metrics['rms_position_error'] * 1e3:8.3g} mm"
                f"  cross {metrics['max_cross_track_error'] * 1e3:8.3g} mm"
                f"  peak {metrics['max_wheel_speed_ratio']:.3f}"
                f"  tick p50 {metrics['tick_time_p50'] * 1e3:6.3f} ms"
                f"  ({time.perf_counter() - started:.1f} s)")
    return runs


def _robot_info(robot: Robot) -> dict[str, Any]:
    return {"name": robot.name, "kind": robot.kind,
            "wheel_positions": robot.wheel_positions.round(6).tolist()}


def _list(array: np.ndarray, decimals: int = 7) -> list[Any]:
    return np.round(array, decimals).tolist()  # type: ignore[no-any-return]


def pack_run(scenario: Scenario, name: str, metrics: dict[str, Any],
             result: SimResult) -> dict[str, Any]:
    """One run as plain data: names, metrics, time series, robot outline."""
    return {
        "layout": scenario.layout,
        "trajectory": scenario.trajectory_name,
        "heading": scenario.heading,
        "speed": scenario.speed,
        "peak_ratio": round(scenario.peak_ratio, 4),
        "controller": name,
        "metrics": metrics,
        "series": {
            "time": _list(result.time), "pose": _list(result.pose),
            "reference": _list(result.reference), "wheel_command": _list(result.wheel_command),
            "wheel_limit": _list(result.wheel_limit), "tick_time": _list(result.tick_time, 8),
            "solve_time": _list(result.solve_time, 8), "status": list(result.status),
            "dt": result.dt,
        },
        "robot": _robot_info(scenario.robot),
    }


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
               "solve_time_p50", "solve_time_p99", "deadline_misses", "failures")


def write_csv(runs: list[dict[str, Any]], path: Path) -> None:
    """One row per run: scenario columns then the metrics (SI units)."""
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["layout", "trajectory", "heading", "speed", "peak_ratio", "controller",
                         *CSV_METRICS, "failures_by_status"])
        for run in runs:
            metrics = run["metrics"]
            failures = sorted(metrics["failures_by_status"].items())
            by_status = ";".join(f"{k}:{v}" for k, v in failures)
            writer.writerow([run["layout"], run["trajectory"], run["heading"], run["speed"],
                             run["peak_ratio"], run["controller"],
                             *(metrics[key] for key in CSV_METRICS), by_status])


def summary_table(runs: list[dict[str, Any]]) -> str:
    """A fixed-width text table of the headline numbers."""
    header = (f"{'layout':8s} {'traj':8s} {'speed':8s} {'controller':10s} {'rms pos':>9s} "
              f"{'max cross':>9s} {'rms head':>8s} {'peak':>6s} {'viol':>4s} {'fail':>4s} "
              f"{'tick p50':>9s}")
    units = (f"{'':8s} {'':8s} {'':8s} {'':10s} {'[mm]':>9s} {'[mm]':>9s} {'[deg]':>8s} "
             f"{'[lim]':>6s} {'':>4s} {'':>4s} {'[ms]':>9s}")
    lines = [header, units, "-" * len(header)]
    for run in runs:
        m = run["metrics"]
        lines.append(
            f"{run['layout']:8s} {run['trajectory']:8s} {run['speed']:8s} {run['controller']:10s} "
            f"{m['rms_position_error'] * 1e3:9.3g} {m['max_cross_track_error'] * 1e3:9.3g} "
            f"{math.degrees(m['rms_heading_error']):8.3g} {m['max_wheel_speed_ratio']:6.3f} "
            f"{m['limit_violations']:4d} {m['failures']:4d} {m['tick_time_p50'] * 1e3:9.3f}"
        )
    return "\n".join(lines)
