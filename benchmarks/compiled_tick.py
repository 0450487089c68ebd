"""``mpc-bench perf``'s ``compiled`` section: on every scenario of the run (layout x mode x
speed), the compiled tick (``Controller(compiled=True)``, :mod:`mpc.tick`) beside the same
with its Hessian rebuilt every tick (no reuse, :data:`mpc.tick.reuse.REBUILD_DRIFT` below
0), the Python tick (daqp), the compiled tick's virtual-machine path, the exported C
library's tick (:mod:`benchmarks.exported`: built with CMake, each ``mpc_tick_step`` timed
in C on the compiled tick's recorded ticks) and the project's IPOPT path: the same ticks on
the same plant (each of ``plants`` in turn: the ideal one, and the realistic one of
:mod:`benchmarks.perf_plants`), every controller built once and run ``rounds`` times in turns (the
order rotated each round) so that their ratios are taken under the same load; tick times
pooled over the rounds, errors from the first round (the exported library's: the recorded
run's, whose commands it repeats).

A scenario the compiled tick does not cover says so, with the reason its
:class:`~mpc.tick.UnsupportedTickError` gives, instead of rows: as the compiled tick covers
more, rows appear with no change here. Each robot's library is compiled once (the first
scenario that needs it; later ones load it from the cache), and so is its exported program.
``motors`` (``mpc-bench perf --motors``): the layouts' motor presets
(:func:`~mpc.robots.motor_preset`) instead, the Python tick with its motor rows screened as
it ships (:mod:`mpc.solvers.row_screen`). Where the compiled tick runs a row screen
(:mod:`mpc.tick.screen`: a motor model's rows, swerve's guard faces), one more row,
``compiled-unscreened``: the same library with every row in daqp's problem.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

import mpc.tick.reuse as reuse
import mpc.tick.screen as screen
from benchmarks.exported import ExportBuildError, ExportedTick, differences, tick_inputs
from benchmarks.scenarios import ScenarioError
from mpc import Controller, ControllerError
from mpc.robots import MOTOR_ROBOT_PRESETS, motor_preset, preset
from mpc.sim import TrackingController
from mpc.tick import UnsupportedTickError
from trajectories import Trajectory

#: The controllers of the section, by row name: their ``Controller`` options.
CONTROLLERS: dict[str, dict[str, Any]] = {
    "python": {"solver": "daqp"},
    "compiled": {"solver": "daqp", "compiled": True},
    "compiled-rebuild": {"solver": "daqp", "compiled": True},
    "compiled-unscreened": {"solver": "daqp", "compiled": True},
    "virtual-machine": {"solver": "daqp", "compiled": "virtual-machine"},
    "ipopt": {"solver": "ipopt"},
}
#: The row of the compiled tick with its row screen off (every row in daqp's problem,
#: :data:`mpc.tick.screen.SCREEN_AFTER` 0): only where the compiled tick has a screen.
UNSCREENED = "compiled-unscreened"
#: The row of the exported C library's tick (timed in C, on the compiled tick's ticks).
EXPORTED = "exported"
#: The path column of the exported library's row.
EXPORTED_PATH = "C (export_c, cmake)"

#: Issue 37's lines for every scenario (ratios within the run): the IPOPT path's tick p50
#: over the compiled tick's at least, the compiled tick's p99 over its p50 at most, and its
#: p99 at most [s].
TARGET_IPOPT_OVER_COMPILED = 50.0
TARGET_P99_OVER_P50 = 3.0
TARGET_P99 = 1e-3

#: A scenario the compiled tick refuses: its reason is the row.
_NOTE = "; it supports "


def compiled_section(layouts: list[str], modes: list[str], speeds: dict[str, float],
                     shape: str, heading: str, horizon: int, dt: float, ticks: int,
                     rounds: int, reference: Callable[..., Trajectory],
                     run: Callable[..., Any],
                     row: Callable[..., dict[str, Any]], settle: Callable[[int], int],
                     say: Callable[[str], None], motors: bool = False,
                     plants: tuple[str, ...] | list[str] = ("ideal",)) -> dict[str, Any]:
    """The section: ``rows`` (each with perf's row keys), ``unsupported`` (the scenarios
    the compiled tick refuses, with the reason) and ``builds`` (per robot: seconds to build
    or load its compiled and exported libraries). ``reference``, ``run``, ``row``,
    ``settle``: perf's own helpers, so that its rows have every other section's keys;
    ``motors``: on the layouts' motor presets (a layout with none: ScenarioError);
    ``plants``: each scenario's closed loops on each of these plants in turn
    (:data:`benchmarks.perf_plants.PLANTS`, ``run``'s ``plant``), the same controllers on
    each, the rows saying which (``plant``)."""
    if motors:
        unknown = [layout for layout in layouts if layout not in MOTOR_ROBOT_PRESETS]
        if unknown:
            raise ScenarioError(f"--motors: no motor preset of {', '.join(unknown)}; "
                                f"expected some of {', '.join(MOTOR_ROBOT_PRESETS)}")
    say(f"{rounds} rounds of {ticks} ticks each, the controllers taking turns; N={horizon}, "
        f"{shape} {heading} heading, {' and '.join(plants)} plant"
        + ("s" if len(plants) > 1 else "") + ("; motor presets" if motors else ""))
    say(f"{'layout':8s} {'mode':5s} {'speed':7s} {'plant':9s} {'controller':16s} "
        f"{'tick p50':>9s} {'tick p99':>9s} {'solve p50':>9s} {'rms err':>9s} "
        f"{'/compiled':>9s} {'build':>6s}  path")
    say(f"{'':8s} {'':5s} {'':7s} {'':9s} {'':16s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} "
        f"{'[mm]':>9s} {'':>9s} {'[s]':>6s}")
    rows: list[dict[str, Any]] = []
    unsupported: list[dict[str, Any]] = []
    builds: dict[str, dict[str, Any]] = {}
    notes: dict[str, None] = {}
    announced: set[str] = set()
    for layout in layouts:
        robot = motor_preset(layout) if motors else preset(layout)
        for mode in modes:
            exported: ExportedTick | str | None = None  # built at the mode's first scenario
            for speed, ratio in speeds.items():
                trajectory = reference(shape, heading, robot, ratio)
                label = f"{layout:8s} {mode:5s} {speed:7s}"
                first = layout not in builds
                if layout not in announced:
                    announced.add(layout)
                    say(f"{label} building the compiled tick (N={horizon}; compiled once, "
                        f"then loaded from the cache) ...")
                started = time.perf_counter()
                try:
                    compiled = _built("compiled", robot, trajectory, horizon, dt, mode)
                except UnsupportedTickError as error:
                    reason, _, supported = str(error).partition(_NOTE)
                    if supported:
                        notes[_NOTE.removeprefix("; ") + supported] = None
                    unsupported.append({"layout": layout, "mode": mode, "speed": speed,
                                        "reason": str(error)})
                    say(f"{label} not supported: {reason}")
                    continue
                built: dict[str, tuple[TrackingController, float]] = {
                    "compiled": (compiled, time.perf_counter() - started)}
                if first:
                    builds[layout] = {"compiled_s": built["compiled"][1],
                                      "tick_path": compiled.tick_path}
                    say(f"{label} {compiled.tick_path} tick ready in "
                        f"{built['compiled'][1]:.1f} s")
                try:
                    for name in CONTROLLERS:
                        if name == UNSCREENED and not _screened(compiled):
                            continue  # (no screen: the compiled row is this row)
                        if name not in built:
                            started = time.perf_counter()
                            control = _built(name, robot, trajectory, horizon, dt, mode)
                            built[name] = control, time.perf_counter() - started
                except ControllerError as error:  # a controller the scenario cannot have
                    say(f"{label} skipped: {error}")
                    continue
                if exported is None:
                    exported = _exported(compiled, label, say)
                    builds[layout][f"exported_{mode}"] = (
                        exported if isinstance(exported, str)
                        else {"build_s": exported.build_time, "cached": exported.cached})
                for plant in plants:
                    rows += _scenario(built, exported, layout, mode, speed, ratio, horizon,
                                      ticks, rounds, run, row, settle, say, motors, plant)
    say("/compiled: the row's tick p50 over the compiled tick's; path: what ran the tick "
        "(the compiled tick runs the virtual machine where no compiler works); "
        "compiled-rebuild: the compiled tick with its Hessian rebuilt every tick; "
        "compiled-unscreened: with its row screen off (where it has one); exported: "
        "the library mpc.export_c writes, built with CMake, each mpc_tick_step timed in C "
        "on the compiled tick's recorded ticks (its errors are that run's)")
    for note in notes:
        say(f"(not supported: the compiled tick's error adds \"{note}\")")
    return {"rows": rows, "unsupported": unsupported, "builds": builds}


def _scenario(built: dict[str, tuple[TrackingController, float]],
              exported: ExportedTick | str, layout: str, mode: str, speed: str, ratio: float,
              horizon: int, ticks: int, rounds: int, run: Callable[..., Any],
              row: Callable[..., dict[str, Any]], settle: Callable[[int], int],
              say: Callable[[str], None], motors: bool = False,
              plant: str = "ideal") -> list[dict[str, Any]]:
    """One scenario's rows on ``plant``: every controller in turns, the exported library
    among them (``motors``: the robot is the layout's motor preset)."""
    label = f"{layout:8s} {mode:5s} {speed:7s} {plant:9s}"
    names: list[str] = list(built)
    recorded = inputs = None
    if not isinstance(exported, str):  # its ticks: the compiled tick's closed loop, untimed
        recorded = run(built["compiled"][0], ticks, plant=plant)
        inputs = tick_inputs(built["compiled"][0], recorded.result.time,
                             recorded.result.measured)
        names.append(EXPORTED)
    runs: dict[str, list[Any]] = {name: [] for name in names}
    for turn in range(rounds):
        for name in names[turn % len(names):] + names[:turn % len(names)]:
            if name == EXPORTED:
                assert isinstance(exported, ExportedTick) and inputs is not None
                runs[name].append(exported.replay(inputs))
            else:
                runs[name].append(run(built[name][0], ticks, plant=plant))
    common = {"section": "compiled", "layout": layout, "mode": mode, "speed": speed,
              "peak_ratio": ratio, "horizon": horizon, "rounds": rounds, "motors": motors,
              "plant": plant}
    items: dict[str, dict[str, Any]] = {}
    for name, (control, build) in built.items():
        items[name] = row(runs[name], settle(ticks), **common, solver=name, build_time=build,
                          tick_path=getattr(control, "tick_path", None),
                          hessian_builds=_builds(control))
    if isinstance(exported, ExportedTick) and recorded is not None:
        items[EXPORTED] = _exported_row(runs[EXPORTED], recorded, exported, row,
                                        settle(ticks), common)
    compiled = items["compiled"]["tick_p50"]
    for name, item in items.items():
        item["over_compiled_tick"] = item["tick_p50"] / compiled
        item["python_over_compiled_tick"] = items["python"]["tick_p50"] / compiled
        item["ipopt_over_compiled_tick"] = items["ipopt"]["tick_p50"] / compiled
        build = item.get("build_time", 0.0)
        if mode == "path" and name in built:  # the distance to the path: path mode's error
            item["max_cross_track_error"] = runs[name][0].result.metrics(
                skip=min(2.0, 0.5 * ticks * built[name][0].dt))["max_cross_track_error"]
        say(f"{label} {name:16s} {item['tick_p50'] * 1e3:9.3f} {item['tick_p99'] * 1e3:9.3f} "
            f"{item['solve_p50'] * 1e3:9.3f} {item['rms_position_error'] * 1e3:9.4f} "
            f"{item['over_compiled_tick']:9.2f} {build:6.1f}  {item['tick_path'] or ''}"
            + (f"  path max {item['max_cross_track_error'] * 1e3:.2f} mm"
               if "max_cross_track_error" in item else ""))
    own = items["compiled"]
    line = (f"{label} python / compiled {items['python']['tick_p50'] / compiled:.2f}, "
            f"virtual machine / compiled {items['virtual-machine']['tick_p50'] / compiled:.2f}")
    if EXPORTED in items:
        line += f", exported / compiled {items[EXPORTED]['tick_p50'] / compiled:.2f}"
    elif isinstance(exported, str):
        line += f", exported: not built ({exported})"
    say(line + f", IPOPT path / compiled {items['ipopt']['tick_p50'] / compiled:.1f}, rebuild "
        f"every tick / compiled {items['compiled-rebuild']['tick_p50'] / compiled:.2f} (tick "
        f"p50, same ticks); compiled p99 {own['tick_p99'] * 1e3:.3f} ms = "
        f"{own['tick_p99'] / compiled:.2f} x its p50 (process CPU: p99 "
        f"{own['cpu_p99'] * 1e3:.3f} ms = {own['cpu_p99'] / own['cpu_p50']:.2f} x its p50); "
        f"Hessians built: "
        f"{own['hessian_builds']} compiled, {items['python']['hessian_builds']} python"
        + (f"; row screen: every row / compiled {items[UNSCREENED]['tick_p50'] / compiled:.2f}"
           f" (CPU p99 {items[UNSCREENED]['cpu_p99'] * 1e3:.3f} ms)"
           if UNSCREENED in items else ""))
    if EXPORTED in items:
        export = items[EXPORTED]
        say(f"{label} exported library against the compiled tick on its ticks: largest "
            f"command difference {export['export_max_difference']:.2g}, status mismatches "
            f"{export['export_status_mismatches']}")
    return list(items.values())


def _exported(compiled: TrackingController, label: str,
              say: Callable[[str], None]) -> ExportedTick | str:
    """The compiled controller's exported library built (or loaded), or why not."""
    if getattr(compiled, "mode", "time") == "path":  # (its replay needs the samples taken)
        return "path mode's replay is mpc-bench export-check's"
    say(f"{label} building the exported library (export_c, cmake; once per robot, cached) "
        f"...")
    try:
        exported = ExportedTick(compiled)
    except (ExportBuildError, ControllerError) as error:
        say(f"{label} exported library not built: {error}")
        return str(error)
    say(f"{label} exported library ready in {exported.build_time:.1f} s"
        + (" (from the cache)" if exported.cached else ""))
    return exported


def _exported_row(replays: list[Any], recorded: Any, exported: ExportedTick,
                  row: Callable[..., dict[str, Any]], settle: int,
                  common: dict[str, Any]) -> dict[str, Any]:
    """The exported library's row: its times (C, every round) with the recorded run's
    tracking (the library repeats its commands: the differences are in the row)."""
    item = row(recorded, settle, **common, solver=EXPORTED, build_time=exported.build_time,
               tick_path=EXPORTED_PATH, hessian_builds=int(sum(int(each.rebuilt.sum())
                                                               for each in replays)))
    wall = np.concatenate([each.wall[0, settle:] for each in replays])
    cpu = np.concatenate([each.cpu[0, settle:] for each in replays])
    solve = np.concatenate([each.solve_time[settle:] for each in replays])
    iterations = np.concatenate([each.iterations[settle:] for each in replays])
    item.update({"ticks": int(wall.size), "tick_p50": float(np.median(wall)),
                 "tick_p99": float(np.percentile(wall, 99)),
                 "tick_max": float(max(each.wall.max() for each in replays)),
                 "cpu_p50": float(np.median(cpu)), "cpu_p99": float(np.percentile(cpu, 99)),
                 "solve_p50": float(np.median(solve)),
                 "overhead_p50": float(np.median(wall - solve)),
                 "iterations_p50": float(np.median(iterations))})
    result = recorded.result
    item["export_max_difference"], item["export_status_mismatches"] = differences(
        replays[0], result.twist_command, result.wheel_command, result.status)
    return item


def _built(name: str, robot: Any, trajectory: Trajectory, horizon: int, dt: float,
           mode: str) -> Controller:
    """The section's controller ``name`` (``compiled-rebuild``: built with no Hessian
    reuse, :data:`mpc.tick.reuse.REBUILD_DRIFT` below 0; ``compiled-unscreened``: with no
    row screen, :data:`mpc.tick.screen.SCREEN_AFTER` 0)."""
    saved, after = reuse.REBUILD_DRIFT, screen.SCREEN_AFTER
    if name == "compiled-rebuild":
        reuse.REBUILD_DRIFT = -1.0
    if name == UNSCREENED:
        screen.SCREEN_AFTER = 0
    try:
        return Controller(robot, trajectory, horizon=horizon, dt=dt, mode=mode,
                          **CONTROLLERS[name])
    finally:
        reuse.REBUILD_DRIFT, screen.SCREEN_AFTER = saved, after


def _screened(control: Any) -> bool:
    """Whether the compiled controller runs a row screen (:mod:`mpc.tick.screen`)."""
    compiled = getattr(control, "_compiled", None)
    return compiled is not None and compiled.screen_after > 0 and compiled.path == "compiled"


def _builds(control: Any) -> int | None:
    """Hessians built over every round (the compiled tick's, or the Python tick's
    factorisations), None for a solver with no such count."""
    compiled = getattr(control, "_compiled", None)
    if compiled is not None:
        return int(compiled.rebuilds)
    solver = getattr(control, "solver", None)
    count = getattr(solver, "factorisations", None)
    return None if count is None else int(count)


def issue_targets(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Issue 37's per-scenario lines over the section's rows: the worst scenario of each
    (IPOPT path / compiled tick p50, compiled p99 / p50, compiled p99 [s]; the last two
    in process CPU time too), named."""
    compiled = [item for item in rows if item["solver"] == "compiled"]
    if not compiled:
        return {}

    def name(item: dict[str, Any]) -> str:
        return f"{item['layout']} {item['mode']} {item['speed']}"

    slowest = min(compiled, key=lambda item: item["ipopt_over_compiled_tick"])
    spread = max(compiled, key=lambda item: item["tick_p99"] / item["tick_p50"])
    worst = max(compiled, key=lambda item: item["tick_p99"])
    # process CPU beside wall clock: on a shared machine the wall p99 is mostly the time
    # the scheduler gave other processes
    cpu_spread = max(compiled, key=lambda item: item["cpu_p99"] / item["cpu_p50"])
    cpu_worst = max(compiled, key=lambda item: item["cpu_p99"])
    found = {
        "ipopt_over_compiled_tick_min": (slowest["ipopt_over_compiled_tick"],
                                         TARGET_IPOPT_OVER_COMPILED, False, name(slowest)),
        "compiled_p99_over_p50_max": (spread["tick_p99"] / spread["tick_p50"],
                                      TARGET_P99_OVER_P50, True, name(spread)),
        "compiled_tick_p99_max": (worst["tick_p99"], TARGET_P99, True, name(worst)),
        "compiled_cpu_p99_over_p50_max": (cpu_spread["cpu_p99"] / cpu_spread["cpu_p50"],
                                          TARGET_P99_OVER_P50, True, name(cpu_spread)),
        "compiled_cpu_p99_max": (cpu_worst["cpu_p99"], TARGET_P99, True, name(cpu_worst)),
    }
    return {key: {"measured": float(value), "limit": limit,
                  "at_most" if at_most else "at_least": True, "scenario": scenario,
                  "met": bool(value <= limit if at_most else value >= limit)}
            for key, (value, limit, at_most, scenario) in found.items()}
