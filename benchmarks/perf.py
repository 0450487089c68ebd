"""``mpc-bench perf``: where a tick's time goes, how it scales, and against a peer, in one run.

Every comparison is a ratio between runs of this one invocation, because the machines
are shared and noisy; absolute times are what this machine did while it ran. Sections
(``--sections`` picks some):

1. ``profile``: one tick of the fast path (daqp) split into its phases by
   :class:`mpc.profiling.TickProfile` (median and p99 per phase) on the reference
   scenario: Mecanum, figure-eight at 0.8 x the wheel limits, fixed heading, N = 20,
   dt = 0.05 s, ideal plant. Written to ``tick_profile.txt`` and ``tick_profile.json``.
2. ``horizons``: the reference scenario at every ``--horizons`` for every ``--solvers``
   (IPOPT over fewer ticks): tick p50/p99, the solver's own time, the rest of ``step()``
   (overhead), iterations, RMS position error, and how the tick grows with N.
3. ``scenarios``: every ``--layouts`` x ``--modes`` (time, path) x ``--speeds`` (inside
   0.8 x, beyond 1.3 x the limits) at N = 20 with daqp: tick p50/p99/max, flagging a
   p99 above 1 ms.
4. ``peers``: do-mpc (the ``peers`` extra) on the same problem (:mod:`benchmarks.peers`),
   next to the project's daqp and IPOPT paths on the same plant and ticks, inside and
   beyond the limits: tick p50 ratios and tracking errors (agreeing errors show the two
   NLPs are the same problem). Each controller runs ``--peer-rounds`` times, the
   controllers taking turns, and its tick p50 is over all those ticks: a burst of load
   lands on every controller alike instead of on one run. The controllers' objects are
   frozen out of the garbage collector's scans meanwhile (``gc.freeze``): all of them are
   alive at once, as they would not be in a robot's program. Skipped with one line when
   do-mpc is not installed.
5. ``compiled``: on every scenario of section 3 (``--layouts`` x ``--modes`` x
   ``--speeds``, figure-eight, fixed heading, N = 20), the compiled tick
   (``Controller(compiled=True)``) beside itself rebuilding its Hessian every tick, the
   Python tick, its virtual-machine path, the exported C library's tick (``mpc.export_c``,
   built with CMake, timed in C) and the IPOPT path, as ratios within the run; a scenario
   the compiled tick does not cover yet says why (:mod:`benchmarks.compiled_tick`). With
   it, the peers section has the compiled tick too (``mpc-compiled``: do-mpc and the
   IPOPT path over it, issue 37's lines). Each robot's library is compiled once (tens of
   seconds at N = 20; cached after), so ``--quick`` leaves the section out unless named.

The peers and compiled sections close their loops on each of ``--plants``
(:mod:`benchmarks.perf_plants`): the ideal plant and the ``realistic`` one (motor lag, a
tick of delay, noise, slip, ten substeps, a start 0.28 m off), both by default (``--quick``:
ideal), and issue 37's lines are stated per plant. ``--runs R`` runs those two sections R
times over and states each line in each run and whether it held in every run.

Times [s] in ``perf.json``, printed in ms or us. ``tick`` is the whole ``step()``
(``Command.tick_time``); ``solve`` the solver's own time (daqp and OSQP: their reported
solve time; IPOPT: its wall time); ``overhead`` their difference (Python, NumPy, CasADi).
Timing statistics leave out each run's first ticks (cold start, ``settle`` in the JSON);
``tick max`` covers every tick. Tracking errors leave out the first 2 s (half the run
if shorter).
"""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from benchmarks import peers
from benchmarks.compiled_tick import compiled_section, issue_targets
from benchmarks.options import add_list_option
from benchmarks.outdir import add_force_argument, claim
from benchmarks.perf_plants import PLANTS, describe, simulate_options
from benchmarks.runner import machine
from benchmarks.scenarios import (
    HEADINGS,
    LAYOUTS,
    PRESETS,
    SPEEDS,
    TRAJECTORIES,
    Parser,
    ScenarioError,
    choose,
    parse_speeds,
    reference,
)
from mpc import SOLVERS, Command, Controller, ControllerError
from mpc.arrays import FloatArray
from mpc.control.controller import MODES
from mpc.profiling import TickProfile
from mpc.robots import preset
from mpc.sim import SimResult, TrackingController, simulate
from trajectories import Trajectory

#: The reference scenario: Mecanum, figure-eight inside the limits, fixed heading, N = 20.
REFERENCE_LAYOUT, REFERENCE_SHAPE, REFERENCE_HEADING = "mecanum", "figure8", "fixed"
REFERENCE_HORIZON = 20
DT = 0.05  # control tick [s]
#: The fast path every ratio is taken against.
FAST = "daqp"
#: The fast path with its CasADi terms compiled to C (``Controller(jit=True)``), at N = 20,
#: run alternately with the default this many times.
JIT = "daqp_jit"
JIT_PEER = "mpc-daqp-jit"  # the peers section's row of the fast path with jit=True
JIT_REPEATS = 3
#: The peers section's row of the compiled tick (``Controller(compiled=True)``), with the
#: ``compiled`` section.
COMPILED_PEER = "mpc-compiled"
#: Rounds of the peers section: each controller runs its ticks this many times, in turns.
PEER_ROUNDS = 3
#: A scenario's tick p99 above this is flagged [s].
P99_LIMIT = 1e-3
SECTIONS: tuple[str, ...] = ("profile", "horizons", "scenarios", "peers", "compiled")
#: ``--quick``'s sections unless named: the compiled tick compiles a library per robot the
#: first time (tens of seconds at N = 20; cached after), not a smoke run's seconds.
QUICK_SECTIONS: tuple[str, ...] = ("profile", "horizons", "scenarios", "peers")
#: Environment variables that set how many threads NumPy's BLAS uses (kept in perf.json).
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: Errors leave out up to this much of a run's start [s].
ERROR_SKIP = 2.0

#: Issue 12's targets for the fast path, checked against this run (absolute times are
#: this machine's).
TARGET_TICK_P50 = 100e-6  # [s], reference scenario
TARGET_TICK_P99 = 300e-6  # [s], reference scenario
TARGET_OVER_DO_MPC = 100.0  # do-mpc tick / daqp tick at least
TARGET_OVER_IPOPT = 50.0  # IPOPT-path tick / daqp tick at least
TARGET_RMS_VS_IPOPT = 0.10  # daqp RMS error within 10% of IPOPT's, inside the limits
#: Issue 11's speed targets for swerve, time mode 1.3x beyond the limits, same run.
TARGET_SWERVE_P99 = 2e-3  # [s] swerve's tick p99
TARGET_SWERVE_OVER_MECANUM = 2.0  # swerve's tick p50 / Mecanum's at most
#: Issue 37's lines for the compiled tick on the reference scenario (Mecanum figure-eight,
#: N = 20, inside the limits), from the peers section's same ticks.
TARGET_DO_MPC_OVER_COMPILED = 250.0  # do-mpc tick p50 / compiled tick p50 at least
TARGET_IPOPT_OVER_COMPILED = 120.0  # IPOPT-path tick p50 / compiled tick p50 at least
TARGET_COMPILED_RMS_VS_IPOPT = 0.05  # compiled RMS error within 5% of IPOPT's


def _settle(ticks: int) -> int:
    """Ticks left out of the timing statistics: the cold start."""
    return min(10, ticks // 5)


class Run(NamedTuple):
    """One closed-loop run: the simulation's record and each tick's process CPU time [s]."""

    result: SimResult
    cpu: FloatArray


class _CpuTimed:
    """Wraps a controller and keeps the process CPU time of every ``step()`` [s]: the
    computation alone, without the time the scheduler gave other processes (on a shared
    machine the wall-clock p99 is mostly that)."""

    def __init__(self, control: TrackingController) -> None:
        self.control = control
        self.robot, self.dt = control.robot, control.dt
        self.cpu: list[float] = []

    @property
    def trajectory(self) -> Trajectory:
        return self.control.trajectory

    def reset(self) -> None:
        self.control.reset()
        self.cpu.clear()

    def step(self, pose: ArrayLike, t: float, *args: Any, **kwargs: Any) -> Command:
        """The controller's step (measured steer angles and the like passed on)."""
        started = time.process_time()
        command = self.control.step(pose, t, *args, **kwargs)
        self.cpu.append(time.process_time() - started)
        return command


def _run(control: TrackingController, ticks: int,
         on_tick: Callable[[int, int], None] | None = None, plant: str = "ideal") -> Run:
    """``control``'s closed loop over ``ticks`` on ``plant`` (:data:`benchmarks.perf_plants.
    PLANTS`), each step's process CPU time kept."""
    timed = _CpuTimed(control)
    result = simulate(timed, ticks * control.dt, on_tick=on_tick,
                      **simulate_options(plant, control.trajectory))
    return Run(result, np.asarray(timed.cpu))


def _row(run: Run | list[Run], settle: int, **labels: Any) -> dict[str, Any]:
    """One run's timing and tracking numbers (times [s], errors [m]); for a list of runs of
    the same ticks, the timing of all of them pooled (each without its first ``settle``
    ticks) and the tracking of the first."""
    runs = run if isinstance(run, list) else [run]
    result = runs[0].result

    def pooled(values: Callable[[Run], FloatArray]) -> FloatArray:
        return np.concatenate([values(each)[settle:] for each in runs])

    tick = pooled(lambda each: each.result.tick_time)
    solve = pooled(lambda each: each.result.solve_time)
    cpu = pooled(lambda each: each.cpu)
    duration = len(result.tick_time) * result.dt
    metrics = result.metrics(skip=min(ERROR_SKIP, 0.5 * duration))
    return {
        **labels,
        "ticks": len(tick), "settle": settle,
        "tick_p50": float(np.median(tick)), "tick_p99": float(np.percentile(tick, 99)),
        "tick_max": float(max(each.result.tick_time.max() for each in runs)),
        "cpu_p50": float(np.median(cpu)), "cpu_p99": float(np.percentile(cpu, 99)),
        "solve_p50": float(np.median(solve)),
        "overhead_p50": float(np.median(tick - solve)),
        "iterations_p50": float(np.median(pooled(lambda each: each.result.iterations))),
        "rms_position_error": metrics["rms_position_error"],
        "max_position_error": metrics["max_position_error"],
        "limit_violations": metrics["limit_violations"],
        "accel_violations": metrics["accel_violations"],
        "failures": metrics["failures"],
    }


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:9.3f}"


class Printer:
    """Prints lines as they come (flushed: progress) and keeps them for ``perf.txt``."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def __call__(self, line: str = "") -> None:
        line = line.rstrip()
        print(line, flush=True)
        self.lines.append(line)


# ----------------------------------------------------------------------------- 1. profile
def profile_run(horizon: int, ticks: int, layout: str = REFERENCE_LAYOUT, mode: str = "time",
                speed: str = "inside") -> tuple[dict[str, Any], list[str]]:
    """A scenario's tick at ``horizon`` split into its phases (daqp; the reference scenario
    unless ``layout``, ``mode`` and ``speed`` say otherwise): the document and its text
    table."""
    robot = preset(layout)
    trajectory = reference(REFERENCE_SHAPE, REFERENCE_HEADING, robot, SPEEDS[speed])
    control = Controller(robot, trajectory, horizon=horizon, dt=DT, solver=FAST, mode=mode)
    profile = TickProfile()
    control.profile = profile
    settle = _settle(ticks)
    order: list[str] = []

    def forget_cold_start(k: int, _ticks: int) -> None:
        if k == settle - 1:
            order.extend(profile.samples)
            profile.samples.clear()
            profile.ticks.clear()

    run = _run(control, ticks, forget_cold_start)
    kept = ticks - settle
    rows: list[dict[str, Any]] = []
    for phase in dict.fromkeys([*order, *profile.samples]):
        values = np.asarray(profile.samples.get(phase, []))
        if values.size:
            rows.append({"phase": phase, "runs": int(values.size),
                         "p50": float(np.median(values)),
                         "p99": float(np.percentile(values, 99)),
                         "mean_per_tick": float(values.sum() / kept)})
    timing = _row(run, settle)
    document = {
        "scenario": {"layout": layout, "trajectory": REFERENCE_SHAPE,
                     "heading": REFERENCE_HEADING, "mode": mode, "speed": speed,
                     "peak_ratio": SPEEDS[speed], "horizon": horizon, "dt": DT,
                     "solver": FAST, "plant": "ideal"},
        "ticks": kept, "settle": settle, "phases": rows,
        "sum_of_medians": float(sum(row["p50"] for row in rows)),
        "sum_of_means": float(sum(row["mean_per_tick"] for row in rows)),
        **{key: timing[key] for key in ("tick_p50", "tick_p99", "cpu_p50", "cpu_p99")},
    }
    lines = [
        f"tick split: {layout} {REFERENCE_SHAPE} {REFERENCE_HEADING} heading, {mode} mode, "
        f"{speed} ({SPEEDS[speed]:g} x limits), N={horizon}, dt {DT} s, {FAST}, ideal "
        f"plant; {kept} ticks after {settle} settling",
        f"{'phase':24s} {'runs':>5s} {'p50 [us]':>9s} {'p99 [us]':>9s} {'mean/tick [us]':>15s}",
    ]
    for row in rows:
        lines.append(f"{row['phase']:24s} {row['runs']:5d} {row['p50'] * 1e6:9.1f} "
                     f"{row['p99'] * 1e6:9.1f} {row['mean_per_tick'] * 1e6:15.1f}")
    lines += [
        f"{'sum':24s} {'':5s} {document['sum_of_medians'] * 1e6:9.1f} {'':9s} "
        f"{document['sum_of_means'] * 1e6:15.1f}",
        f"whole step(), same ticks: p50 {timing['tick_p50'] * 1e6:.1f} us, p99 "
        f"{timing['tick_p99'] * 1e6:.1f} us (wall, Command.tick_time); p50 "
        f"{timing['cpu_p50'] * 1e6:.1f} us, p99 {timing['cpu_p99'] * 1e6:.1f} us (process CPU)",
    ]
    return document, lines


PROFILE_NOTE = ("runs: ticks in which the phase ran; a phase that runs on some ticks only "
                "(a Hessian rebuild) has its p50/p99 over those, and mean/tick spreads it over "
                "every tick. Phase times are wall clock: a p99 holds the ticks on which the "
                "scheduler ran another process.")


def profile_section(horizons: list[int], ticks: int, out: Path, command: str,
                    say: Printer, scenario: tuple[str, str, str] = (REFERENCE_LAYOUT, "time",
                                                                    "inside")
                    ) -> list[dict[str, Any]]:
    """:func:`profile_run` at each horizon (``scenario``: layout, mode, speed); writes
    ``tick_profile.txt`` and ``.json``."""
    documents, text = [], [f"$ {command}", ""]
    for horizon in horizons:
        document, lines = profile_run(horizon, ticks, *scenario)
        documents.append(document)
        for line in lines:
            say(line)
        text += [*lines, ""]
    say(PROFILE_NOTE)
    text.append(PROFILE_NOTE)
    (out / "tick_profile.txt").write_text("\n".join(text) + "\n")
    (out / "tick_profile.json").write_text(
        json.dumps({"command": command, "machine": machine(), "profiles": documents},
                   indent=1) + "\n")
    say(f"wrote {out / 'tick_profile.txt'} and {out / 'tick_profile.json'}")
    return documents


# ---------------------------------------------------------------------------- 2. horizons
def horizons_section(solvers: list[str], horizons: list[int], ticks: int, ipopt_ticks: int,
                     say: Printer) -> list[dict[str, Any]]:
    """The reference scenario for every solver and horizon."""
    robot = preset(REFERENCE_LAYOUT)
    trajectory = reference(REFERENCE_SHAPE, REFERENCE_HEADING, robot, SPEEDS["inside"])
    say(f"{'solver':6s} {'N':>4s} {'tick p50':>9s} {'tick p99':>9s} {'cpu p99':>9s} "
        f"{'solve p50':>9s} {'overhead':>9s} {'iters':>6s} {'rms err':>9s} {'wall':>6s}")
    say(f"{'':6s} {'':>4s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} "
        f"{'':>6s} {'[mm]':>9s} {'[s]':>6s}")
    rows = []
    for solver in solvers:
        count = ipopt_ticks if solver == "ipopt" else ticks
        for horizon in horizons:
            started = time.perf_counter()
            control = Controller(robot, trajectory, horizon=horizon, dt=DT, solver=solver)
            row = _row(_run(control, count), _settle(count), section="horizons",
                       layout=REFERENCE_LAYOUT, mode="time", speed="inside", solver=solver,
                       horizon=horizon)
            rows.append(row)
            say(f"{solver:6s} {horizon:4d} {_ms(row['tick_p50'])} {_ms(row['tick_p99'])} "
                f"{_ms(row['cpu_p99'])} {_ms(row['solve_p50'])} {_ms(row['overhead_p50'])} "
                f"{row['iterations_p50']:6.0f} {row['rms_position_error'] * 1e3:9.4f} "
                f"{time.perf_counter() - started:6.1f}")
    say(f"rms err: each run's own ticks after {ERROR_SKIP:g} s (IPOPT runs are shorter; "
        f"section 4 compares errors over the same ticks)")
    return rows


def jit_comparison(ticks: int, repeats: int, say: Printer) -> dict[str, Any] | None:
    """The reference scenario at N = 20: the fast path with ``jit=True`` (its CasADi terms
    compiled to C) against the default, both built once and run alternately ``repeats``
    times, so that their ratio is taken under the same load; None (and said so) when it
    cannot compile."""
    robot = preset(REFERENCE_LAYOUT)
    trajectory = reference(REFERENCE_SHAPE, REFERENCE_HEADING, robot, SPEEDS["inside"])
    started = time.perf_counter()
    try:
        compiled = Controller(robot, trajectory, horizon=REFERENCE_HORIZON, dt=DT,
                              solver=FAST, jit=True)
    except ControllerError as error:
        say(f"skipped: {error}")
        return None
    build = time.perf_counter() - started
    default = Controller(robot, trajectory, horizon=REFERENCE_HORIZON, dt=DT, solver=FAST)
    ticks_of: dict[str, list[FloatArray]] = {"default": [], "jit": []}
    commands_equal = True
    for _ in range(repeats):
        results = {label: simulate(control, ticks * DT)
                   for label, control in (("default", default), ("jit", compiled))}
        for label, result in results.items():
            ticks_of[label].append(result.tick_time[_settle(ticks):])
        commands_equal &= bool(np.array_equal(results["jit"].twist_command,
                                              results["default"].twist_command))
    document: dict[str, Any] = {"build_s": build, "repeats": repeats, "ticks": ticks,
                                "same_commands": commands_equal}
    for label, parts in ticks_of.items():
        pooled = np.concatenate(parts)
        document[f"{label}_p50"] = float(np.median(pooled))
        document[f"{label}_p99"] = float(np.percentile(pooled, 99))
    document["jit_over_default_p50"] = document["jit_p50"] / document["default_p50"]
    say(f"{FAST} N={REFERENCE_HORIZON}, {repeats} alternating runs each: default p50 "
        f"{document['default_p50'] * 1e6:.1f} us, p99 {document['default_p99'] * 1e6:.1f} us; "
        f"jit=True p50 {document['jit_p50'] * 1e6:.1f} us, p99 "
        f"{document['jit_p99'] * 1e6:.1f} us ({document['jit_over_default_p50']:.2f} x; "
        f"{build:.1f} s to build; the same commands: {'yes' if commands_equal else 'NO'})")
    return document


def growth(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per solver: tick p50 at the largest horizon over the smallest, against their ratio."""
    found: dict[str, dict[str, Any]] = {}
    for solver in dict.fromkeys(row["solver"] for row in rows):
        by_horizon = {row["horizon"]: row for row in rows if row["solver"] == solver}
        low, high = min(by_horizon), max(by_horizon)
        if high > low:
            ratio = by_horizon[high]["tick_p50"] / by_horizon[low]["tick_p50"]
            found[solver] = {"from": low, "to": high, "horizon_ratio": high / low,
                             "tick_ratio": ratio, "at_most_linear": ratio <= high / low}
    return found


# --------------------------------------------------------------------------- 3. scenarios
def scenarios_section(layouts: list[str], modes: list[str], speeds: dict[str, float],
                      trajectories: list[str], headings: list[str], ticks: int,
                      say: Printer, jit: bool = False) -> list[dict[str, Any]]:
    """Every layout x trajectory x heading x mode x speed at N = 20 with daqp (``jit``:
    built with ``jit=True``); a tick p99 above :data:`P99_LIMIT` is flagged, wall clock and
    process CPU apart."""
    say(f"{'layout':8s} {'shape':8s} {'heading':8s} {'mode':5s} {'speed':7s} "
        f"{'tick p50':>9s} {'tick p99':>9s} {'cpu p99':>9s} {'tick max':>9s} {'iters':>6s} "
        f"{'rms err':>9s}  p99 > {P99_LIMIT * 1e3:g} ms")
    say(f"{'':8s} {'':8s} {'':8s} {'':5s} {'':7s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} "
        f"{'[ms]':>9s} {'':>6s} {'[mm]':>9s}")
    rows = []
    for layout in layouts:
        robot = preset(layout)
        for shape in trajectories:
            for heading in headings:
                for speed, ratio in speeds.items():
                    trajectory = reference(shape, heading, robot, ratio)
                    for mode in modes:
                        control = Controller(robot, trajectory, horizon=REFERENCE_HORIZON,
                                             dt=DT, solver=FAST, mode=mode, jit=jit)
                        row = _row(_run(control, ticks), _settle(ticks), section="scenarios",
                                   layout=layout, trajectory=shape, heading=heading,
                                   mode=mode, speed=speed, peak_ratio=ratio, solver=FAST,
                                   horizon=REFERENCE_HORIZON, jit=jit)
                        row["over_p99_limit"] = row["tick_p99"] > P99_LIMIT
                        row["cpu_over_p99_limit"] = row["cpu_p99"] > P99_LIMIT
                        rows.append(row)
                        flag = " ".join(name for name, over in
                                        (("wall", row["over_p99_limit"]),
                                         ("cpu", row["cpu_over_p99_limit"])) if over)
                        say(f"{layout:8s} {shape:8s} {heading:8s} {mode:5s} {speed:7s} "
                            f"{_ms(row['tick_p50'])} {_ms(row['tick_p99'])} "
                            f"{_ms(row['cpu_p99'])} {_ms(row['tick_max'])} "
                            f"{row['iterations_p50']:6.0f} "
                            f"{row['rms_position_error'] * 1e3:9.4f}  {flag}")
    return rows


# ------------------------------------------------------------------------------- 4. peers
def peers_section(ticks: int, say: Printer, rounds: int = PEER_ROUNDS,
                  compiled: bool = False, plants: tuple[str, ...] | list[str] = ("ideal",)
                  ) -> dict[str, Any]:
    """daqp (the default and ``jit=True``, when it compiles; with ``compiled``, the compiled
    tick too), the IPOPT path and (when
    installed) do-mpc on the reference scenario, inside and beyond the limits, over the same
    ticks on the same plant: each controller built once and run ``rounds`` times, the
    controllers taking turns (the order rotated each round), so that every ratio is taken
    under the same load, their objects frozen out of the garbage collector's scans
    (``gc.freeze``) meanwhile; tick times pooled over the rounds, errors from the first.
    Each of ``plants`` (:data:`benchmarks.perf_plants.PLANTS`) in turn, the same
    controllers on each: the rows say which (``plant``)."""
    robot = preset(REFERENCE_LAYOUT)
    names = [f"mpc-{FAST}", JIT_PEER, *([COMPILED_PEER] if compiled else []), "mpc-ipopt"]
    if peers.available():
        names.append("do-mpc")
        say(f"do-mpc {peers.version()}: IPOPT inside do-mpc, exact SE(2) integral (no "
            f"collocation), the project's grid, weights and wheel limits")
    else:
        say(peers.INSTALL_HINT)
    say(f"{rounds} rounds of {ticks} ticks each, the controllers taking turns; tick p50 over "
        f"the rounds' ticks pooled")
    for plant in plants:
        say(describe(plant))
    say(f"{'speed':7s} {'plant':9s} {'controller':12s} {'tick p50':>9s} {'solve p50':>9s} "
        f"{'iters':>6s} {'rms err':>11s} {'max err':>11s} {'failures':>8s} {'build':>6s}")
    say(f"{'':7s} {'':9s} {'':12s} {'[ms]':>9s} {'[ms]':>9s} {'':>6s} {'[mm]':>11s} "
        f"{'[mm]':>11s} {'':>8s} {'[s]':>6s}")
    rows = []
    for speed in ("inside", "beyond"):
        trajectory: Trajectory = reference(REFERENCE_SHAPE, REFERENCE_HEADING, robot,
                                           SPEEDS[speed])
        built: dict[str, tuple[TrackingController, float]] = {}
        for name in names:
            started = time.perf_counter()
            control: TrackingController
            if name == "do-mpc":
                ours = Controller(robot, trajectory, horizon=REFERENCE_HORIZON, dt=DT)
                control = peers.DoMpcController(robot, trajectory, horizon=REFERENCE_HORIZON,
                                                dt=DT, stage_dt=ours.stage_dt,
                                                weights=ours.weights)
            elif name == JIT_PEER:
                try:
                    control = Controller(robot, trajectory, horizon=REFERENCE_HORIZON, dt=DT,
                                         solver=FAST, jit=True)
                except ControllerError as error:  # no compiler: the row is left out
                    say(f"{speed:7s} {name:10s} skipped: {error}")
                    continue
            elif name == COMPILED_PEER:
                try:
                    control = Controller(robot, trajectory, horizon=REFERENCE_HORIZON, dt=DT,
                                         solver=FAST, compiled=True)
                except ControllerError as error:  # not covered yet: the row is left out
                    say(f"{speed:7s} {name:10s} skipped: {error}")
                    continue
            else:
                control = Controller(robot, trajectory, horizon=REFERENCE_HORIZON, dt=DT,
                                     solver=name.removeprefix("mpc-"))
            built[name] = control, time.perf_counter() - started
        for plant in plants:
            rows += _peer_rounds(built, ticks, rounds, speed, plant, say)
    return {"status": "measured" if "do-mpc" in names else "do-mpc not installed",
            "version": peers.version(), "rows": rows,
            "integration": "exact SE(2) integral of the body twist over each stage "
                           "(discrete do-mpc model, no collocation)"}


def _peer_rounds(built: dict[str, tuple[TrackingController, float]], ticks: int, rounds: int,
                 speed: str, plant: str, say: Printer) -> list[dict[str, Any]]:
    """The peers' rounds at ``speed`` on ``plant``: one row a controller."""
    # Every controller is alive through the rounds: their objects are frozen out of
    # the garbage collector's scans, so that one's heap (do-mpc's is large) does not
    # slow another's ticks (docs/design/perf-gc-freeze.md).
    gc.collect()
    gc.freeze()
    runs: dict[str, list[Run]] = {name: [] for name in built}
    failures = dict.fromkeys(built, 0)
    order = list(built)
    try:
        for turn in range(rounds):
            for name in order[turn % len(order):] + order[:turn % len(order)]:
                control = built[name][0]
                runs[name].append(_run(control, ticks, plant=plant))  # (simulate resets it)
                if isinstance(control, peers.DoMpcController):
                    failures[name] += control.failures  # IPOPT reported no success
    finally:
        gc.unfreeze()
    rows = []
    for name, (control, build) in built.items():
        row = _row(runs[name], _settle(ticks), section="peers", layout=REFERENCE_LAYOUT,
                   mode="time", speed=speed, peak_ratio=SPEEDS[speed], solver=name,
                   horizon=REFERENCE_HORIZON, build_time=build, rounds=rounds, plant=plant)
        if isinstance(control, peers.DoMpcController):
            row["failures"] = failures[name]  # (no fallback: IPOPT's last iterate)
        rows.append(row)
        say(f"{speed:7s} {plant:9s} {name:12s} {_ms(row['tick_p50'])} {_ms(row['solve_p50'])} "
            f"{row['iterations_p50']:6.0f} {row['rms_position_error'] * 1e3:11.6f} "
            f"{row['max_position_error'] * 1e3:11.6f} {row['failures']:8d} {build:6.1f}")
    return rows


# ------------------------------------------------------------------------------- summary
def summarise(horizon_rows: list[dict[str, Any]], scenario_rows: list[dict[str, Any]],
              peer: dict[str, Any] | None, drift: dict[str, Any] | None,
              jit: dict[str, Any] | None = None,
              section: dict[str, Any] | None = None) -> dict[str, Any]:
    """Ratios within this run, and issues 11 and 12's targets checked against them
    (``jit``: :func:`jit_comparison`'s document, reported beside them, not a target);
    with the ``compiled`` section's document (``section``), issue 37's lines (``issue37``)."""
    summary: dict[str, Any] = {}
    at = {(row["solver"], row["horizon"]): row for row in horizon_rows}
    fast = at.get((FAST, REFERENCE_HORIZON))
    if fast is not None:
        summary[f"{FAST}_tick_p50_N20"] = fast["tick_p50"]
        summary[f"{FAST}_tick_p99_N20"] = fast["tick_p99"]
        summary[f"{FAST}_cpu_p99_N20"] = fast["cpu_p99"]
        summary[f"{FAST}_tick_over_solve_N20"] = fast["tick_p50"] / fast["solve_p50"]
        for solver in SOLVERS:
            other = at.get((solver, REFERENCE_HORIZON))
            if solver != FAST and other is not None:
                summary[f"{solver}_over_{FAST}_tick_N20"] = other["tick_p50"] / fast["tick_p50"]
    if jit is not None:
        summary[JIT] = dict(jit)
        ipopt_over = summary.get(f"ipopt_over_{FAST}_tick_N20")
        if ipopt_over is not None:  # the two ratios, each within this run
            summary[JIT]["ipopt_over_jit_tick_N20"] = ipopt_over / jit["jit_over_default_p50"]
    if horizon_rows:
        summary["growth"] = growth(horizon_rows)
    if scenario_rows:
        summary["scenario_count"] = len(scenario_rows)
        summary["scenarios_jit"] = any(row.get("jit", False) for row in scenario_rows)
        summary["scenario_tick_p99_max"] = max(row["tick_p99"] for row in scenario_rows)
        summary["scenario_cpu_p99_max"] = max(row["cpu_p99"] for row in scenario_rows)
        for key, flag in (("scenarios_over_p99_limit", "over_p99_limit"),
                          ("scenarios_cpu_over_p99_limit", "cpu_over_p99_limit")):
            summary[key] = [f"{row['layout']} {row['trajectory']} {row['heading']} "
                            f"{row['mode']} {row['speed']}" for row in scenario_rows if row[flag]]
        by_layout = {(row["layout"], row["mode"], row["speed"]): row for row in scenario_rows}
        swerve = by_layout.get(("swerve", "time", "beyond"))
        mecanum = by_layout.get(("mecanum", "time", "beyond"))
        if swerve is not None and mecanum is not None:
            summary["swerve_tick_p99_beyond"] = swerve["tick_p99"]
            summary["swerve_over_mecanum_tick_p50_beyond"] = (swerve["tick_p50"]
                                                              / mecanum["tick_p50"])
    if peer is not None and peer["rows"]:
        summary.update(same_ticks(peer["rows"]))
    if drift is not None:
        summary["drift"] = drift
    summary["targets"] = _targets(summary)
    if section is not None:
        summary["compiled_scenarios"] = {
            "measured": len({(row["layout"], row["mode"], row["speed"])
                             for row in section["rows"]}),
            "not_supported": len(section["unsupported"])}
        summary["issue37"] = _issue37(summary, section["rows"])
    return summary


def same_ticks(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The peers section's ratios over the same ticks (one plant's rows), by
    ``same_ticks_<speed>``."""
    found: dict[str, dict[str, Any]] = {}
    by = {(row["speed"], row["solver"]): row for row in rows}
    for speed in ("inside", "beyond"):
        mine, ipopt = by[(speed, f"mpc-{FAST}")], by[(speed, "mpc-ipopt")]
        item = {f"ipopt_over_{FAST}_tick": ipopt["tick_p50"] / mine["tick_p50"],
                f"{FAST}_rms_over_ipopt_rms":
                    mine["rms_position_error"] / ipopt["rms_position_error"]}
        other = by.get((speed, "do-mpc"))
        if other is not None:
            item.update({
                f"do_mpc_over_{FAST}_tick": other["tick_p50"] / mine["tick_p50"],
                "do_mpc_over_ipopt_tick": other["tick_p50"] / ipopt["tick_p50"],
                "do_mpc_rms_over_ipopt_rms":
                    other["rms_position_error"] / ipopt["rms_position_error"]})
        compiled = by.get((speed, JIT_PEER))
        if compiled is not None:  # beside the targets (those are the default's)
            item["ipopt_over_jit_tick"] = ipopt["tick_p50"] / compiled["tick_p50"]
            if other is not None:
                item["do_mpc_over_jit_tick"] = other["tick_p50"] / compiled["tick_p50"]
        tick = by.get((speed, COMPILED_PEER))
        if tick is not None:  # issue 37's lines (the compiled tick)
            item["compiled_tick_p50"] = tick["tick_p50"]
            item["ipopt_over_compiled_tick"] = ipopt["tick_p50"] / tick["tick_p50"]
            item["compiled_rms_over_ipopt_rms"] = (tick["rms_position_error"]
                                                   / ipopt["rms_position_error"])
            if other is not None:
                item["do_mpc_over_compiled_tick"] = other["tick_p50"] / tick["tick_p50"]
        found[f"same_ticks_{speed}"] = item
    return found


def _issue37(summary: dict[str, Any], rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Issue 37's "done when" lines measured in this run: the reference scenario's (from
    the peers section's same ticks, inside the limits) and every scenario's
    (:func:`benchmarks.compiled_tick.issue_targets`)."""
    checks: dict[str, dict[str, Any]] = {}
    inside = summary.get("same_ticks_inside", {})
    for key, limit, at_most in (("do_mpc_over_compiled_tick", TARGET_DO_MPC_OVER_COMPILED, False),
                                ("ipopt_over_compiled_tick", TARGET_IPOPT_OVER_COMPILED, False),
                                ("compiled_rms_over_ipopt_rms",
                                 1.0 + TARGET_COMPILED_RMS_VS_IPOPT, True)):
        if key in inside:
            value = inside[key]
            checks[f"mecanum_inside_{key}"] = {
                "measured": value, "limit": limit, "at_most" if at_most else "at_least": True,
                "met": bool(value <= limit if at_most else value >= limit)}
    checks.update(issue_targets(rows))
    return checks


def _targets(summary: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Issue 12's "done when" (and issue 11's swerve speed lines), each with the measured
    value and whether it is met."""
    checks: dict[str, dict[str, Any]] = {}

    def check(name: str, value: float | None, limit: float, at_most: bool) -> None:
        if value is not None:
            met = value <= limit if at_most else value >= limit
            checks[name] = {"measured": value, "limit": limit,
                            "at_most" if at_most else "at_least": True, "met": bool(met)}

    check(f"{FAST}_tick_p50_N20", summary.get(f"{FAST}_tick_p50_N20"), TARGET_TICK_P50, True)
    check(f"{FAST}_tick_p99_N20", summary.get(f"{FAST}_tick_p99_N20"), TARGET_TICK_P99, True)
    check(f"{FAST}_cpu_p99_N20", summary.get(f"{FAST}_cpu_p99_N20"), TARGET_TICK_P99, True)
    inside = summary.get("same_ticks_inside")
    if inside is not None:
        if f"do_mpc_over_{FAST}_tick" in inside:
            check(f"do_mpc_over_{FAST}_tick", inside[f"do_mpc_over_{FAST}_tick"],
                  TARGET_OVER_DO_MPC, False)
        check(f"ipopt_over_{FAST}_tick", inside[f"ipopt_over_{FAST}_tick"],
              TARGET_OVER_IPOPT, False)
        check(f"{FAST}_rms_over_ipopt_rms_inside", inside[f"{FAST}_rms_over_ipopt_rms"],
              1.0 + TARGET_RMS_VS_IPOPT, True)
    if "scenario_tick_p99_max" in summary:
        check("scenario_tick_p99_max", summary["scenario_tick_p99_max"], P99_LIMIT, True)
        check("scenario_cpu_p99_max", summary["scenario_cpu_p99_max"], P99_LIMIT, True)
    if "swerve_tick_p99_beyond" in summary:
        check("swerve_tick_p99_beyond", summary["swerve_tick_p99_beyond"], TARGET_SWERVE_P99,
              True)
        check("swerve_over_mecanum_tick_p50_beyond",
              summary["swerve_over_mecanum_tick_p50_beyond"], TARGET_SWERVE_OVER_MECANUM, True)
    fast_growth = summary.get("growth", {}).get(FAST)
    if fast_growth is not None:
        check(f"{FAST}_tick_growth", fast_growth["tick_ratio"], fast_growth["horizon_ratio"],
              True)
    return checks


def _print_summary(summary: dict[str, Any], say: Printer) -> None:
    if set(summary) == {"targets"} and not summary["targets"]:
        return  # nothing was compared (the profile alone)
    say("summary (ratios of tick p50 within this run unless named):")
    if f"{FAST}_tick_over_solve_N20" in summary:
        say(f"  {FAST} N=20: tick p50 {summary[f'{FAST}_tick_p50_N20'] * 1e6:.1f} us, "
            f"p99 {summary[f'{FAST}_tick_p99_N20'] * 1e6:.1f} us (CPU p99 "
            f"{summary[f'{FAST}_cpu_p99_N20'] * 1e6:.1f} us), tick / solve "
            f"{summary[f'{FAST}_tick_over_solve_N20']:.2f}")
    for solver in SOLVERS:
        key = f"{solver}_over_{FAST}_tick_N20"
        if key in summary:
            say(f"  {solver} / {FAST} at N=20: {summary[key]:.1f}")
    if JIT in summary:
        jit = summary[JIT]
        line = (f"  {FAST} with jit=True (its terms compiled to C) at N=20, alternating with "
                f"the default: {jit['jit_over_default_p50']:.2f} x its tick p50 "
                f"({jit['jit_p50'] * 1e6:.1f} against {jit['default_p50'] * 1e6:.1f} us)")
        if "ipopt_over_jit_tick_N20" in jit:
            line += f"; ipopt / it {jit['ipopt_over_jit_tick_N20']:.1f}"
        say(line)
    for solver, item in summary.get("growth", {}).items():
        verdict = "at most linear" if item["at_most_linear"] else "MORE than linear"
        say(f"  growth {solver}: tick(N={item['to']}) / tick(N={item['from']}) = "
            f"{item['tick_ratio']:.2f} against {item['horizon_ratio']:g}: {verdict}")
    if "scenario_tick_p99_max" in summary:
        over, cpu = summary["scenarios_over_p99_limit"], summary["scenarios_cpu_over_p99_limit"]
        built = " (jit=True)" if summary["scenarios_jit"] else ""
        say(f"  scenarios{built}: worst tick p99 "
            f"{summary['scenario_tick_p99_max'] * 1e3:.3f} ms wall "
            f"({len(over)} of {summary['scenario_count']} over 1 ms), "
            f"{summary['scenario_cpu_p99_max'] * 1e3:.3f} ms CPU ({len(cpu)} over 1 ms"
            + (f": {', '.join(cpu)}" if cpu else "") + ")")
    for speed in ("inside", "beyond"):
        item = summary.get(f"same_ticks_{speed}")
        if item is None:
            continue
        line = (f"  same ticks, {speed}: IPOPT path / {FAST} {item[f'ipopt_over_{FAST}_tick']:.1f}"
                f"; RMS error {FAST} / IPOPT path {item[f'{FAST}_rms_over_ipopt_rms']:.4f}")
        if f"do_mpc_over_{FAST}_tick" in item:
            line += (f"; do-mpc / {FAST} {item[f'do_mpc_over_{FAST}_tick']:.1f}, do-mpc / IPOPT"
                     f" path {item['do_mpc_over_ipopt_tick']:.2f}; RMS error do-mpc / IPOPT "
                     f"path {item['do_mpc_rms_over_ipopt_rms']:.4f}")
        if "ipopt_over_jit_tick" in item:
            line += f"; with jit=True: IPOPT path / it {item['ipopt_over_jit_tick']:.1f}"
            if "do_mpc_over_jit_tick" in item:
                line += f", do-mpc / it {item['do_mpc_over_jit_tick']:.1f}"
        say(line)
        if "ipopt_over_compiled_tick" in item:  # issue 37's two ratios, stated as such
            line = (f"  same ticks, {speed}: {REFERENCE_LAYOUT} {REFERENCE_SHAPE} "
                    f"N={REFERENCE_HORIZON}, compiled tick p50 "
                    f"{item['compiled_tick_p50'] * 1e6:.1f} us: ")
            if "do_mpc_over_compiled_tick" in item:
                line += f"do-mpc / compiled {item['do_mpc_over_compiled_tick']:.1f}, "
            else:
                line += "do-mpc / compiled: do-mpc not installed, "
            say(line + f"IPOPT path / compiled {item['ipopt_over_compiled_tick']:.1f}; RMS "
                f"error compiled / IPOPT path {item['compiled_rms_over_ipopt_rms']:.4f}")
    if "drift" in summary:
        drift = summary["drift"]
        say(f"  drift: {FAST} N=20 tick p50 measured again at the end / at the start "
            f"{drift['end_over_start']:.2f} (the machine's noise over this run)")
    targets = summary["targets"]
    if targets:
        say("issue 12 targets (and issue 11's swerve_ lines) on this machine:")
        for name, item in targets.items():
            sign = "<=" if item.get("at_most") else ">="
            value, limit = item["measured"], item["limit"]
            shown = (f"{value * 1e6:.1f} us {sign} {limit * 1e6:.0f} us" if limit < 0.01
                     else f"{value:.2f} {sign} {limit:g}")
            say(f"  {name}: {shown}: {'met' if item['met'] else 'NOT met'}")
    if "issue37" in summary:
        covered = summary["compiled_scenarios"]
        plants = summary.get("issue37_plants") or {"": summary["issue37"]}
        for plant, lines in plants.items():
            on = f" on the {plant} plant" if plant else ""
            say(f"issue 37 targets (the compiled tick, {covered['measured']} scenarios "
                f"measured, {covered['not_supported']} not supported yet){on} on this "
                f"machine:")
            for name, item in lines.items():
                say(f"  {name}: {_shown(item)}: {'met' if item['met'] else 'NOT met'}")


def _shown(item: dict[str, Any]) -> str:
    """A target's measured value against its limit, with its worst scenario if named."""
    sign = "<=" if item.get("at_most") else ">="
    value, limit = item["measured"], item["limit"]
    shown = (f"{value * 1e6:.1f} us {sign} {limit * 1e6:.0f} us" if limit < 0.01
             else f"{value:.2f} {sign} {limit:g}")
    return shown + (f" (worst: {item['scenario']})" if "scenario" in item else "")


def issue37_by_plant(peer_rows: list[dict[str, Any]], compiled_rows: list[dict[str, Any]],
                     plants: list[str]) -> dict[str, dict[str, dict[str, Any]]]:
    """Issue 37's lines on each plant, from one run's peers and compiled rows (a row
    without a ``plant`` is the ideal plant's)."""
    found = {}
    for plant in plants:
        mine = [row for row in peer_rows if row.get("plant", "ideal") == plant]
        ticks = same_ticks(mine) if mine else {}
        found[plant] = _issue37(ticks, [row for row in compiled_rows
                                        if row.get("plant", "ideal") == plant])
    return found


def every_run(runs: list[dict[str, dict[str, dict[str, Any]]]]
              ) -> dict[str, dict[str, dict[str, Any]]]:
    """Issue 37's lines over several runs (each :func:`issue37_by_plant`'s), by plant and
    line: each run's value (and worst scenario) and whether it was met in every run."""
    table: dict[str, dict[str, dict[str, Any]]] = {}
    for lines_by_plant in runs:
        for plant, lines in lines_by_plant.items():
            for name, item in lines.items():
                entry = table.setdefault(plant, {}).setdefault(
                    name, {"limit": item["limit"], "at_most": bool(item.get("at_most")),
                           "measured": [], "scenario": [], "met": []})
                entry["measured"].append(item["measured"])
                entry["scenario"].append(item.get("scenario"))
                entry["met"].append(item["met"])
    for lines in table.values():
        for entry in lines.values():
            entry["met_in_every_run"] = len(entry["met"]) == len(runs) and all(entry["met"])
    return table


def _print_every_run(table: dict[str, dict[str, dict[str, Any]]], runs: int,
                     say: Printer) -> None:
    say(f"issue 37 targets in each of the {runs} runs (run 1 / 2 / ..., worst scenario in "
        f"brackets):")
    for plant, lines in table.items():
        say(f"  {plant} plant:")
        for name, entry in lines.items():
            values = []
            for value, scenario in zip(entry["measured"], entry["scenario"], strict=True):
                text = (f"{value * 1e6:.1f} us" if entry["limit"] < 0.01 else f"{value:.2f}")
                values.append(text + (f" ({scenario})" if scenario else ""))
            sign = "<=" if entry["at_most"] else ">="
            limit = (f"{entry['limit'] * 1e6:.0f} us" if entry["limit"] < 0.01
                     else f"{entry['limit']:g}")
            verdict = ("met in every run" if entry["met_in_every_run"]
                       else f"NOT met in {entry['met'].count(False)} of {runs}")
            say(f"    {name}: {' / '.join(values)}; {sign} {limit}: {verdict}")


# ---------------------------------------------------------------------------------- main
def _integers(flag: str, text: str) -> list[int]:
    try:
        values = [int(item) for item in text.split(",") if item.strip()]
    except ValueError:
        raise ScenarioError(f"{flag} must be a comma list of integers, got {text!r}") from None
    if not values or min(values) < 1:
        raise ScenarioError(f"{flag} must list integers >= 1, got {text!r}")
    return sorted(set(values))


def _profile_scenario(text: str | None) -> tuple[str, str, str]:
    """``--profile-scenario``'s layout, mode and speed (the reference scenario's if None)."""
    if text is None:
        return REFERENCE_LAYOUT, "time", "inside"
    parts = [part.strip() for part in text.split(",")]
    if len(parts) != 3:
        raise ScenarioError(f"--profile-scenario must be LAYOUT,MODE,SPEED (e.g. "
                            f"swerve,path,beyond), got {text!r}")
    layout, mode, speed = parts
    for flag, value, known in (("layout", layout, LAYOUTS), ("mode", mode, MODES),
                               ("speed", speed, tuple(SPEEDS))):
        if value not in known:
            raise ScenarioError(f"--profile-scenario: unknown {flag} {value!r}; expected one "
                                f"of {', '.join(known)}")
    return layout, mode, speed


def _commit() -> str | None:
    """The git commit of the code measured (``+dirty``: the library or the benchmark has
    uncommitted changes; results folders do not count), or None outside a git checkout."""
    folder = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=folder, capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "mpc", "trajectories", "benchmarks", ":!benchmarks/results"],
                               cwd=folder, capture_output=True, text=True, timeout=10,
                               check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("+dirty" if dirty else "")


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench perf", description=__doc__.split("\n")[0])
    add_list_option(parser, "--sections",
                    help=f"comma list of {', '.join(SECTIONS)} (default: all; "
                         f"--quick: {', '.join(QUICK_SECTIONS)})")
    add_list_option(parser, "--horizons", help="horizons of the horizons section (10,20,50,100)")
    parser.add_argument("--profile-horizons",
                        help="horizons the tick is split into phases at (20)")
    parser.add_argument("--profile-scenario", metavar="LAYOUT,MODE,SPEED",
                        help=f"the scenario the tick is split in, e.g. swerve,path,beyond "
                             f"(default: {REFERENCE_LAYOUT},time,inside)")
    add_list_option(parser, "--solvers",
                    help=f"comma list of {', '.join(SOLVERS)} (default: all)")
    add_list_option(parser, "--layouts",
                    help=f"scenarios: comma list of {', '.join(LAYOUTS)} (default: "
                         f"{', '.join(PRESETS)})")
    add_list_option(parser, "--modes",
                    help=f"scenarios: comma list of {', '.join(MODES)} (default: both)")
    add_list_option(parser, "--speeds",
                    help="scenarios: inside (0.8 x limits), beyond (1.3 x) or peak ratios "
                         "like 1.1 (default: inside,beyond)")
    add_list_option(parser, "--trajectories",
                    help=f"scenarios: comma list of {', '.join(TRAJECTORIES)} "
                         "(default: figure8)")
    add_list_option(parser, "--headings",
                    help=f"scenarios: comma list of {', '.join(HEADINGS)} (default: fixed)")
    parser.add_argument("--jit", action="store_true",
                        help="scenarios: build the daqp controllers with jit=True (their "
                             "CasADi terms compiled to C) instead of the default")
    parser.add_argument("--motors", action="store_true",
                        help="compiled: the layouts' motor presets (mpc.robots.motor_preset: "
                             "voltage, current and traction rows) instead of the kinematic")
    add_list_option(parser, "--plants",
                    help=f"peers and compiled: comma list of {', '.join(PLANTS)} (default: "
                         f"both; --quick: ideal): each scenario's closed loop on each")
    parser.add_argument("--runs", type=int,
                        help="peers and compiled: run both sections this many times, issue "
                             "37's lines stated for each run (1)")
    parser.add_argument("--ticks", type=int, help="ticks per run (400; --quick 40)")
    parser.add_argument("--ipopt-ticks", type=int,
                        help="ticks per IPOPT run and per peers run (120; --quick 20)")
    parser.add_argument("--peer-rounds", type=int,
                        help=f"peers: runs of each controller, in turns ({PEER_ROUNDS}; "
                             f"--quick 1)")
    parser.add_argument("--out", default="bench-out", metavar="DIR",
                        help="writes perf.json, perf.txt and tick_profile.txt/.json here "
                             "(bench-out)")
    add_force_argument(parser)
    parser.add_argument("--quick", action="store_true",
                        help="smoke run in seconds: horizons 10,20, 40 ticks (IPOPT 20), "
                             "scenarios on mecanum only, no compiled section unless named")
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    sections = choose("--sections", "section", args.sections, SECTIONS,
                      QUICK_SECTIONS if args.quick else SECTIONS)
    horizons = _integers("--horizons", args.horizons or ("10,20" if args.quick
                                                         else "10,20,50,100"))
    profile_horizons = _integers("--profile-horizons",
                                 args.profile_horizons or str(REFERENCE_HORIZON))
    profile_scenario = _profile_scenario(args.profile_scenario)
    solvers = choose("--solvers", "solver", args.solvers, list(SOLVERS))
    layouts = choose("--layouts", "layout", args.layouts or ("mecanum" if args.quick else None),
                      LAYOUTS, PRESETS)
    modes = choose("--modes", "mode", args.modes, list(MODES))
    speeds = parse_speeds(args.speeds)
    trajectories = choose("--trajectories", "trajectory", args.trajectories, TRAJECTORIES,
                           [REFERENCE_SHAPE])
    headings = choose("--headings", "heading", args.headings, HEADINGS, [REFERENCE_HEADING])
    ticks = args.ticks if args.ticks is not None else (40 if args.quick else 400)
    ipopt_ticks = (args.ipopt_ticks if args.ipopt_ticks is not None
                   else (20 if args.quick else 120))
    for flag, value in (("--ticks", ticks), ("--ipopt-ticks", ipopt_ticks)):
        if value < 20:
            raise ScenarioError(f"{flag} must be >= 20, got {value}")
    rounds = (args.peer_rounds if args.peer_rounds is not None
              else (1 if args.quick else PEER_ROUNDS))
    if rounds < 1:
        raise ScenarioError(f"--peer-rounds must be >= 1, got {rounds}")
    plants = choose("--plants", "plant", args.plants, list(PLANTS),
                    ["ideal"] if args.quick else list(PLANTS))
    runs = args.runs if args.runs is not None else 1
    if runs < 1:
        raise ScenarioError(f"--runs must be >= 1, got {runs}")
    profiles = ("tick_profile.txt", "tick_profile.json") if "profile" in sections else ()
    out = claim(args.out, ("perf.json", "perf.txt", *profiles), args.force)

    say = Printer()
    command = " ".join(["mpc-bench", "perf", *argv])
    started = time.perf_counter()
    load_start = os.getloadavg() if hasattr(os, "getloadavg") else None
    commit = _commit()
    say(f"{command}: sections {', '.join(sections)}; {ticks} ticks a run (IPOPT and peers "
        f"{ipopt_ticks}), dt {DT} s, ideal plant; peers and compiled on the "
        f"{', '.join(plants)} plant{'s' if len(plants) > 1 else ''}"
        + (f", {runs} runs" if runs > 1 else ""))
    profile = horizon_rows = scenario_rows = peer = drift = jit = None
    if "profile" in sections:
        say("\n== 1. tick split (TickProfile) ==")
        profile = profile_section(profile_horizons, ticks, out, command, say, profile_scenario)
    if "horizons" in sections:
        say(f"\n== 2. horizons: {REFERENCE_LAYOUT} {REFERENCE_SHAPE} inside, solvers "
            f"{', '.join(solvers)} ==")
        horizon_rows = horizons_section(solvers, horizons, ticks, ipopt_ticks, say)
        if FAST in solvers:
            say(f"\n{FAST} with jit=True against the default (same scenario, N="
                f"{REFERENCE_HORIZON}):")
            jit = jit_comparison(ticks, JIT_REPEATS, say)
    if "scenarios" in sections:
        built = " with jit=True" if args.jit else ""
        say(f"\n== 3. scenarios at N={REFERENCE_HORIZON}, {FAST}{built} (p99 flagged above "
            f"{P99_LIMIT * 1e3:g} ms) ==")
        scenario_rows = scenarios_section(layouts, modes, speeds, trajectories, headings,
                                          ticks, say, args.jit)
    compiled = None
    peer_runs: list[dict[str, Any] | None] = []
    compiled_runs: list[dict[str, Any] | None] = []
    for run in range(1, runs + 1):
        each = f" (run {run} of {runs})" if runs > 1 else ""
        found = None
        if "peers" in sections:
            say(f"\n== 4. peers: {FAST}, the IPOPT path and do-mpc on the same problem and "
                f"ticks{each} ==")
            found = peers_section(ipopt_ticks, say, rounds, "compiled" in sections, plants)
            for row in found["rows"]:
                row["run"] = run
        peer_runs.append(found)
        found = None
        if "compiled" in sections:
            say("\n== 5. compiled tick: Controller(compiled=True) beside itself rebuilding "
                "its Hessian every tick, the Python tick, its virtual machine, the exported C "
                f"library and the IPOPT path{each} ==")
            found = compiled_section(
                layouts, modes, speeds, REFERENCE_SHAPE, REFERENCE_HEADING,
                REFERENCE_HORIZON, DT, ipopt_ticks, rounds, reference, _run, _row, _settle,
                say, motors=args.motors, plants=plants)
            for row in found["rows"]:
                row["run"] = run
        compiled_runs.append(found)
    peer, compiled = peer_runs[0], compiled_runs[0]
    first = next((row for row in horizon_rows or []
                  if row["solver"] == FAST and row["horizon"] == REFERENCE_HORIZON), None)
    if first is not None:  # the same run again: how much the machine moved meanwhile
        robot = preset(REFERENCE_LAYOUT)
        again = _row(_run(Controller(robot, reference(REFERENCE_SHAPE, REFERENCE_HEADING,
                                                      robot, SPEEDS["inside"]),
                                     horizon=REFERENCE_HORIZON, dt=DT, solver=FAST), ticks),
                     _settle(ticks))
        drift = {"start_tick_p50": first["tick_p50"], "end_tick_p50": again["tick_p50"],
                 "end_over_start": again["tick_p50"] / first["tick_p50"]}
    lead = plants[0]  # issues 11 and 12's lines: from the first plant's peers rows

    def on_first(document: dict[str, Any] | None) -> dict[str, Any] | None:
        return None if document is None else {
            **document, "rows": [row for row in document["rows"]
                                 if row.get("plant", "ideal") == lead]}

    summary = summarise(horizon_rows or [], scenario_rows or [], on_first(peer), drift, jit,
                        on_first(compiled))
    by_run = [issue37_by_plant((ran or {}).get("rows", []), (built or {}).get("rows", []),
                               plants)
              for ran, built in zip(peer_runs, compiled_runs, strict=True)]
    if "issue37" in summary:
        summary["issue37_plants"] = by_run[0]
        if runs > 1:
            summary["issue37_runs"] = by_run
            summary["issue37_every_run"] = every_run(by_run)
    say()
    _print_summary(summary, say)
    if "issue37_every_run" in summary:
        _print_every_run(summary["issue37_every_run"], runs, say)
    rows = [*(horizon_rows or []), *(scenario_rows or []),
            *(row for ran in peer_runs for row in (ran or {}).get("rows", [])),
            *(row for built in compiled_runs for row in (built or {}).get("rows", []))]
    document = {
        "command": command,
        "commit": commit,
        "machine": {**machine(), "load_average_start": load_start,
                    "load_average_end": os.getloadavg() if hasattr(os, "getloadavg") else None,
                    # BLAS threads: the condensed QP's dense algebra runs in NumPy's BLAS
                    "thread_env": {name: os.environ.get(name) for name in THREAD_VARIABLES}},
        "settings": {"dt": DT, "ticks": ticks, "ipopt_ticks": ipopt_ticks, "peer_rounds": rounds,
                     "horizons": horizons, "profile_horizons": profile_horizons,
                     "profile_scenario": list(profile_scenario),
                     "solvers": solvers, "layouts": layouts,
                     "modes": modes, "speeds": speeds, "trajectories": trajectories,
                     "headings": headings, "sections": sections, "plant": "ideal",
                     "plants": plants, "runs": runs,
                     "plant_settings": {name: {"preset": PLANTS[name].preset,
                                               "start_offset": PLANTS[name].start_offset,
                                               "seed": PLANTS[name].seed}
                                        for name in plants},
                     "jit_scenarios": args.jit, "motors_compiled": args.motors,
                     "p99_limit": P99_LIMIT},
        "profiles": profile,
        "rows": rows,
        "peers": None if peer is None else {key: value for key, value in peer.items()
                                            if key != "rows"},
        "jit": jit,
        "compiled": None if compiled is None else {key: value for key, value in
                                                   compiled.items() if key != "rows"},
        "summary": summary,
        "wall_time": time.perf_counter() - started,
    }
    (out / "perf.json").write_text(json.dumps(document, indent=1) + "\n")
    say(f"wrote {out / 'perf.json'} ({document['wall_time']:.0f} s)")
    (out / "perf.txt").write_text("\n".join(say.lines) + "\n")
    sys.stdout.flush()
    return 0
