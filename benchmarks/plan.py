"""The benchmark's runs: every scenario with every controller that applies to it, on a
pool of workers (:mod:`benchmarks.executor`), one progress line a run."""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

from benchmarks.eta import EtaEstimator
from benchmarks.executor import MPC_CONTROLLERS, RunPool, RunSpec
from benchmarks.executor import optimal_lap as yardstick
from benchmarks.runner import Scenario, describe_robot, describe_trajectory, run_pace
from benchmarks.scenarios import Settings, applies


def run_all(
    scenarios: list[Scenario],
    controllers: list[str],
    settings: Settings,
    duration: float | None,
    skip: float,
    plant: str,
    seed: int,
    log: Callable[[str], None],
    pool: RunPool | None = None,
    failed: list[dict[str, Any]] | None = None,
    command_ramp: bool | None = None,
    estimator: EtaEstimator | None = None,
) -> list[dict[str, Any]]:
    """Simulate every scenario with every controller on ``pool`` (default: in this
    process); print one line per run as it finishes; return the runs in plan order.

    A run that raised is left out of the result and appended to ``failed`` (its labels and
    an ``"error"``), and the other runs go on. ``command_ramp``: what the MPCs are told of
    the wheel loops (:attr:`~benchmarks.executor.RunSpec.command_ramp`; None: per plant).
    ``estimator`` (if any) learns the runs' times for the ETA
    (:meth:`benchmarks.executor.RunPool.run`).
    """
    plan = [(index, name) for index, scenario in enumerate(scenarios) for name in controllers
            if applies(name, scenario.robot)]
    described = [(describe_robot(s.robot), describe_trajectory(s)) for s in scenarios]
    executor = pool or RunPool(workers=1)  # one worker: no processes to close
    laps = executor.map(yardstick, described)  # once per scenario, in parallel
    specs = [RunSpec(robot=described[index][0], trajectory=described[index][1],
                     controller=name, settings=settings, duration=duration, skip=skip,
                     plant=plant, command_ramp=command_ramp if name in MPC_CONTROLLERS else None,
                     seed=seed, optimal_lap=laps[index], series=True,
                     labels={"layout": scenarios[index].layout,
                             "trajectory": scenarios[index].trajectory_name,
                             "heading": scenarios[index].heading,
                             "speed": scenarios[index].speed})
             for index, name in plan]
    widths = {key: max(len(str(spec.labels[key])) for spec in specs) if specs else 0
              for key in ("layout", "trajectory", "heading", "speed")}
    widths["controller"] = max((len(name) for _, name in plan), default=0)
    results = executor.run(specs, log, line=functools.partial(_run_line, widths=widths),
                           estimator=estimator)
    if failed is not None:
        failed.extend(result for result in results if "error" in result)
    return [result for result in results if "error" not in result]


def _run_line(run: Mapping[str, Any], widths: Mapping[str, int] | None = None) -> str:
    """The text of a run's progress line, its names padded to ``widths`` (the longest of
    each in the plan) so that the numbers line up."""
    names = " ".join(f"{run[key]:{(widths or {}).get(key, 0)}s}"
                     for key in ("layout", "trajectory", "heading", "speed", "controller"))
    if "error" in run:
        return f"{names} FAILED {run['error']}"
    metrics, pace = run["metrics"], run_pace(dict(run))
    return (f"{names} rms {metrics['rms_position_error'] * 1e3:8.3g} mm"
            f"  path {metrics['max_cross_track_error'] * 1e3:8.3g} mm"
            f"  lap/target {'-' if pace is None else f'{pace:.3f}':>5s}"
            f"  tick p50 {metrics['tick_time_p50'] * 1e3:6.3f} ms")
