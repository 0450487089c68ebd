"""``mpc-bench slider``: the slider robot (SWOM) on its independent plant, MPC against the
reactive baseline.

Each case asks the robot to turn its direction of travel faster than its units can
steer (``max_steer_rate``): a figure-eight and a square driven round and back (its
corners and the reversal). Every controller runs on :class:`~mpc.sim.slider_plant
.SliderPlant` (the joint states integrated from the commanded rates, the stroke a hard
stop), from rest with the wheels aimed along the reference's start and every slider at
mid-stroke. The table gives the position error (RMS, peak), the largest commanded rate
over its limit (drive, steer, slider; 1.000 is at the limit), the ticks with a rate over
its limit and with a slider run into a stop, the sliders' range, the fastest slip at a
contact (the wheels disagreeing on one rigid motion), and each controller's tick time as
a ratio to the baseline's in the same run. Nothing is random.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from benchmarks.scenarios import Parser, choose
from benchmarks.table import Column, format_table
from mpc.control.slider import SliderController
from mpc.robots import preset
from mpc.robots.wheels.slider.robot import SliderRobot
from mpc.sim.slider_baseline import ReactiveSliderController
from mpc.sim.slider_run import SliderRun, run_slider
from trajectories import FigureEight, Trajectory, Waypoints

#: The preset the table runs by default.
ROBOT = "swom"
CONTROLLERS: tuple[str, ...] = ("mpc-daqp", "mpc-ipopt", "reactive")


@dataclass(frozen=True)
class SliderCase:
    """A reference and how long to run it [s]."""

    name: str
    trajectory: Trajectory
    duration: float


def figure_eight(laps: float = 2.0) -> SliderCase:
    """A figure-eight 1 m wide, 5 s a lap (peak 0.89 m/s; the direction of travel turns at
    up to 4.0 rad/s at the lobes' ends), ``laps`` laps."""
    return SliderCase("figure8", FigureEight(0.5, 5.0), 5.0 * laps)


def square_with_reversals(edges: int = 8) -> SliderCase:
    """A 0.5 m square round and back (0.8 s an edge, clamped cubic splines through the
    corners: the direction turns at up to 3.3 rad/s, and reverses at the start corner),
    the first ``edges`` of its 8 edges, then 0.6 s at rest at the end."""
    side, edge = 0.5, 0.8
    corners = [(0, 0), (side, 0), (side, side), (0, side), (0, 0), (0, side), (side, side),
               (side, 0), (0, 0)][:edges + 1]
    trajectory = Waypoints(edge * np.arange(len(corners)),
                           [(x, y, 0.0) for x, y in corners])
    return SliderCase("square-reversals", trajectory, edge * edges + 0.6)


CASES: dict[str, Callable[[], SliderCase]] = {
    "figure8": figure_eight, "square-reversals": square_with_reversals}


def peak_turn_rate(trajectory: Trajectory, duration: float, moving: float = 0.05) -> float:
    """The fastest turn of the direction of travel [rad/s] while the reference moves faster
    than ``moving`` [m/s] (sampled every 5 ms): what a wheel rolling along it must steer."""
    sample = trajectory.sample(np.arange(0.0, duration, 0.005))
    velocity, acceleration = sample.velocity[:, :2], sample.acceleration[:, :2]
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    cross = velocity[:, 0] * acceleration[:, 1] - velocity[:, 1] * acceleration[:, 0]
    fast = speed > moving
    return float(np.max(np.abs(cross[fast]) / speed[fast] ** 2))


def controller(name: str, robot: SliderRobot, trajectory: Trajectory, horizon: int = 20,
               dt: float = 0.05) -> Any:
    """The controller ``name`` (one of :data:`CONTROLLERS`) for the slider robot."""
    if name == "reactive":
        return ReactiveSliderController(robot, trajectory, dt)
    return SliderController(robot, trajectory, horizon, dt, solver=name.removeprefix("mpc-"))


def run_case(case: SliderCase, name: str, robot: SliderRobot | None = None,
             horizon: int = 20, duration: float | None = None) -> SliderRun:
    """One controller on one case (``duration`` [s] overrides the case's)."""
    chosen = preset(ROBOT) if robot is None else robot
    if not isinstance(chosen, SliderRobot):
        raise TypeError(f"the slider benchmark takes a slider robot, got {chosen.kind!r}")
    return run_slider(controller(name, chosen, case.trajectory, horizon),
                      case.duration if duration is None else duration)


def table(results: dict[tuple[str, str], SliderRun], robot: SliderRobot) -> str:
    """The results as a table (module docstring)."""
    columns = (Column("case", align="<"), Column("controller", align="<"),
               Column("RMS", "[mm]"), Column("peak", "[mm]"), Column("drive", "/limit"),
               Column("steer", "/limit"), Column("slider", "/limit"),
               Column("over", "[ticks]"), Column("stops", "[ticks]"),
               Column("slider range", "[mm]"), Column("slip", "[m/s]"),
               Column("tick", "/reactive"))
    rows = []
    for (case, name), run in results.items():
        baseline = results.get((case, "reactive"))
        ratio = (f"{run.mean_tick / baseline.mean_tick:.0f}x" if baseline is not None
                 and baseline.mean_tick > 0 else "-")
        low, high = 1e3 * run.slider_positions.min(), 1e3 * run.slider_positions.max()
        rows.append([case, name, f"{1e3 * run.rms_error:.1f}", f"{1e3 * run.max_error:.1f}",
                     *(f"{value:.3f}" for value in run.peak_ratios),
                     str(run.rate_violations), str(run.stroke_violations),
                     f"{low:.0f}-{high:.0f}", f"{run.peak_slip:.3f}", ratio])
    stroke = robot.strokes
    note = (f"robot {robot.name}: stroke {1e3 * stroke[:, 0].min():.0f}-"
            f"{1e3 * stroke[:, 1].max():.0f} mm, limits drive "
            f"{robot.max_wheel_speed.min():g} rad/s, steer {robot.max_steer_rates.min():g} "
            f"rad/s, slider {robot.max_slider_speeds.min():g} m/s")
    return format_table(columns, rows) + "\n" + note


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench slider", description=__doc__.split("\n")[0],
                    epilog="Cases: " + ", ".join(CASES) + ". Controllers: "
                           + ", ".join(CONTROLLERS) + ".")
    parser.add_argument("--cases", help="comma-separated cases (all)")
    parser.add_argument("--controllers", help="comma-separated controllers (all)")
    parser.add_argument("--horizon", type=int, default=20, help="MPC stages (20)")
    return parser


def main(argv: list[str]) -> int:
    args: argparse.Namespace = _parser().parse_args(argv)
    cases = choose("--cases", "case", args.cases, tuple(CASES), tuple(CASES))
    names = choose("--controllers", "controller", args.controllers, CONTROLLERS, CONTROLLERS)
    robot = preset(ROBOT)
    assert isinstance(robot, SliderRobot)
    results: dict[tuple[str, str], SliderRun] = {}
    for case_name in cases:
        case = CASES[case_name]()
        turn = peak_turn_rate(case.trajectory, case.duration)
        print(f"{case.name}: {case.duration:g} s, direction of travel turns at up to "
              f"{turn:.2f} rad/s (steering limit {robot.max_steer_rates.min():g} rad/s)",
              flush=True)
        for name in names:
            results[(case.name, name)] = run_case(case, name, robot, args.horizon)
    print(table(results, robot))
    return 0 if all(math.isfinite(run.rms_error) for run in results.values()) else 1
