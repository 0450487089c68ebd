"""Independent closed-loop runs, in this process, on local processes or on a Dask cluster.

A run is a :class:`RunSpec`: plain data (a robot preset name or description dict, a
trajectory spec, a controller name, settings, plant, seed). A worker rebuilds the robot,
the reference and the controller from it (:func:`execute`); nothing compiled (CasADi
functions, OSQP or daqp workspaces) crosses a process boundary, and one function runs
every run whichever executor carries it, so a run's numbers do not depend on where it
ran. :class:`RunPool` is that executor::

    with RunPool(workers=4) as pool:                  # or RunPool(scheduler="tcp://...")
        results = pool.run(specs, log=print)          # in the order of specs

``workers=1`` runs in this process. Local workers are spawned (not forked) with
``OPENBLAS_NUM_THREADS=1`` (and the OpenMP and MKL equivalents) in their environment,
so BLAS is single-threaded from their first numpy import; Dask's nanny sets the same
variables in its workers by default (``distributed.nanny.pre-spawn-environ``), and
:class:`RunPool` checks them on connecting. A run that raises comes back as an entry
with an ``"error"`` field; the other runs go on.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from benchmarks.eta import EtaEstimator, PlannedRun, prior_factor
from benchmarks.runner import Scenario, default_duration, pack_run
from benchmarks.scenarios import _MPC as MPC_CONTROLLERS  # (solver, mode) by name
from benchmarks.scenarios import (
    ALL_TRAJECTORIES,
    HEADINGS,
    ScenarioError,
    Settings,
    controller,
    mpc_controller,
    reference,
    shape,
)
from mpc.robots import Robot, from_dict, motor_preset, preset
from mpc.sim import (
    PLANT_PRESETS,
    MotorPlantConfig,
    PlantConfig,
    TrackingController,
    simulate,
)
from trajectories import (
    SampledTrajectory,
    Trajectory,
    Waypoints,
)

#: Environment of every worker process: single-threaded BLAS and OpenMP.
THREAD_ENV: dict[str, str] = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
                              "MKL_NUM_THREADS": "1"}
#: Metrics that measure the machine rather than the run (left out of comparisons).
TIMING_METRICS: frozenset[str] = frozenset({
    "tick_time_p50", "tick_time_p95", "tick_time_p99", "tick_time_max", "solve_time_p50",
    "solve_time_p99", "deadline_misses"})

R = TypeVar("R")


@dataclass(frozen=True)
class RunSpec:
    """One closed-loop run as plain data.

    Attributes:
        robot: a preset name or a description (:func:`mpc.robots.from_dict`).
        trajectory: ``{"shape": "circle"|"figure8", "heading": "fixed"|"tangent"|"spin"}``
            with ``"period"`` [s] or ``"ratio"`` (peak wheel speed / limit), or
            ``{"times": [...], "poses": [[x, y, theta], ...]}`` (waypoints), or
            ``{"samples": {"times", "poses", "velocities", "accelerations"}}`` (a
            :class:`~trajectories.SampledTrajectory`, e.g. a Choreo file's).
        controller: a benchmark controller name (:data:`benchmarks.scenarios.CONTROLLERS`).
        labels: layout, trajectory, heading and speed names copied into the result.
        settings: horizon, dt and polygon sides.
        duration: simulated seconds; None: two laps at the target pace after ``skip``.
        weights: MPC cost weights (names of :class:`mpc.model.weights.Weights`).
        delay_ticks: MPC only, the command latency the controller compensates.
        plant: a plant preset name or the fields of :class:`mpc.sim.PlantConfig`.
        command_ramp: MPC only, tell it that the wheel loops ramp each command over the tick
            (``Controller(command_ramp=...)``); None: on the motor plant, whose loops do.
        initial_offset: the true start pose minus the reference's at t = 0 (world frame,
            [m, m, rad]); None: on the reference.
        optimal_lap: the scenario's time-optimal lap [s] (:func:`optimal_lap`, computed once
            per scenario by the caller); None: no yardstick (durations from the period).
        series: pack the time series (the benchmark's results) or the metrics only.
    """

    robot: str | Mapping[str, Any]
    trajectory: Mapping[str, Any]
    controller: str
    labels: Mapping[str, str] = field(default_factory=dict)
    settings: Settings = Settings()
    duration: float | None = None
    skip: float = 2.0
    weights: Mapping[str, Any] | None = None
    delay_ticks: int = 0
    plant: str | Mapping[str, Any] = "ideal"
    command_ramp: bool | None = None
    seed: int | None = 0
    initial_offset: tuple[float, float, float] | None = None
    optimal_lap: float | None = None
    series: bool = False


def build_robot(spec: str | Mapping[str, Any]) -> Robot:
    if isinstance(spec, str):
        return preset(spec)
    if "motor_preset" in spec:
        return motor_preset(str(spec["motor_preset"]))
    return from_dict({k: v for k, v in spec.items() if v is not None})


def build_trajectory(spec: Mapping[str, Any], robot: Robot) -> Trajectory:
    """The reference of a trajectory spec (see :class:`RunSpec`)."""
    if "times" in spec:
        return Waypoints(spec["times"], spec["poses"])
    if "samples" in spec:  # e.g. a Choreo file's samples (theta as sampled)
        samples = spec["samples"]
        return SampledTrajectory(samples["times"], samples["poses"], samples["velocities"],
                                 samples.get("accelerations"))
    name, heading = spec.get("shape"), spec.get("heading", "fixed")
    if name not in ALL_TRAJECTORIES or heading not in HEADINGS:
        raise ScenarioError(f"unknown trajectory spec {dict(spec)!r}")
    if "ratio" in spec:
        return reference(name, heading, robot, float(spec["ratio"]))
    return shape(name, heading)(float(spec["period"]))


def build_controller(spec: RunSpec, robot: Robot, trajectory: Trajectory) -> TrackingController:
    """The controller of a run: by benchmark name, with the spec's weights and latency; an
    MPC on the motor plant is told that its wheel loops ramp each command over the tick
    (``Controller(command_ramp=True)``) unless the spec says otherwise."""
    name, settings = spec.controller, spec.settings
    if name not in MPC_CONTROLLERS:
        if spec.weights is not None or spec.delay_ticks or spec.command_ramp is not None:
            raise ScenarioError(f"weights, delay_ticks and command_ramp apply to MPC "
                                f"controllers, not {name}")
        return controller(name, robot, trajectory, settings)
    plant = _plant(spec.plant)
    ramp = spec.command_ramp
    if ramp is None:
        ramp = isinstance(PLANT_PRESETS.get(plant) if isinstance(plant, str) else plant,
                          MotorPlantConfig)
    return mpc_controller(name, robot, trajectory, settings, spec.weights, spec.delay_ticks,
                          command_ramp=ramp)


def _plant(spec: str | Mapping[str, Any]) -> str | PlantConfig:
    return spec if isinstance(spec, str) else PlantConfig(**spec)


def _simulate(spec: RunSpec) -> dict[str, Any]:
    robot = build_robot(spec.robot)
    trajectory = build_trajectory(spec.trajectory, robot)
    labels = dict(spec.labels)
    scenario = Scenario(labels.get("layout", robot.name), robot,
                        labels.get("trajectory", str(spec.trajectory.get("shape", "csv"))),
                        trajectory, labels.get("speed", "-"), labels.get("heading", "-"))
    # the caller computed the yardstick once per scenario (optimal_lap); cached_property
    # keeps its value in the instance dict, so priming it skips the retiming solve here
    vars(scenario)["optimal_lap"] = spec.optimal_lap
    length = spec.duration or default_duration(scenario, spec.skip)
    control = build_controller(spec, robot, trajectory)
    start = (None if spec.initial_offset is None
             else trajectory.sample(0.0).pose + np.asarray(spec.initial_offset, dtype=float))
    result = simulate(control, length, initial_pose=start, plant=_plant(spec.plant),
                      seed=spec.seed)
    # the window the metrics and the report share: a default duration is laps after the
    # skip (all of it kept); a given one keeps at least its second half
    skip = spec.skip if spec.duration is None else min(spec.skip, 0.5 * length)
    metrics = result.metrics(skip=skip)
    if spec.series:
        return pack_run(scenario, spec.controller, metrics, result, skip)
    return {**labels, "controller": spec.controller, "seed": spec.seed,
            "ticks": len(result.time), "metrics": metrics}


def execute(spec: RunSpec) -> tuple[dict[str, Any], float]:
    """Run one spec; return its result and the seconds it took. Never raises: an exception
    becomes ``{labels..., "controller", "error": "Type: message", "traceback"}``."""
    for name, value in THREAD_ENV.items():  # for any process this run starts
        os.environ.setdefault(name, value)
    started = time.perf_counter()
    try:
        result = _simulate(spec)
    except Exception as error:  # noqa: BLE001  (a failed run is a result, not a crash)
        result = {**_failed(spec, error), "traceback": traceback.format_exc(limit=6)}
    return result, time.perf_counter() - started


def _failed(spec: RunSpec, error: BaseException) -> dict[str, Any]:
    return {**spec.labels, "controller": spec.controller, "seed": spec.seed,
            "error": f"{type(error).__name__}: {error}"}


def comparable(result: Mapping[str, Any]) -> dict[str, Any]:
    """A result without what measures the machine (tick and solve times): equal across
    executors, run for run, for the same specs."""
    out = {k: v for k, v in result.items() if k not in ("series", "traceback")}
    if isinstance(result.get("metrics"), Mapping):
        out["metrics"] = {k: v for k, v in result["metrics"].items()
                          if k not in TIMING_METRICS}
    if isinstance(result.get("series"), Mapping):
        out["series"] = {k: v for k, v in result["series"].items()
                         if k not in ("tick_time", "solve_time")}
    return out


def optimal_lap(robot: str | Mapping[str, Any], trajectory: Mapping[str, Any]) -> float | None:
    """The time-optimal lap of a spec's reference under its robot's limits [s] (the
    benchmark's yardstick, :attr:`Scenario.optimal_lap`); None if there is none."""
    built = build_robot(robot)
    return Scenario("", built, "", build_trajectory(trajectory, built), "", "").optimal_lap


def _ticks(spec: RunSpec) -> float:
    """The ticks a run simulates (its duration, or the default's estimate from the spec)."""
    period = spec.trajectory.get("period") or 10.0
    target = max(period, spec.optimal_lap or period)
    length = spec.duration or max(6.0, 2.2 * target + spec.skip)
    return length / spec.settings.dt


def _cost(spec: RunSpec) -> float:
    """A rough relative cost, to start the longest runs first (shorter tail)."""
    return _ticks(spec) * prior_factor(spec.controller) * spec.settings.horizon


def start_order(specs: Sequence[RunSpec]) -> list[int]:
    """The order a pool starts ``specs`` in: the costliest run of each controller first
    (so that the ETA has seen every kind early), then the rest longest first."""
    order = sorted(range(len(specs)), key=lambda i: -_cost(specs[i]))
    first: dict[str, int] = {}
    for index in order:
        first.setdefault(specs[index].controller, index)
    leading = set(first.values())
    return [*first.values(), *(index for index in order if index not in leading)]


def _worker_init() -> None:
    os.environ.update(THREAD_ENV)


def _blas_env() -> dict[str, str | None]:
    return {name: os.environ.get(name) for name in THREAD_ENV}


def check_pool_options(workers: int | None, scheduler: str | None) -> None:
    """``--workers`` and ``--scheduler`` as :class:`RunPool` takes them, or ScenarioError
    (callers check them before they create an output folder)."""
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ScenarioError(f"--workers must be an integer >= 1, got {workers!r}")
    if workers is not None and scheduler is not None:
        raise ScenarioError("give --workers or --scheduler, not both")


class RunPool:
    """Runs specs in this process (``workers=1``), on ``workers`` local processes (default:
    the machine's cores) or on the Dask cluster at ``scheduler`` (``tcp://host:port``).

    A batch of one run stays in this process on the local path. Use as a context manager,
    or call :meth:`close`.
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 timeout: float = 10.0) -> None:
        check_pool_options(workers, scheduler)
        self.workers = workers or os.cpu_count() or 1
        self.scheduler, self.timeout = scheduler, timeout  # [s] to reach the scheduler
        self._executor: cf.Executor | None = None
        self._client: Any = None
        self._saved_env: dict[str, str | None] = {}
        self.notes: list[str] = []  # what the pool found on starting (Dask worker settings)

    def __enter__(self) -> RunPool:
        if self.scheduler is not None:
            self._connect(self.scheduler)
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def description(self) -> str:
        if self.scheduler is not None:
            return f"Dask cluster at {self.scheduler} ({self.workers} workers)"
        return "this process" if self.workers == 1 else f"{self.workers} local processes"

    def _connect(self, address: str) -> None:
        try:
            from distributed import Client
        except ImportError:
            raise ScenarioError("--scheduler needs dask.distributed: "
                                "pip install 'holonomic-mpc[sweeps]'") from None
        try:
            self._client = Client(address, timeout=self.timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as error:
            raise ScenarioError(f"--scheduler: cannot reach the Dask scheduler at {address}: "
                                f"{error}") from None
        envs = self._client.run(_blas_env)
        self.workers = max(1, len(envs))
        for worker, env in sorted(envs.items()):
            if any(env.get(name) != "1" for name in THREAD_ENV):
                self.notes.append(f"dask worker {worker} has {env}: BLAS may use several "
                                  f"threads there (start workers with a nanny, the default)")
        self._executor = self._client.get_executor(pure=False)

    def _pool(self) -> cf.Executor:
        if self._executor is None:
            self._saved_env = {name: os.environ.get(name) for name in THREAD_ENV}
            os.environ.update(THREAD_ENV)  # inherited by every worker spawned from now on
            self._executor = cf.ProcessPoolExecutor(
                self.workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_worker_init)
        return self._executor

    def _local(self, count: int) -> bool:
        return self.scheduler is None and (self.workers == 1 or count == 1)

    def map(self, fn: Callable[..., R], items: Sequence[tuple[Any, ...]]) -> list[R]:
        """``[fn(*item) for item in items]`` on the pool, in order (``fn`` should not raise:
        its exception propagates)."""
        if self._local(len(items)):
            return [fn(*item) for item in items]
        futures = [self._pool().submit(fn, *item) for item in items]
        try:
            return [future.result() for future in futures]
        except BrokenProcessPool as error:
            raise ScenarioError(f"a worker process died ({error}); a script that starts a pool "
                                "must guard its entry with if __name__ == '__main__'") from None

    def run(self, specs: Sequence[RunSpec], log: Callable[[str], None] | None = None,
            line: Callable[[Mapping[str, Any]], str] | None = None,
            estimator: EtaEstimator | None = None) -> list[dict[str, Any]]:
        """Every spec's result, in the order of ``specs``; with ``log`` and ``line``, a line
        per run as it finishes: ``[done/total] <line(result)> (seconds)``. ``estimator``
        (if any) is given the runs in the order they start and each one's time."""
        results: list[dict[str, Any]] = [{}] * len(specs)
        local = self._local(len(specs))
        order = list(range(len(specs))) if local else start_order(specs)
        position = {index: place for place, index in enumerate(order)}
        if estimator is not None:
            estimator.plan_runs([PlannedRun(specs[i].controller, _ticks(specs[i]))
                                 for i in order], 1 if local else self.workers)
        done = 0

        def finished(index: int, outcome: tuple[dict[str, Any], float]) -> None:
            nonlocal done
            results[index], seconds = outcome
            done += 1
            if estimator is not None:
                estimator.run_finished(position[index], seconds)
            if log is not None:
                text = (line or _names)(results[index])
                log(f"[{done:{len(str(len(specs)))}d}/{len(specs)}] {text} ({seconds:.1f} s)")

        if local:
            for index, spec in enumerate(specs):
                finished(index, execute(spec))
            return results
        futures = {self._pool().submit(execute, specs[i]): i for i in order}
        try:
            for future in cf.as_completed(futures):
                finished(futures[future], _outcome(future, specs[futures[future]]))
        except BaseException:
            for future in futures:
                future.cancel()
            raise
        return results

    def close(self) -> None:
        if self._executor is not None and self._client is None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            os.environ.update({k: v for k, v in self._saved_env.items() if v is not None})
            for name in (k for k, v in self._saved_env.items() if v is None):
                del os.environ[name]
        if self._client is not None:
            self._client.close()
        self._executor, self._client = None, None


def _names(result: Mapping[str, Any]) -> str:
    """The default progress text: the run's labels and controller, and any error."""
    names = " ".join(v for k, v in result.items()
                     if isinstance(v, str) and k not in ("error", "traceback"))
    return f"{names} FAILED {result['error']}" if "error" in result else names


def _outcome(future: cf.Future[Any], spec: RunSpec) -> tuple[dict[str, Any], float]:
    """A finished future's result, or an error entry if the worker itself was lost."""
    try:
        return future.result()  # type: ignore[no-any-return]
    except Exception as error:  # noqa: BLE001  (a lost worker fails its runs, not the sweep)
        return _failed(spec, error), 0.0


__all__ = ["THREAD_ENV", "TIMING_METRICS", "RunPool", "RunSpec", "build_controller",
           "build_robot", "build_trajectory", "comparable", "execute", "optimal_lap"]
