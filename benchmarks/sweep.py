"""``mpc-bench sweep``: Monte-Carlo over random robots, references, starts and plant faults.

Each case draws, from one seeded generator (so the cases depend on --seed only):

    robot       of a kind drawn from --kinds, as its wheel type samples it (omni, mecanum,
                swerve, ball: the ranges are in each sampler's docstring,
                mpc.robots.description.registry.robot_samplers); every kind: acceleration limit
                1.5-4 x the speed limit [1/s]
    reference   circle or figure-eight (1 m), fixed or tangent heading, peak wheel
                speed 0.5-1.4 x the limit
    start       0-0.3 m off the reference in any direction, heading off by +-0.5 rad
    plant       motor lag 0-50 ms, delay 0-2 ticks (told to the MPC), pose noise
                0-3 mm and 0-0.01 rad, slip 0-5 % (--no-faults: the ideal plant)
    seed        of the plant's noise and slip

and runs every --controllers on it (paired). The summary gives, per controller and
robot kind, runs that raised, runs with fallback ticks, speed and acceleration limit
violations (ticks commanding beyond a limit: must be 0 for the MPC; the command exits
with 1 otherwise) and the p50/p90/p99 of the RMS position, RMS heading and maximum
path errors after --skip seconds, as a table and sweep.json.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Mapping
from dataclasses import asdict
from typing import Any

import numpy as np

from benchmarks.cli import add_pool_arguments
from benchmarks.executor import RunPool, RunSpec, check_pool_options
from benchmarks.options import add_list_option
from benchmarks.outdir import add_force_argument, claim
from benchmarks.progress import Progress
from benchmarks.scenarios import CONTROLLERS, Parser, ScenarioError, Settings, choose, seed
from benchmarks.table import Column, format_table
from mpc.robots.description.registry import robot_samplers
from mpc.validation import MAX_HORIZON, MAX_SIMULATION_TICKS

#: Random cases in one sweep (--runs).
MAX_SWEEP_RUNS = 100_000

#: Robot kinds a sweep draws from by default (any of robot_samplers() on request).
KINDS: tuple[str, ...] = ("omni", "mecanum", "swerve", "ball")
QUANTILES: tuple[int, ...] = (50, 90, 99)


def random_robot(kind: str, rng: np.random.Generator) -> dict[str, Any]:
    """A robot description (for :func:`mpc.robots.from_dict`) of a registered kind
    (:func:`mpc.robots.description.registry.robot_samplers`), with an acceleration limit."""
    samplers = robot_samplers()
    if kind not in samplers:
        raise ScenarioError(f"unknown robot kind {kind!r}; valid: {', '.join(samplers)}")
    robot = samplers[kind](rng)
    robot["max_wheel_accel"] = robot["max_wheel_speed"] * rng.uniform(1.5, 4.0)
    robot["name"] = f"random-{kind}"
    return robot


def random_plant(rng: np.random.Generator) -> dict[str, Any]:
    """Plant faults (the fields of :class:`mpc.sim.PlantConfig`) within the stated ranges."""
    return {"motor_lag": rng.uniform(0.0, 0.05), "delay_ticks": int(rng.integers(0, 3)),
            "position_noise": rng.uniform(0.0, 0.003), "heading_noise": rng.uniform(0.0, 0.01),
            "slip": rng.uniform(0.0, 0.05)}


def sample_cases(count: int, kinds: list[str], controllers: list[str], seed: int,
                 faults: bool = True, duration: float = 10.0, skip: float = 2.0,
                 settings: Settings | None = None) -> list[RunSpec]:
    """``count`` random cases, each run by every controller (specs case by case)."""
    rng = np.random.default_rng(seed)
    specs = []
    for case in range(count):
        kind = kinds[int(rng.integers(len(kinds)))]
        robot = random_robot(kind, rng)
        trajectory: dict[str, Any] = {"shape": ("circle", "figure8")[int(rng.integers(2))],
                      "heading": ("fixed", "tangent")[int(rng.integers(2))],
                      "ratio": rng.uniform(0.5, 1.4)}
        distance, direction = rng.uniform(0.0, 0.3), rng.uniform(0.0, 2.0 * math.pi)
        offset = (distance * math.cos(direction), distance * math.sin(direction),
                  rng.uniform(-0.5, 0.5))
        plant: str | dict[str, Any] = random_plant(rng) if faults else "ideal"
        run_seed = int(rng.integers(2**31))
        labels = {"case": str(case), "layout": kind, "trajectory": trajectory["shape"],
                  "heading": trajectory["heading"], "speed": f"x{trajectory['ratio']:.3f}"}
        for name in controllers:
            delay = plant["delay_ticks"] if isinstance(plant, dict) and name.startswith(
                "mpc") else 0
            specs.append(RunSpec(robot=robot, trajectory=trajectory, controller=name,
                                 labels=labels, settings=settings or Settings(),
                                 duration=duration, skip=skip, delay_ticks=delay, plant=plant,
                                 seed=run_seed, initial_offset=offset))
    return specs


def summarise(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per controller and robot kind, then per controller over every kind."""
    rows = []
    groups = sorted({(r["controller"], r.get("layout", "-")) for r in results})
    groups += sorted({(r["controller"], "all") for r in results})
    for name, kind in groups:
        chosen = [r for r in results
                  if r["controller"] == name and kind in ("all", r.get("layout", "-"))]
        ok = [r["metrics"] for r in chosen if "error" not in r]
        row: dict[str, Any] = {
            "controller": name, "kind": kind, "runs": len(chosen),
            "errors": len(chosen) - len(ok),
            "runs_with_fallbacks": sum(m["failures"] > 0 for m in ok),
            "speed_violations": sum(m["limit_violations"] for m in ok),
            "accel_violations": sum(m["accel_violations"] for m in ok)}
        for key in ("rms_position_error", "rms_heading_error", "max_cross_track_error"):
            values = np.array([m[key] for m in ok]) if ok else np.full(1, np.nan)
            row[key] = {f"p{q}": float(np.percentile(values, q)) for q in QUANTILES}
        rows.append(row)
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The summary as text, every column as wide as its widest cell (mm and deg)."""
    columns = (Column("controller", align="<"), Column("kind", align="<"), Column("runs"),
               Column("raised"), Column("fallbk"), Column("viol"),
               Column("rms pos p50/p90/p99", "[mm]"), Column("rms head p50/p90/p99", "[deg]"),
               Column("max path p50/p90/p99", "[mm]"))
    return format_table(columns, [
        [str(row["controller"]), str(row["kind"]), str(row["runs"]), str(row["errors"]),
         str(row["runs_with_fallbacks"]), str(row["speed_violations"] + row["accel_violations"]),
         _quantiles(row, "rms_position_error", 1e3),
         _quantiles(row, "rms_heading_error", 180 / math.pi),
         _quantiles(row, "max_cross_track_error", 1e3)] for row in rows])


def _quantiles(row: dict[str, Any], key: str, scale: float) -> str:
    return "/".join(f"{row[key][f'p{q}'] * scale:.3g}" for q in QUANTILES)


def progress_line(result: Mapping[str, Any]) -> str:
    """One progress line's text for a result."""
    names = " ".join(str(result[key]) for key in
                     ("case", "layout", "trajectory", "heading", "speed", "controller")
                     if key in result)
    if "error" in result:
        return f"{names} FAILED {result['error']}"
    metrics = result["metrics"]
    return (f"{names} rms {metrics['rms_position_error'] * 1e3:.3g} mm, "
            f"{math.degrees(metrics['rms_heading_error']):.3g} deg")


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench sweep", description=__doc__.split("\n\n")[0],
                    epilog=__doc__.split("\n\n", 1)[1],
                    formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=100, help="random cases (100)")
    add_list_option(parser, "--kinds", help=f"comma list of {', '.join(KINDS)} (default: all)")
    add_list_option(parser, "--controllers", default="mpc-daqp",
                    help=f"comma list of {', '.join(CONTROLLERS)} (mpc-daqp)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of every random draw (0)")
    parser.add_argument("--no-faults", action="store_true", help="ideal plant")
    parser.add_argument("--duration", type=float, default=10.0, help="seconds per run (10)")
    parser.add_argument("--skip", type=float, default=2.0, help="settling seconds (2)")
    parser.add_argument("--horizon", type=int, default=20, help="MPC horizon (20)")
    parser.add_argument("--out", default="sweep-out", metavar="DIR",
                        help="writes sweep.json here (sweep-out)")
    add_force_argument(parser)
    add_pool_arguments(parser)
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if args.runs < 1 or args.horizon < 1 or not args.duration > args.skip >= 0:
        raise ScenarioError("--runs and --horizon must be >= 1, --duration > --skip >= 0")
    if args.runs > MAX_SWEEP_RUNS:
        raise ScenarioError(f"--runs must be at most {MAX_SWEEP_RUNS} (a bound of this "
                            f"command), got {args.runs}")
    longest = MAX_SIMULATION_TICKS * Settings().dt
    if not args.duration <= longest:
        raise ScenarioError(f"--duration must be at most {longest:g} s ({MAX_SIMULATION_TICKS} "
                            f"ticks of {Settings().dt:g} s), got {args.duration:g}")
    if args.horizon > MAX_HORIZON:
        raise ScenarioError(f"--horizon must be at most {MAX_HORIZON}, got {args.horizon}")
    kinds = choose("--kinds", "robot kind", args.kinds, tuple(robot_samplers()), KINDS)
    controllers = choose("--controllers", "controller", args.controllers, CONTROLLERS)
    specs = sample_cases(args.runs, kinds, controllers, args.seed, not args.no_faults,
                         args.duration, args.skip, Settings(horizon=args.horizon))
    check_pool_options(args.workers, args.scheduler)
    out = claim(args.out, ("sweep.json",), args.force)
    started = time.perf_counter()
    with RunPool(args.workers, args.scheduler) as pool, Progress(len(specs), "runs") as bar:
        bar.print(f"sweep: {args.runs} cases x {len(controllers)} controllers on "
                  f"{pool.description}")
        results = pool.run(specs, bar.advance, progress_line)
    rows = summarise(results)
    print()
    print(table(rows))
    document = {"command": " ".join(["mpc-bench", "sweep", *argv]), "summary": rows,
                "cases": [{"spec": asdict(spec), "result": result}
                          for spec, result in zip(specs, results, strict=True)]}
    (out / "sweep.json").write_text(json.dumps(document), encoding="utf-8")
    print(f"\nwrote {out / 'sweep.json'} ({time.perf_counter() - started:.0f} s)")
    violations = sum(row["speed_violations"] + row["accel_violations"] for row in rows
                     if row["controller"].startswith("mpc") and row["kind"] == "all")
    if violations:
        print(f"mpc-bench sweep: {violations} limit violation(s) by the MPC", flush=True)
        return 1
    return 0
