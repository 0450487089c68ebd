"""``mpc-bench perf --sections compiled``: the compiled tick (``Controller(compiled=True)``,
:mod:`mpc.tick`) beside the same with its Hessian rebuilt every tick (no reuse,
:data:`mpc.tick.reuse.REBUILD_DRIFT` below 0), the Python tick (daqp), the compiled tick's
virtual-machine path and the project's IPOPT path, on the scenarios it supports
(constant-Jacobian layouts and swerve in time mode; path mode on constant-Jacobian
layouts where ``--modes`` names it), inside and beyond the limits: the same ticks on the
same ideal plant, every controller built once and run ``rounds`` times in turns (the order
rotated each round) so that their ratios are taken under the same load; tick times pooled
over the rounds, errors from the first round. In path mode the compiled tick rebuilds
its Hessian every tick anyway, so it has no ``compiled-rebuild`` row.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import mpc.tick.reuse as reuse
from mpc import Controller, ControllerError
from mpc.robots import preset
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
                     say: Callable[[str], None], modes: tuple[str, ...] = ("time",)
                     ) -> list[dict[str, Any]]:
    """The section's rows (``reference``, ``run``, ``row``, ``settle``: perf's own helpers,
    so that its rows have every other section's keys; ``modes``: ``Controller`` modes)."""
    say(f"{rounds} rounds of {ticks} ticks each, the controllers taking turns; N={horizon}, "
        f"{shape} {heading} heading, {' and '.join(modes)} mode, ideal plant")
    say(f"{'layout':8s} {'speed':7s} {'controller':16s} {'tick p50':>9s} {'tick p99':>9s} "
        f"{'solve p50':>9s} {'rms err':>9s} {'/compiled':>9s} {'build':>6s}  path")
    say(f"{'':8s} {'':7s} {'':16s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} {'[mm]':>9s} "
        f"{'':>9s} {'[s]':>6s}")
    rows: list[dict[str, Any]] = []
    for layout, mode, (speed, ratio) in ((layout, mode, item) for layout in layouts
                                         for mode in modes for item in speeds.items()):
        robot = preset(layout)
        trajectory = reference(shape, heading, robot, ratio)
        label = speed if mode == "time" else f"{speed}:path"  # (the speed column's)
        built: dict[str, tuple[TrackingController, float]] = {}
        names = [name for name in CONTROLLERS
                 if name != "compiled" and not (mode == "path" and name == "compiled-rebuild")]
        try:
            for name in ("compiled", *names):
                started = time.perf_counter()
                control = _built(name, robot, trajectory, horizon, dt, mode)
                built[name] = control, time.perf_counter() - started
        except ControllerError as error:  # a layout the compiled tick does not cover
            say(f"{layout:8s} {label:7s} skipped: {error}")
            continue
        runs: dict[str, list[Any]] = {name: [] for name in built}
        order = list(built)
        for turn in range(rounds):
            for name in order[turn % len(order):] + order[:turn % len(order)]:
                runs[name].append(run(built[name][0], ticks))
        section_rows = {name: row(runs[name], settle(ticks), section="compiled",
                                  layout=layout, mode=mode, speed=speed,
                                  peak_ratio=ratio, solver=name, horizon=horizon,
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
            if mode == "path":  # the distance to the path, the time-optimal yardstick's
                item["max_cross_track_error"] = runs[name][0].result.metrics(
                    skip=min(2.0, 0.5 * ticks * dt))["max_cross_track_error"]
            rows.append(item)
            say(f"{layout:8s} {label:7s} {name:16s} {item['tick_p50'] * 1e3:9.3f} "
                f"{item['tick_p99'] * 1e3:9.3f} {item['solve_p50'] * 1e3:9.3f} "
                f"{item['rms_position_error'] * 1e3:9.4f} "
                f"{item['over_compiled_tick']:9.2f} {built[name][1]:6.1f}  "
                f"{item['tick_path'] or ''}"
                + (f"  path max {item['max_cross_track_error'] * 1e3:.2f} mm"
                   if mode == "path" else ""))
        rebuild = section_rows.get("compiled-rebuild")
        say(f"{layout:8s} {label:7s} python / compiled "
            f"{section_rows['python']['tick_p50'] / compiled:.2f}, IPOPT path / compiled "
            f"{section_rows['ipopt']['tick_p50'] / compiled:.1f}, "
            + (f"rebuild every tick / compiled {rebuild['tick_p50'] / compiled:.2f} "
               if rebuild is not None else "")
            + f"(tick p50, same ticks); compiled p99 / p50 "
            f"{section_rows['compiled']['tick_p99'] / compiled:.2f}; Hessians built: "
            f"{section_rows['compiled']['hessian_builds']} compiled, "
            f"{section_rows['python']['hessian_builds']} python")
    say("/compiled: the row's tick p50 over the compiled tick's; path: what ran the tick "
        "(the compiled tick runs the virtual machine where no compiler works); "
        "compiled-rebuild: the compiled tick with its Hessian rebuilt every tick")
    return rows


def _built(name: str, robot: Any, trajectory: Trajectory, horizon: int,
           dt: float, mode: str = "time") -> TrackingController:
    """The section's controller ``name`` (``compiled-rebuild``: built with no Hessian
    reuse, :data:`mpc.tick.reuse.REBUILD_DRIFT` below 0)."""
    saved = reuse.REBUILD_DRIFT
    if name == "compiled-rebuild":
        reuse.REBUILD_DRIFT = -1.0
    try:
        return Controller(robot, trajectory, horizon=horizon, dt=dt, mode=mode,
                          **CONTROLLERS[name])
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
