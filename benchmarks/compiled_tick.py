"""``mpc-bench perf --sections compiled``: the compiled tick (``Controller(compiled=True)``,
:mod:`mpc.tick`) beside the same with its Hessian rebuilt every tick (no reuse,
:data:`mpc.tick.reuse.REBUILD_DRIFT` below 0), the Python tick (daqp), the compiled tick's
virtual-machine path and the project's IPOPT path, on the scenarios it supports
(constant-Jacobian layouts, time mode), inside and beyond the limits: the same ticks on the same
ideal plant, every controller built once and run ``rounds`` times in turns (the order
rotated each round) so that their ratios are taken under the same load; tick times pooled
over the rounds, errors from the first round. ``--motors``: the layouts' motor presets
(:func:`~mpc.robots.motor_preset`), the Python tick with its motor rows screened as it
ships (:mod:`mpc.solvers.row_screen`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import mpc.tick.reuse as reuse
from benchmarks.scenarios import ScenarioError
from mpc import Controller, ControllerError
from mpc.robots import MOTOR_ROBOT_PRESETS, motor_preset, preset
from mpc.sim import TrackingController
from trajectories import Trajectory

#: The controllers of the section, by row name: their ``Controller`` options.
CONTROLLERS: dict[str, dict[str, Any]] = {
    "python": {"solver": "daqp"},
    "compiled": {"solver": "daqp", "compiled": True},
    "compiled-rebuild": {"solver": "daqp", "compiled": True},
    "virtual-machine": {"solver": "daqp", "compiled": "virtual-machine"},
    "ipopt": {"solver": "ipopt"},
}


def compiled_section(layouts: list[str], speeds: dict[str, float], shape: str, heading: str,
                     horizon: int, dt: float, ticks: int, rounds: int,
                     reference: Callable[..., Trajectory],
                     run: Callable[[TrackingController, int], Any],
                     row: Callable[..., dict[str, Any]], settle: Callable[[int], int],
                     say: Callable[[str], None], motors: bool = False) -> list[dict[str, Any]]:
    """The section's rows (``reference``, ``run``, ``row``, ``settle``: perf's own helpers,
    so that its rows have every other section's keys); ``motors``: on the layouts' motor
    presets."""
    if motors:
        unknown = [layout for layout in layouts if layout not in MOTOR_ROBOT_PRESETS]
        if unknown:
            raise ScenarioError(f"--motors: no motor preset of {', '.join(unknown)}; "
                                f"expected some of {', '.join(MOTOR_ROBOT_PRESETS)}")
    say(f"{rounds} rounds of {ticks} ticks each, the controllers taking turns; N={horizon}, "
        f"{shape} {heading} heading, time mode, ideal plant"
        + ("; motor presets" if motors else ""))
    say(f"{'layout':8s} {'speed':7s} {'controller':16s} {'tick p50':>9s} {'tick p99':>9s} "
        f"{'solve p50':>9s} {'rms err':>9s} {'/compiled':>9s} {'build':>6s}  path")
    say(f"{'':8s} {'':7s} {'':16s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} {'[mm]':>9s} "
        f"{'':>9s} {'[s]':>6s}")
    rows: list[dict[str, Any]] = []
    for layout in layouts:
        robot = motor_preset(layout) if motors else preset(layout)
        for speed, ratio in speeds.items():
            trajectory = reference(shape, heading, robot, ratio)
            built: dict[str, tuple[TrackingController, float]] = {}
            try:
                for name in ("compiled", *(name for name in CONTROLLERS if name != "compiled")):
                    started = time.perf_counter()
                    control = _built(name, robot, trajectory, horizon, dt)
                    built[name] = control, time.perf_counter() - started
            except ControllerError as error:  # a layout the compiled tick does not cover
                say(f"{layout:8s} {speed:7s} skipped: {error}")
                continue
            runs: dict[str, list[Any]] = {name: [] for name in built}
            order = list(built)
            for turn in range(rounds):
                for name in order[turn % len(order):] + order[:turn % len(order)]:
                    runs[name].append(run(built[name][0], ticks))
            section_rows = {name: row(runs[name], settle(ticks), section="compiled",
                                      layout=layout, mode="time", speed=speed,
                                      peak_ratio=ratio, solver=name, horizon=horizon,
                                      motors=motors,
                                      build_time=build, rounds=rounds,
                                      tick_path=getattr(control, "tick_path", None),
                                      hessian_builds=_builds(control))
                            for name, (control, build) in built.items()}
            compiled = section_rows["compiled"]["tick_p50"]
            for name, item in section_rows.items():
                item["python_over_compiled_tick"] = (section_rows["python"]["tick_p50"]
                                                     / compiled)
                item["ipopt_over_compiled_tick"] = (section_rows["ipopt"]["tick_p50"]
                                                    / compiled)
                item["over_compiled_tick"] = item["tick_p50"] / compiled
                rows.append(item)
                say(f"{layout:8s} {speed:7s} {name:16s} {item['tick_p50'] * 1e3:9.3f} "
                    f"{item['tick_p99'] * 1e3:9.3f} {item['solve_p50'] * 1e3:9.3f} "
                    f"{item['rms_position_error'] * 1e3:9.4f} "
                    f"{item['over_compiled_tick']:9.2f} {built[name][1]:6.1f}  "
                    f"{item['tick_path'] or ''}")
            say(f"{layout:8s} {speed:7s} python / compiled "
                f"{section_rows['python']['tick_p50'] / compiled:.2f}, IPOPT path / compiled "
                f"{section_rows['ipopt']['tick_p50'] / compiled:.1f}, rebuild every tick / "
                f"compiled {section_rows['compiled-rebuild']['tick_p50'] / compiled:.2f} "
                f"(tick p50, same ticks); Hessians built: "
                f"{section_rows['compiled']['hessian_builds']} compiled, "
                f"{section_rows['python']['hessian_builds']} python")
    say("/compiled: the row's tick p50 over the compiled tick's; path: what ran the tick "
        "(the compiled tick runs the virtual machine where no compiler works); "
        "compiled-rebuild: the compiled tick with its Hessian rebuilt every tick")
    return rows


def _built(name: str, robot: Any, trajectory: Trajectory, horizon: int,
           dt: float) -> TrackingController:
    """The section's controller ``name`` (``compiled-rebuild``: built with no Hessian
    reuse, :data:`mpc.tick.reuse.REBUILD_DRIFT` below 0)."""
    saved = reuse.REBUILD_DRIFT
    if name == "compiled-rebuild":
        reuse.REBUILD_DRIFT = -1.0
    try:
        return Controller(robot, trajectory, horizon=horizon, dt=dt, **CONTROLLERS[name])
    finally:
        reuse.REBUILD_DRIFT = saved


def _builds(control: Any) -> int | None:
    """Hessians built over every round (the compiled tick's, or the Python tick's
    factorisations), None for a solver with no such count."""
    compiled = getattr(control, "_compiled", None)
    if compiled is not None:
        return int(compiled.rebuilds)
    solver = getattr(control, "solver", None)
    count = getattr(solver, "factorisations", None)
    return None if count is None else int(count)
