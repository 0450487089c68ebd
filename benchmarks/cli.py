# PYTHON_ARGCOMPLETE_OK  (argcomplete looks for this line in the console script's module)
"""``mpc-bench``: compare tracking controllers on holonomic robots.

    mpc-bench [options]          run the benchmark (the ``run`` command; defaults: every
                                 layout, circle and figure-eight, inside and 30% beyond the
                                 wheel limits, MPC (daqp with default and tuned weights,
                                 IPOPT, path mode) and baselines)
    mpc-bench --trajectory FILE  run a Choreo .traj on its own robot (or a CSV on the layouts)
    mpc-bench COMMAND [options]  one of :data:`COMMANDS` (``mpc-bench --help`` lists them)

A list is taken by the same plural option in every command (:mod:`benchmarks.options`);
no option is matched by a prefix (``--control`` is an error), and a mistyped option,
name or command gets the closest known one. A command refuses to write into an ``--out``
folder that holds its results already, unless given ``--force``. On a terminal, long
commands draw a progress bar with one ETA (:mod:`benchmarks.progress`; the benchmark's
learned per controller kind and counting its report, :mod:`benchmarks.eta`); elsewhere
they print one plain line per finished run, ending with the ETA. The benchmark ends with
a one-line verdict (the report's headline, :func:`benchmarks.report.verdict`) and the
report's path. Shell completion,
if ``argcomplete`` is installed: ``eval "$(register-python-argcomplete mpc-bench)"``.

Runs are independent: ``--workers N`` spreads them over N local processes (default:
the machine's cores) and ``--scheduler tcp://HOST:PORT`` over a Dask cluster, with the
same results run for run (see :mod:`benchmarks.executor`).
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.eta import EtaEstimator, eta_errors, format_seconds
from benchmarks.executor import RunPool, check_pool_options
from benchmarks.options import add_list_option
from benchmarks.outdir import add_force_argument, claim
from benchmarks.plan import run_all
from benchmarks.progress import Progress
from benchmarks.reference_files import file_scenarios, read_reference
from benchmarks.runner import build_scenarios, results_document, summary_table, write_csv
from benchmarks.scenarios import (
    ALL_TRAJECTORIES,
    CONTROLLERS,
    DEFAULT_CONTROLLERS,
    DEFAULT_HEADINGS,
    DEFAULT_LAYOUTS,
    HEADINGS,
    LAYOUTS,
    TRAJECTORIES,
    Parser,
    ScenarioError,
    Settings,
    applies,
    check_plan_sizes,
    choose,
    csv_reference,
    did_you_mean,
    parse_speeds,
    robots,
    seed,
)
from mpc.errors import MpcError, ReportError
from mpc.plot.results import counted
from mpc.robots import motor_preset
from mpc.sim import PLANT_PRESETS
from mpc.validation import MAX_HORIZON, MAX_POLYGON_SIDES, MAX_SIMULATION_TICKS, MAX_STEP


def add_pool_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``--workers`` and ``--scheduler`` options of every command that runs sweeps."""
    parser.add_argument("--workers", type=int, metavar="N",
                        help="local worker processes (default: the machine's cores; 1 runs "
                             "in this process)")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="run on this Dask cluster instead (workers need holonomic-mpc "
                             "installed; pip install 'holonomic-mpc[sweeps]')")


def _parser(prog: str = "mpc-bench run", add_help: bool = True) -> Parser:
    """The options of ``mpc-bench [run]``."""
    parser = Parser(
        prog=prog, add_help=add_help,
        description="Benchmark MPC tracking against feedforward + P baselines on holonomic "
                    "robots.",
        epilog="Other commands: " + ", ".join(name for name in COMMANDS if name != "run")
               + " (mpc-bench --help lists them; mpc-bench COMMAND --help for each).",
    )
    add_list_option(parser, "--layouts",
                    help=f"comma list of {', '.join(LAYOUTS)} "
                         f"(default: {', '.join(DEFAULT_LAYOUTS)})")
    add_list_option(parser, "--trajectories",
                    help=f"comma list of {', '.join(ALL_TRAJECTORIES)} "
                         f"(default: {', '.join(TRAJECTORIES)})")
    add_list_option(parser, "--speeds",
                    help="comma list of inside (peak wheel speed 0.8 x limit), beyond (1.3 x) "
                         "or peak ratios like 1.1 (default: both)")
    add_list_option(parser, "--controllers",
                    help=f"comma list of {', '.join(CONTROLLERS)} "
                         f"(default: {', '.join(DEFAULT_CONTROLLERS)})")
    add_list_option(parser, "--headings",
                    help=f"comma list of heading profiles, {', '.join(HEADINGS)} "
                         f"(default: {','.join(DEFAULT_HEADINGS)})")
    parser.add_argument("--horizon", type=int, default=20, help="MPC horizon in ticks (20)")
    parser.add_argument("--dt", type=float, default=0.05, help="control tick [s] (0.05)")
    parser.add_argument("--polygon-sides", type=int,
                        help="fast paths: take each swerve module's speed and acceleration "
                             "disks as a constant polygon of this many sides (even, >= 4) "
                             "instead of the default, the speed disk linearised around "
                             "each tick's plan and the acceleration disk a 16-gon")
    parser.add_argument("--duration", type=float,
                        help="simulated seconds per run (default: 2.2 laps at the fastest "
                             "pace the wheels allow + --skip, at least 6 s)")
    parser.add_argument("--skip", type=float,
                        help="seconds of settling left out of the tracking errors (default "
                             "2.0, 1.0 with --quick); with --duration, at most half of it; "
                             "without, the run lasts its 2.2 laps after the skip")
    parser.add_argument("--plant", default="ideal", choices=sorted(PLANT_PRESETS),
                        help="simulated robot: ideal, realistic (motor lag, 1-tick delay, "
                             "pose noise, slip) or motor (the layouts' motor presets driven "
                             "through their DC motors; see also 'mpc-bench motors')")
    parser.add_argument("--no-command-ramp", dest="command_ramp", action="store_false",
                        help="with --plant motor: do not tell the MPCs that the motor "
                             "plant's wheel loops ramp each command over the tick (they are "
                             "told by default: Controller(command_ramp=True))")
    parser.add_argument("--robot", metavar="TOML", help="also run a robot from a TOML file")
    parser.add_argument("--trajectory", action="append", metavar="FILE",
                        help="run the reference in FILE: a Choreo .traj on the swerve robot it "
                             "was planned for, a CSV (t,x,y,theta) on the chosen layouts; "
                             "named after the file, run as given; repeatable. The built-in "
                             "shapes then run only if --trajectories is given")
    parser.add_argument("--trajectory-csv", metavar="CSV",
                        help="also run a waypoint trajectory from a CSV file (t,x,y,theta) on "
                             "every layout, named 'csv' (older form of --trajectory FILE.csv)")
    parser.add_argument("--seed", type=seed, default=0, help="seed for noise and slip (0)")
    parser.add_argument("--out", default="bench-out", metavar="DIR",
                        help="output folder (bench-out)")
    add_force_argument(parser)
    parser.add_argument("--no-report", action="store_true", help="skip the figures and HTML page")
    parser.add_argument("--quick", action="store_true",
                        help="a run in seconds that shows the difference: mecanum and "
                             "swerve, figure8, fixed heading, beyond the limits, 6 s per "
                             "run, the default controllers but mpc-ipopt (with "
                             "--trajectory: 3 s of each file)")
    add_pool_arguments(parser)
    return parser


#: What ``--quick`` runs, unless given: the scenarios that tell MPC from the baselines
#: (beyond the wheel limits, where clipping or desaturating a P law falls behind), with
#: every default controller but the exact IPOPT path (mpc-daqp solves its problem).
QUICK: dict[str, str] = {
    "layouts": "mecanum,swerve", "trajectories": "figure8", "headings": "fixed",
    "speeds": "beyond",
    "controllers": ",".join(name for name in DEFAULT_CONTROLLERS if name != "mpc-ipopt")}
QUICK_DURATION = 6.0  # [s] a run of --quick: 1 s of settling, then 5 s measured
QUICK_FILE_DURATION = 3.0  # [s] of each --trajectory file under --quick


def _check_run_numbers(args: argparse.Namespace) -> None:
    """The run's numbers within the library's stated bounds, each error naming its flag."""
    if not 1 <= args.horizon <= MAX_HORIZON:
        raise ScenarioError(f"--horizon must be 1 to {MAX_HORIZON} ticks, got {args.horizon}")
    if not 0 < args.dt <= MAX_STEP:
        raise ScenarioError(f"--dt must be a number > 0 and at most {MAX_STEP:g} [s], "
                            f"got {args.dt}")
    longest = MAX_SIMULATION_TICKS * args.dt
    if args.duration is not None and not 0 < args.duration <= longest:
        raise ScenarioError(f"--duration must be > 0 and at most {longest:g} s "
                            f"({MAX_SIMULATION_TICKS} ticks), got {args.duration}")
    if args.skip is not None and not (math.isfinite(args.skip) and args.skip >= 0):
        raise ScenarioError(f"--skip must be a finite number >= 0 [s], got {args.skip}")
    if args.polygon_sides is not None and (
            not 4 <= args.polygon_sides <= MAX_POLYGON_SIDES or args.polygon_sides % 2):
        raise ScenarioError(f"--polygon-sides must be an even integer 4 to "
                            f"{MAX_POLYGON_SIDES}, got {args.polygon_sides}")


def _check_run_lengths(scenarios: list[Any], args: argparse.Namespace) -> None:
    """Every run's length within the simulated-ticks bound and longer than one tick after
    the settling time, or ScenarioError naming --dt, --duration and --skip."""
    from benchmarks.runner import default_duration

    for scenario in scenarios:
        length = args.duration or default_duration(scenario, args.skip)
        given = "--duration" if args.duration else "its default duration (2.2 laps + --skip)"
        if length / args.dt > MAX_SIMULATION_TICKS:
            raise ScenarioError(
                f"--dt {args.dt:g} s makes a run of {length:g} s ({given}) "
                f"{length / args.dt:.3g} ticks; at most {MAX_SIMULATION_TICKS} ticks are "
                "simulated (raise --dt or shorten --duration)")
        if length - min(args.skip, 0.5 * length) < args.dt:
            raise ScenarioError(
                f"--dt {args.dt:g} s leaves no tick of a {length:g} s run ({given}) after "
                f"--skip {args.skip:g} s (lower --dt or lengthen --duration)")


def run(argv: list[str], prog: str = "mpc-bench run") -> int:
    """``mpc-bench [run] [options]``: the benchmark; results.json, results.csv, report/."""
    args = _parser(prog).parse_args(argv)
    files = [read_reference(path) for path in args.trajectory or []]
    shapes = args.trajectories is not None or not files  # files alone: only the files
    if files and not shapes:
        own_robots = all(file.robot is not None for file in files)  # Choreo files only
        given = (("--speeds", args.speeds), ("--headings", args.headings),
                 ("--layouts", args.layouts if own_robots else None))
        ignored = [flag for flag, value in given if value is not None]
        if ignored:
            raise ScenarioError(f"{' and '.join(ignored)} apply to the built-in shapes; files "
                                "given with --trajectory run as timed, a .traj on its own "
                                "robot (add --trajectories to run shapes too)")
    _check_run_numbers(args)
    if args.quick:  # defaults for what was not given (a given value is kept, checked above)
        for name, value in QUICK.items():
            if getattr(args, name) is None:
                setattr(args, name, value)
        if args.duration is None:  # a file runs a short stretch of itself
            args.duration = QUICK_DURATION if shapes else QUICK_FILE_DURATION
    if args.skip is not None and args.duration is not None and args.skip > 0.5 * args.duration:
        raise ScenarioError(f"--skip {args.skip:g} s must be at most half of --duration "
                            f"{args.duration:g} s (the tracking errors are taken over the "
                            "rest)")
    if args.skip is None:  # the default settling time, shortened for a short run
        args.skip = 1.0 if args.quick else 2.0
        if args.duration is not None:
            args.skip = min(args.skip, 0.5 * args.duration)
    layouts = choose("--layouts", "layout", args.layouts, LAYOUTS, DEFAULT_LAYOUTS)
    chosen_robots = robots(layouts, args.robot)
    if not args.command_ramp and args.plant != "motor":
        raise ScenarioError("--no-command-ramp applies to --plant motor (the other plants' "
                            "wheels step to each command; their MPCs are not told of a ramp)")
    if args.plant == "motor":  # a motor plant drives robots with motors: the motor presets
        chosen_robots = {name: motor_preset(name) if name in layouts else robot
                         for name, robot in chosen_robots.items()}
        for name, robot in chosen_robots.items():
            if robot.dynamics is None:
                raise ScenarioError(f"--plant motor drives robots through their motor models; "
                                    f"robot {name!r} of --robot {args.robot!r} has none (add a "
                                    "[dynamics] table, or use --plant ideal or realistic)")
    trajectories = choose("--trajectories", "trajectory", args.trajectories, ALL_TRAJECTORIES,
                          TRAJECTORIES)
    controllers = choose("--controllers", "controller", args.controllers, CONTROLLERS,
                         DEFAULT_CONTROLLERS)
    headings = choose("--headings", "heading", args.headings, HEADINGS, DEFAULT_HEADINGS)
    speeds = parse_speeds(args.speeds)
    for file in files:
        if file.robot is not None and args.plant == "motor":
            raise ScenarioError(f"--plant motor drives robots through their motor models; the "
                                f"robot of {str(file.path)!r} has none (use --plant ideal or "
                                "realistic)")
    csv_trajectory = csv_reference(args.trajectory_csv) if args.trajectory_csv else None
    settings = Settings(horizon=args.horizon, dt=args.dt, polygon_sides=args.polygon_sides)
    check_plan_sizes({**chosen_robots, **{str(file.path): file.robot for file in files
                                          if file.robot is not None}}, controllers, settings)
    check_pool_options(args.workers, args.scheduler)
    scenarios = [*build_scenarios(chosen_robots, trajectories if shapes else [], speeds,
                                  headings, csv_trajectory),
                 *file_scenarios(files, chosen_robots)]
    _check_run_lengths(scenarios, args)
    total = sum(applies(name, scenario.robot) for scenario in scenarios for name in controllers)
    skipped = sorted({f"{name} on {scenario.layout}" for scenario in scenarios
                      for name in controllers if not applies(name, scenario.robot)})
    if total == 0:
        raise ScenarioError(f"no run: {', '.join(skipped)} do(es) not apply (--controllers "
                            "and --layouts; mpc-tuned needs a preset with tuned weights, "
                            "ff-p-setpoint a swerve robot)")
    # the output folder last, once every option is known to be good (no empty folder left)
    writes = ("results.json", "results.csv", "eta.json",
              *(() if args.no_report else ("report/index.html",)))
    out = claim(args.out, writes, args.force)
    started = time.perf_counter()
    failed: list[dict[str, Any]] = []
    workers = args.workers or os.cpu_count() or 1
    estimator = EtaEstimator()
    if not args.no_report:  # the report's figures: one per run, one per scenario, two more
        estimator.plan_report(total, len(scenarios) + 2)
    with Progress(total, "runs", estimator=estimator) as progress:
        with RunPool(args.workers, args.scheduler) as pool:
            progress.print(f"mpc-bench: {counted(len(scenarios), 'scenario')} x "
                           f"{counted(len(controllers), 'controller')} "
                           f"({total} runs), plant {args.plant}, horizon {args.horizon}, "
                           f"dt {args.dt} s, on {pool.description}")
            for note in pool.notes:
                progress.print(f"mpc-bench: note: {note}")
            if skipped:
                progress.print(f"mpc-bench: note: not run, as they do not apply: "
                               f"{', '.join(skipped)}")
            runs = run_all(scenarios, controllers, settings, args.duration, args.skip,
                           args.plant, args.seed, progress.advance, pool, failed,
                           command_ramp=None if args.command_ramp else False,
                           estimator=estimator)
        document = results_document(
            runs,
            command=" ".join(["mpc-bench", *argv]),
            settings={"horizon": args.horizon, "dt": args.dt,
                      "polygon_sides": args.polygon_sides, "duration": args.duration,
                      "plant": args.plant,
                      "command_ramp": args.plant == "motor" and args.command_ramp,
                      "skip": args.skip, "headings": headings,
                      "seed": args.seed,
                      "trajectory_files": [str(file.path) for file in files]},
        )
        if failed:  # kept beside the runs, out of the tables and figures
            document["meta"]["failed_runs"] = [
                {key: value for key, value in run.items() if key != "traceback"}
                for run in failed]
        (out / "results.json").write_text(json.dumps(document))
        write_csv(runs, out / "results.csv")
        progress.print("")
        progress.print(summary_table(runs))
        progress.print(f"\nwrote {out / 'results.json'} and {out / 'results.csv'} "
                       f"({time.perf_counter() - started:.0f} s)")
        index = None
        if not args.no_report and runs:
            index = _write_report(document, out / "report", workers, progress)
    shown = index if index is not None else out / "results.json"
    _write_eta(estimator, out / "eta.json")
    from benchmarks.report import verdict  # no matplotlib: the headline's numbers only

    print(f"mpc-bench: {verdict(runs)}; {'report' if index else 'results'}: {shown} "
          f"({format_seconds(time.perf_counter() - started)} in all)")
    if failed:
        print(f"mpc-bench: {len(failed)} run(s) failed (listed in results.json meta.failed_runs)",
              file=sys.stderr)
        return 1
    return 0


def _write_eta(estimator: EtaEstimator, path: Path) -> None:
    """The run's ETAs as given out (``log``: [elapsed, eta] [s]), its whole time
    (``wall_s``) and the ETA's relative error at a tenth, half and nine tenths of it
    (:func:`benchmarks.eta.eta_errors`), to check the estimator against a real run."""
    wall = estimator.clock() - estimator.started
    errors = eta_errors(estimator.log, wall)
    path.write_text(json.dumps({"wall_s": wall, "errors": {f"{k:g}": v for k, v in
                                                            errors.items()},
                                "log": [list(pair) for pair in estimator.log]}))


def _write_report(document: dict[str, Any], folder: Path, workers: int = 1,
                  progress: Progress | None = None) -> Path:
    """The report of ``document`` in ``folder``, its figures counted on ``progress`` (a
    display of its own if None); returns the page's path."""
    from benchmarks.report import write_report  # matplotlib only when asked for

    runs = document["runs"]
    if progress is None:
        own_eta = EtaEstimator()
        own_eta.plan_runs([], workers)
        scenarios = {tuple(run.get(key) for key in ("layout", "trajectory", "heading", "speed"))
                     for run in runs}
        own_eta.plan_report(len(runs), len(scenarios) + 2)
        with Progress(0, "report", estimator=own_eta) as own:
            return _write_report(document, folder, workers, own)
    estimator = progress.estimator
    if estimator is not None:
        estimator.report_started()
    progress.stage("report figures", 0)

    def on_figure(done: int, total: int) -> None:
        if estimator is not None:
            estimator.report_progress(done, total)
        every = not progress.live and (done == total or done % 10 == 0)
        progress.update(done, total, f"report: {done}/{total} figures" if every else None)

    return write_report(document, folder, on_figure=on_figure, workers=workers)


def _report_parser() -> Parser:
    parser = Parser(prog="mpc-bench report", description="Rebuild the report from a results.json.")
    parser.add_argument("results", help="path of results.json")
    parser.add_argument("--out", metavar="DIR",
                        help="report folder (default: 'report' beside the results, or the "
                             "results' own folder when it is a report (mpc.plot.report "
                             "writes its results.json there), rebuilt in place; another "
                             "folder that holds a report is refused without --force)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="processes drawing the runs' figures (default: the machine's "
                             "cores)")
    add_force_argument(parser)
    return parser


def report(argv: list[str]) -> int:
    """``mpc-bench report RESULTS``: the figures and HTML page of a results.json again."""
    args = _report_parser().parse_args(argv)
    from benchmarks.report import load_results

    if args.workers is not None and args.workers < 1:
        raise ScenarioError(f"--workers must be >= 1, got {args.workers}")
    path = Path(args.results)
    document = load_results(path)
    # The report beside its own results.json is derived from it alone: rebuilt in place.
    # mpc.plot.report keeps results.json inside the report folder: that folder is the report.
    mine = path.parent if (path.parent / "index.html").exists() else path.parent / "report"
    folder = claim(Path(args.out) if args.out else mine, ("index.html",),
                   args.force or args.out is None)
    try:
        index = _write_report(document, folder, args.workers or os.cpu_count() or 1)
    except ReportError as error:  # a damaged field found while drawing: name the file
        raise ReportError(f"results file {str(path)!r}: {error}") from None
    print(f"wrote {index}")
    return 0


@dataclass(frozen=True)
class Command:
    """A subcommand: its one-line ``summary`` and the module (imported when used) whose
    ``parser`` and ``main`` functions build its options and run it."""

    summary: str
    module: str
    parser: str = "_parser"
    main: str = "main"

    def function(self, name: str) -> Callable[..., Any]:
        return getattr(importlib.import_module(self.module), name)  # type: ignore[no-any-return]


#: Every subcommand, in the order ``mpc-bench --help`` lists them; ``run`` is the default.
COMMANDS: dict[str, Command] = {
    "run": Command("run the benchmark (the default: 'mpc-bench [options]' is 'mpc-bench run "
                   "[options]')", "benchmarks.cli", "_parser", "run"),
    "report": Command("rebuild the figures and HTML report from a results.json",
                      "benchmarks.cli", "_report_parser", "report"),
    "perf": Command("tick time against horizon for every solver path, per layout and mode",
                    "benchmarks.perf"),
    "qp-replay": Command("the fast path's QPs from a run, solved again by each installed QP "
                         "solver", "benchmarks.qp_replay"),
    "soak": Command("memory and tick time over a long run", "benchmarks.soak"),
    "export": Command("one robot preset's controller as a self-contained C library "
                      "(mpc.export_c)", "benchmarks.export"),
    "export-check": Command("the exported C library, built with CMake, against the Python "
                            "controller on recorded ticks of every preset",
                            "benchmarks.export_check"),
    "motors": Command("motor-aware MPC against kinematic control on the motor plant",
                      "benchmarks.motors"),
    "fuzz": Command("seeded abuse of every robot and control path, counting unsafe commands",
                    "benchmarks.fuzz"),
    "tune": Command("tune the MPC's cost weights for a robot (Optuna)", "benchmarks.tune"),
    "sweep": Command("Monte-Carlo over random robots, starts and plant faults",
                     "benchmarks.sweep"),
    "docs-pages": Command("regenerate the docs' Benchmarks and Performance pages and the "
                          "README's results table from benchmarks/results/",
                          "benchmarks.docs_pages"),
    "slider": Command("the slider robot (SWOM) on its own plant, MPC against the reactive "
                      "baseline", "benchmarks.slider"),
}


def command_parser() -> Parser:
    """The whole command line as one argparse tree, for ``--help`` and shell completion:
    the subcommands (each with its own options) and, at the top, the options of ``run``."""
    parser = Parser(
        prog="mpc-bench", usage="mpc-bench [COMMAND] [options]",
        parents=[_parser("mpc-bench", add_help=False)],
        description="Benchmark MPC tracking against feedforward + P baselines on holonomic "
                    "robots. Without a COMMAND, runs the benchmark with the options below.",
        epilog="'mpc-bench --version' prints the version. 'mpc-bench COMMAND --help' shows a "
               "command's options. An --out folder that "
               "holds a command's results is not overwritten without --force. Shell "
               "completion (pip install argcomplete): "
               'eval "$(register-python-argcomplete mpc-bench)"',
    )
    parser._positionals.title = "commands"  # the subcommands, listed before the options
    parser._optionals.title = "options of run (the default command)"
    subparsers = parser.add_subparsers(prog="mpc-bench", metavar="COMMAND", dest="command")
    for name, command in COMMANDS.items():
        own: Parser = command.function(command.parser)()
        subparsers.add_parser(name, parents=[own], add_help=False, help=command.summary,
                              description=own.description, epilog=own.epilog,
                              formatter_class=own.formatter_class)
    return parser


def _complete() -> None:
    """Shell completion through argcomplete, if installed (it exits when completing)."""
    try:
        import argcomplete
    except ImportError:
        return
    argcomplete.autocomplete(command_parser())


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mpc-bench`` console script."""
    if argv is None:
        if "_ARGCOMPLETE" in os.environ:  # the shell asks for completions
            _complete()
        argv = sys.argv[1:]
    argv = list(argv)
    prog = f"mpc-bench {argv[0]}" if argv and argv[0] in COMMANDS else "mpc-bench"
    try:
        if argv and argv[0] in ("-h", "--help"):
            command_parser().print_help()
            return 0
        if argv and argv[0] == "--version":
            from importlib.metadata import version

            print(f"mpc-bench {version('holonomic-mpc')}")
            return 0
        if argv and argv[0] in COMMANDS:
            command = COMMANDS[argv[0]]
            return command.function(command.main)(argv[1:])  # type: ignore[no-any-return]
        if argv and not argv[0].startswith("-"):
            raise ScenarioError(f"unknown command {argv[0]!r}{did_you_mean(argv[0], COMMANDS)}; "
                                f"commands: {', '.join(COMMANDS)} (or options of run: "
                                "mpc-bench --help)")
        return run(argv, prog="mpc-bench")
    except (MpcError, OSError) as error:
        # Every bad option, file or value raises one of the project's errors (the
        # report's ReportError included) or an OSError: one line, no traceback.
        # Anything else is a bug and keeps its traceback.
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
