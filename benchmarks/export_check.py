"""``mpc-bench export-check``: the exported C library against the Python controller, on
every preset and mode the compiled tick covers.

For each robot preset (``--layouts``: every shipped preset, then every motor preset,
named ``<layout>-motors`` as its file, :func:`mpc.robots.motor_preset`) x mode x speed:
the Python controller (daqp,
``compiled=False``) runs ``--ticks`` ticks in a closed loop on a plant that differs from
the model (3 % slip along the body x axis, five Euler substeps; the model integrates SE(2)
exactly), from a start
0.16 m and 0.2 rad off the reference, on a figure-eight at ``--speeds`` x the wheel limits
(fixed heading). Its measured poses and the reference windows it sampled are fed to the
library :func:`mpc.export_c` writes for the same controller, built with gcc from its
``CMakeLists.txt`` (:mod:`benchmarks.exported`); the command reports the largest
difference of a commanded twist component or wheel speed, and the ticks whose status
differs, and the same against the compiled tick run in this process on those ticks
(``compiled=True``: the library's graphs and daqp build; the Python tick's daqp is another
release, whose answers on ill-conditioned problems drift apart from it over ticks). Path
mode: the samples the Python controller took each tick (its progress guess and warm-up
rounds, :class:`~benchmarks.exported.SampleLog`) are fed to the library's three calls, and
the line also reports how far the times the library asked for, and the reference time it
tracked, are from the Python controller's. A motor preset's Python tick hands daqp every
row, as the library does (no row screen). The Python tick keeps its Hessian by the
compiled tick's rule for this (rebuilt at once when it drifted beyond
:data:`mpc.tick.reuse.REBUILD_DRIFT`, never staged: a kept Hessian changes a step by far
more than rounding, docs/guide/compiled-tick.md). A preset or mode the compiled tick does
not cover is a line with its reason. Exit code 1 if any difference exceeds
``--tolerance`` or any status differs.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

import mpc.solvers.dense as dense
import mpc.solvers.row_screen as row_screen
import mpc.tick.reuse as reuse
from benchmarks.exported import (
    ExportBuildError,
    ExportedTick,
    SampleLog,
    command_differences,
    path_tick_inputs,
    tick_inputs,
)
from benchmarks.options import add_list_option
from benchmarks.scenarios import Parser, ScenarioError, choose, parse_speeds, reference
from mpc import Command, Controller, Status
from mpc.control.controller import MODES
from mpc.robots import MOTOR_ROBOT_PRESETS, Robot, motor_preset, preset, shipped_presets
from mpc.tick import UnsupportedTickError

#: The start's offset from the reference's first pose (x [m], y [m], heading [rad]).
START_OFFSET = (0.15, -0.05, 0.2)
SLIP = 0.03  # the plant's slip along the body x axis
SUBSTEPS = 5  # the plant's Euler substeps a tick
TOLERANCE = 1e-9  # the largest command difference accepted [m/s, rad/s]
MOTORS = "-motors"  # a motor preset's name here: its layout and this (its file's name)


def robot_names() -> tuple[str, ...]:
    """The robots ``--layouts`` takes: every shipped preset, then every motor preset."""
    return (*shipped_presets(), *(f"{name}{MOTORS}" for name in MOTOR_ROBOT_PRESETS))


def robot_named(name: str) -> Robot:
    """The robot of a :func:`robot_names` name (a ``-motors`` name: the motor preset)."""
    layout = name.removesuffix(MOTORS)
    return motor_preset(layout) if layout != name else preset(name)


@contextmanager
def compiled_reuse_rule(path: bool = False) -> Iterator[None]:
    """The Python tick rebuilding its Hessian at once when it drifted beyond
    :data:`~mpc.tick.reuse.REBUILD_DRIFT` (no staged rebuild): the compiled tick's rule
    (as tests/tick_loop.py's ``same_reuse_rule``); ``path``: and never with the last
    build's sensitivities (``COST_ONLY_DRIFT``; tests/test_compiled_path.py's
    ``path_reuse_rule``)."""
    saved = dense.REBUILD_NOW, dense.REBUILD_EARLY, dense.COST_ONLY_DRIFT
    dense.REBUILD_NOW = dense.REBUILD_EARLY = reuse.REBUILD_DRIFT
    if path:
        dense.COST_ONLY_DRIFT = -1.0
    try:
        yield
    finally:
        dense.REBUILD_NOW, dense.REBUILD_EARLY, dense.COST_ONLY_DRIFT = saved


@contextmanager
def every_row() -> Iterator[None]:
    """The Python tick handing daqp every motor row (no row screen,
    :mod:`mpc.solvers.row_screen`) and never rebuilding its Hessian with the last build's
    sensitivities (``COST_ONLY_DRIFT``: a motor robot's cost moves with the reference), as
    the exported library does (as tests/test_compiled_motor_tick.py and tick_loop.py
    compare them)."""
    saved = row_screen.SCREEN_AFTER, dense.COST_ONLY_DRIFT
    row_screen.SCREEN_AFTER, dense.COST_ONLY_DRIFT = 10**9, -1.0
    try:
        yield
    finally:
        row_screen.SCREEN_AFTER, dense.COST_ONLY_DRIFT = saved


def plant_step(pose: np.ndarray, twist: np.ndarray, dt: float) -> np.ndarray:
    """The next pose on a plant that differs from the model: :data:`SLIP` along the body
    x axis, :data:`SUBSTEPS` Euler substeps over ``dt`` [s]."""
    pose = np.array(pose, dtype=float)
    vx, vy, omega = twist[0] * (1.0 - SLIP), twist[1], twist[2]
    for _ in range(SUBSTEPS):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        pose += dt / SUBSTEPS * np.array([c * vx - s * vy, s * vx + c * vy, omega])
    return pose


def record(controller: Controller, ticks: int, log: SampleLog | None = None
           ) -> tuple[list[float], list[np.ndarray], list[Command], list[Any]]:
    """``controller``'s closed loop on the plant (:func:`plant_step`): each tick's time
    [s], the measured pose, the command and (with ``log``, path mode) the reference's
    samples the tick took."""
    dt = controller.dt
    pose = controller.trajectory.sample(0.0).pose + np.array(START_OFFSET)
    times, poses, commands, samples = [], [], [], []
    for k in range(ticks):
        if log is not None:
            log.take()
        command = controller.step(pose, k * dt)
        times.append(k * dt)
        poses.append(pose)
        commands.append(command)
        samples.append(log.take() if log is not None else None)
        pose = plant_step(pose, command.twist, dt)
    return times, poses, commands, samples


def check(robot_name: str, mode: str, ratio: float, ticks: int, horizon: int,
          dt: float) -> dict[str, Any]:
    """One preset, mode and speed: ``{"supported": False, "reason": ...}``, or the
    comparison (``max_difference``, ``status_mismatches``, ``fallbacks``, ``build_s``)."""
    robot = robot_named(robot_name)
    trajectory = reference("figure8", "fixed", robot, ratio)
    try:
        exported = Controller(robot, trajectory, horizon=horizon, dt=dt, mode=mode,
                              compiled="virtual-machine")
    except UnsupportedTickError as error:
        return {"supported": False, "reason": str(error)}
    if robot.steer_states:  # (the loop and tick_inputs carry no measured steer angles)
        return {"supported": False, "reason": f"robot {robot_name!r}: export-check does not "
                "feed a caster robot's measured steer angles yet"}
    library = ExportedTick(exported)
    path = mode == "path"  # (the reference sampled where the library says: recorded)
    log = SampleLog(trajectory) if path else None
    with compiled_reuse_rule(path), every_row():
        python = Controller(robot, trajectory, horizon=horizon, dt=dt, mode=mode)
        times, poses, commands, samples = record(python, ticks, log)
    replay = library.replay(path_tick_inputs(times, poses, samples) if path
                            else tick_inputs(python, times, poses))
    difference, mismatches = command_differences(replay, commands)
    progress = {}
    if path:  # where the library sampled, and the reference time it tracked
        assert replay.time_gap is not None and replay.reference_time is not None
        progress = {"time_gap": float(replay.time_gap.max(initial=0.0)),
                    "reference_time_difference": float(np.abs(
                        replay.reference_time - [c.reference_time for c in commands]).max())}
    own = compiled_differences(robot, trajectory, horizon, dt, mode, times, poses, replay)
    return {"supported": True, "max_difference": difference, "status_mismatches": mismatches,
            "compiled_difference": own[0], "compiled_status_mismatches": own[1],
            **progress, "ticks": len(commands),
            "fallbacks": sum(command.status is not Status.SOLVED for command in commands),
            "hessians_built": int(replay.rebuilt.sum()), "build_s": library.build_time,
            "cached": library.cached}


def compiled_differences(robot: Robot, trajectory: Any, horizon: int, dt: float, mode: str,
                         times: list[float], poses: list[np.ndarray],
                         replay: Any) -> tuple[float, int]:
    """The library's commands (``replay``) against the compiled tick's in this process
    (``compiled=True``: the same graphs, linked with the same daqp) on the same recorded
    ticks: its largest difference and the ticks whose status differs. Beside the Python
    controller's, it tells the export's own error from the two daqp releases' (the casadi
    wheel's in C, the daqp module's in Python) drifting apart over ticks."""
    compiled = Controller(robot, trajectory, horizon=horizon, dt=dt, mode=mode, compiled=True)
    commands = [compiled.step(pose, t) for t, pose in zip(times, poses, strict=True)]
    return command_differences(replay, commands)


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench export-check", description=__doc__.split("\n")[0])
    add_list_option(parser, "--layouts",
                    help="comma list of robot presets, a motor preset as LAYOUT-motors "
                         "(default: every shipped preset, then every motor preset)")
    add_list_option(parser, "--modes", help=f"comma list of {', '.join(MODES)} (default: all)")
    add_list_option(parser, "--speeds",
                    help="inside (0.8 x limits), beyond (1.3 x) or peak ratios like 1.1 "
                         "(default: inside,beyond)")
    parser.add_argument("--ticks", type=int, default=2000,
                        help="closed-loop ticks recorded per preset, mode and speed (2000)")
    parser.add_argument("--horizon", type=int, default=20, help="MPC horizon in ticks (20)")
    parser.add_argument("--dt", type=float, default=0.05, help="control tick [s] (0.05)")
    parser.add_argument("--tolerance", type=float, default=TOLERANCE,
                        help=f"largest command difference accepted ({TOLERANCE:g})")
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    presets = robot_names()
    robots = choose("--layouts", "layout", args.layouts, presets, presets)
    modes = choose("--modes", "mode", args.modes, list(MODES))
    speeds = parse_speeds(args.speeds)
    if args.ticks < 1:
        raise ScenarioError(f"--ticks must be >= 1, got {args.ticks}")
    if not (math.isfinite(args.tolerance) and args.tolerance >= 0):
        raise ScenarioError(f"--tolerance must be finite and >= 0, got {args.tolerance}")
    started = time.perf_counter()
    print(f"exported library against the Python controller: {args.ticks} closed-loop ticks, "
          f"N={args.horizon}, dt {args.dt:g} s, figure8 fixed heading, plant with "
          f"{SLIP:.0%} slip and {SUBSTEPS} Euler substeps; tolerance {args.tolerance:g}",
          flush=True)
    print(f"{'robot':14s} {'mode':5s} {'speed':7s} {'ticks':>6s} {'max diff':>9s} "
          f"{'status':>6s} {'fallbk':>6s} {'builds':>6s} {'build s':>7s} {'vs comp':>9s} "
          f"{'status':>6s}", flush=True)
    failed = checked = 0
    notes: dict[str, None] = {}
    for robot in robots:
        for mode in modes:
            for speed, ratio in speeds.items():
                label = f"{robot:14s} {mode:5s} {speed:7s}"
                try:
                    item = check(robot, mode, ratio, args.ticks, args.horizon, args.dt)
                except ExportBuildError as error:
                    failed += 1
                    print(f"{label} FAILED: {error}", flush=True)
                    continue
                if not item["supported"]:
                    reason, _, supported = item["reason"].partition("; it supports ")
                    if supported:
                        notes[supported] = None
                    print(f"{label} not supported: {reason}", flush=True)
                    continue
                checked += 1
                progress = max(item.get("time_gap", 0.0),
                               item.get("reference_time_difference", 0.0))
                bad = (item["max_difference"] > args.tolerance
                       or item["status_mismatches"] > 0 or not progress <= args.tolerance)
                failed += bad
                print(f"{label} {item['ticks']:6d} {item['max_difference']:9.2g} "
                      f"{item['status_mismatches']:6d} {item['fallbacks']:6d} "
                      f"{item['hessians_built']:6d} {item['build_s']:7.1f} "
                      f"{item['compiled_difference']:9.2g} "
                      f"{item['compiled_status_mismatches']:6d}"
                      + (f"  times {progress:.2g}" if "time_gap" in item else "")
                      + ("  BEYOND TOLERANCE" if bad else ""), flush=True)
    for supported in notes:
        print(f"(the compiled tick supports {supported})")
    print(f"max diff: the largest |twist or wheel-speed difference| [m/s, rad/s] over the "
          f"ticks; status: ticks whose status differs; fallbk: the Python controller's "
          f"fallback ticks; builds: Hessians the library built; vs comp, status: the same "
          f"against the compiled tick in this process (compiled=True, the library's daqp); "
          f"times (path mode): the largest difference [s] of the times the library sampled "
          f"the reference at, or of the reference time it tracked, from the Python "
          f"controller's; {checked} checked, "
          f"{failed} failed, {time.perf_counter() - started:.0f} s")
    return 1 if failed else 0
