"""``mpc-bench``: compare tracking controllers on holonomic robots.

    mpc-bench [options]          run the benchmark (defaults: every layout,
                                 circle and figure-eight, inside and 30% beyond
                                 the wheel limits, MPC (OSQP, IPOPT) and baselines)
    mpc-bench report RESULTS     rebuild the report from a results.json
    mpc-bench perf [options]     tick time against horizon for both solver paths
    mpc-bench soak [options]     memory and tick time over a long run
    mpc-bench motors [options]   motor-aware MPC against kinematic control on the motor plant
    mpc-bench fuzz [options]     seeded abuse of every robot and control path: unsafe commands
    mpc-bench tune [options]     tune the MPC's cost weights for a robot (Optuna)
    mpc-bench sweep [options]    Monte-Carlo over random robots, starts, plant faults

Runs are independent: ``--workers N`` spreads them over N local processes (default:
the machine's cores) and ``--scheduler tcp://HOST:PORT`` over a Dask cluster, with the
same results run for run (see :mod:`benchmarks.executor`).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from benchmarks import fuzz, motors, perf, soak
from benchmarks.executor import RunPool
from benchmarks.runner import build_scenarios, results_document, run_all, summary_table, write_csv
from benchmarks.scenarios import (
    ALL_TRAJECTORIES,
    CONTROLLERS,
    DEFAULT_CONTROLLERS,
    DEFAULT_HEADINGS,
    DEFAULT_LAYOUTS,
    HEADINGS,
    PRESETS,
    TRAJECTORIES,
    Parser,
    ScenarioError,
    Settings,
    choose,
    csv_reference,
    parse_speeds,
    robots,
)
from mpc.errors import MpcError
from mpc.robots import motor_preset
from mpc.sim import PLANT_PRESETS


def add_pool_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``--workers`` and ``--scheduler`` options of every command that runs sweeps."""
    parser.add_argument("--workers", type=int, metavar="N",
                        help="local worker processes (default: the machine's cores; 1 runs "
                             "in this process)")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="run on this Dask cluster instead (workers need holonomic-mpc "
                             "installed; pip install 'holonomic-mpc[sweeps]')")


def _parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="mpc-bench",
        description="Benchmark MPC tracking against feedforward + P baselines on holonomic "
                    "robots. Subcommands: 'report RESULTS', 'perf', 'soak', 'tune', 'sweep' "
                    "(see --help of each).",
    )
    parser.add_argument("--layouts", help=f"comma list of {', '.join(PRESETS)} "
                                          f"(default: {', '.join(DEFAULT_LAYOUTS)})")
    parser.add_argument("--trajectories",
                        help=f"comma list of {', '.join(ALL_TRAJECTORIES)} "
                             f"(default: {', '.join(TRAJECTORIES)})")
    parser.add_argument("--speeds", help="comma list of inside (peak wheel speed 0.8 x limit), "
                                         "beyond (1.3 x) or peak ratios like 1.1 (default: both)")
    parser.add_argument("--controllers",
                        help=f"comma list of {', '.join(CONTROLLERS)} "
                             f"(default: {', '.join(DEFAULT_CONTROLLERS)})")
    parser.add_argument("--heading", metavar="HEADINGS",
                        help=f"comma list of heading profiles, {', '.join(HEADINGS)} "
                             f"(default: {','.join(DEFAULT_HEADINGS)})")
    parser.add_argument("--horizon", type=int, default=20, help="MPC horizon in ticks (20)")
    parser.add_argument("--dt", type=float, default=0.05, help="control tick [s] (0.05)")
    parser.add_argument("--polygon-sides", type=int, default=16,
                        help="sides of the polygon inscribed in a swerve module's speed disk in "
                             "the OSQP path (even, >= 4; fewer: faster ticks, a little less "
                             "speed; default 16)")
    parser.add_argument("--duration", type=float,
                        help="simulated seconds per run (default: one lap + settling time)")
    parser.add_argument("--skip", type=float, default=2.0,
                        help="seconds of settling left out of the tracking errors (2.0)")
    parser.add_argument("--plant", default="ideal", choices=sorted(PLANT_PRESETS),
                        help="simulated robot: ideal, realistic (motor lag, 1-tick delay, "
                             "pose noise, slip) or motor (the layouts' motor presets driven "
                             "through their DC motors; see also 'mpc-bench motors')")
    parser.add_argument("--robot", metavar="TOML", help="also run a robot from a TOML file")
    parser.add_argument("--trajectory-csv", metavar="CSV",
                        help="also run a waypoint trajectory from a CSV file (t,x,y,theta)")
    parser.add_argument("--seed", type=int, default=0, help="seed for noise and slip (0)")
    parser.add_argument("--out", default="bench-out", metavar="DIR",
                        help="output folder (bench-out)")
    parser.add_argument("--no-report", action="store_true", help="skip the figures and HTML page")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run in seconds: mecanum, figure8, 3 s per run")
    add_pool_arguments(parser)
    return parser


def run(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if args.quick:
        args.layouts = args.layouts or "mecanum"
        args.trajectories = args.trajectories or "figure8"
        args.heading = args.heading or "fixed"
        args.duration = args.duration or 3.0
        args.skip = min(args.skip, 1.0)
    if args.horizon < 1 or not args.dt > 0 or (args.duration is not None and not args.duration > 0):
        raise ScenarioError("--horizon must be >= 1, --dt and --duration > 0")
    if args.polygon_sides < 4 or args.polygon_sides % 2:
        raise ScenarioError(
            f"--polygon-sides must be an even integer >= 4, got {args.polygon_sides}"
        )
    layouts = choose("layout", args.layouts, PRESETS, DEFAULT_LAYOUTS)
    chosen_robots = robots(layouts, args.robot)
    if args.plant == "motor":  # a motor plant drives robots with motors: the motor presets
        chosen_robots = {name: motor_preset(name) if name in layouts else robot
                         for name, robot in chosen_robots.items()}
    trajectories = choose("trajectory", args.trajectories, ALL_TRAJECTORIES, TRAJECTORIES)
    controllers = choose("controller", args.controllers, CONTROLLERS, DEFAULT_CONTROLLERS)
    headings = choose("heading", args.heading, HEADINGS, DEFAULT_HEADINGS)
    speeds = parse_speeds(args.speeds)
    csv_trajectory = csv_reference(args.trajectory_csv) if args.trajectory_csv else None
    settings = Settings(horizon=args.horizon, dt=args.dt, polygon_sides=args.polygon_sides)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    scenarios = build_scenarios(chosen_robots, trajectories, speeds, headings, csv_trajectory)
    started = time.perf_counter()
    failed: list[dict[str, Any]] = []
    with RunPool(args.workers, args.scheduler) as pool:
        print(f"mpc-bench: {len(scenarios)} scenarios x {len(controllers)} controllers, "
              f"plant {args.plant}, horizon {args.horizon}, dt {args.dt} s, "
              f"on {pool.description}", flush=True)
        for note in pool.notes:
            print(f"mpc-bench: note: {note}", flush=True)
        runs = run_all(scenarios, controllers, settings, args.duration, args.skip, args.plant,
                       args.seed, lambda line: print(line, flush=True), pool, failed)
    document = results_document(
        runs,
        command=" ".join(["mpc-bench", *argv]),
        settings={"horizon": args.horizon, "dt": args.dt, "polygon_sides": args.polygon_sides,
                  "duration": args.duration,
                  "plant": args.plant, "skip": args.skip, "headings": headings,
                  "seed": args.seed},
    )
    if failed:  # kept beside the runs, out of the tables and figures
        document["meta"]["failed_runs"] = [
            {key: value for key, value in run.items() if key != "traceback"} for run in failed]
    (out / "results.json").write_text(json.dumps(document))
    write_csv(runs, out / "results.csv")
    print()
    print(summary_table(runs))
    print(f"\nwrote {out / 'results.json'} and {out / 'results.csv'} "
          f"({time.perf_counter() - started:.0f} s)")
    if not args.no_report:
        _write_report(document, out / "report")
    if failed:
        print(f"mpc-bench: {len(failed)} run(s) failed (listed in results.json meta.failed_runs)",
              file=sys.stderr)
        return 1
    return 0


def _write_report(document: dict[str, Any], folder: Path) -> None:
    from benchmarks.report import write_report  # matplotlib only when asked for

    def progress(done: int, total: int) -> None:
        if done == total or done % 10 == 0:
            print(f"report: {done}/{total} figures", flush=True)

    index = write_report(document, folder, on_figure=progress)
    print(f"wrote {index}")


def report(argv: list[str]) -> int:
    parser = Parser(prog="mpc-bench report",
                                     description="Rebuild the report from a results.json.")
    parser.add_argument("results", help="path of results.json")
    parser.add_argument("--out", help="report folder (default: 'report' beside the results)")
    args = parser.parse_args(argv)
    from benchmarks.report import load_results

    path = Path(args.results)
    document = load_results(path)
    _write_report(document, Path(args.out) if args.out else path.parent / "report")
    return 0


def _tune(argv: list[str]) -> int:
    from benchmarks import tune  # Optuna only when asked for

    return tune.main(argv)


def _sweep(argv: list[str]) -> int:
    from benchmarks import sweep

    return sweep.main(argv)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mpc-bench`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    commands = {"report": report, "perf": perf.main, "soak": soak.main, "motors": motors.main,
                "fuzz": fuzz.main, "tune": _tune, "sweep": _sweep}
    try:
        if argv and argv[0] in commands:
            return commands[argv[0]](argv[1:])
        return run(argv)
    except (MpcError, OSError) as error:
        # Every bad option, file or value raises one of the project's errors (the
        # report's ReportError included) or an OSError: one line, no traceback.
        # Anything else is a bug and keeps its traceback.
        print(f"mpc-bench: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mpc-bench: interrupted", file=sys.stderr)
        return 130
