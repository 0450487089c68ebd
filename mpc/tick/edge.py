"""The compiled tick behind :meth:`Controller.step <mpc.control.Controller.step>`: Python
only at the edges (the checks at the front door, the reference sampled from the
trajectory, the :class:`~mpc.control.command.Command` built, the log), every number in
between from the tick's graphs (:mod:`mpc.tick.graphs`), compiled (:class:`NativeTick`)
or in CasADi's virtual machine (:class:`VirtualTick`).

``Controller(..., compiled=True)`` runs the compiled library where a C compiler works and
the virtual machine where none does; ``compiled="virtual-machine"`` the virtual machine
always. :attr:`CompiledTick.path` (``Controller.tick_path``) says which.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.command import Command, Status
from mpc.control.lookahead import Lookahead
from mpc.control.measurements import check_pose, check_steer_angles, check_time
from mpc.errors import ControllerError
from mpc.model.jit import JitError
from mpc.model.tracking import TrackingModel
from mpc.plausibility import check_heading
from mpc.robots.base import Robot, ScalarWheels
from mpc.solvers import TrackingSolver
from mpc.tick import reuse, screen
from mpc.tick.build import compiled_library
from mpc.tick.graphs import UNPLANNED, TickGraphs, build_graphs
from mpc.tick.path import PathGraphs, build_path_graphs
from mpc.tick.path_edge import sample_at
from mpc.tick.path_runner import PathRunner, path_runner
from mpc.tick.runners import (
    CLAMPED,
    FAILURES,
    FLAG,
    ITERATIONS,
    REBUILT,
    SOLVE_TIME,
    STATUS,
    TWIST,
    NativeTick,
    TickRunner,
    VirtualTick,
)
from mpc.tick.support import check_supported
from trajectories import Trajectory, TrajectoryError


class Owner(Protocol):
    """What the tick reads of its :class:`~mpc.control.Controller` (not imported: the
    controller imports this module)."""

    robot: Robot
    model: TrackingModel
    dt: float
    mode: str
    delay_ticks: int
    command_ramp: bool
    allow_unusual: bool
    polygon_sides: int | None

    @property
    def solver(self) -> TrackingSolver: ...

    @property
    def trajectory(self) -> Trajectory: ...

#: ``compiled=`` values: the Python tick, the compiled one (the virtual machine where no
#: compiler works), the virtual machine.
COMPILED_CHOICES: tuple[object, ...] = (False, True, "virtual-machine")

#: Fallbacks starting and ending (the same log as the Python tick's).
log = logging.getLogger("mpc.control")

_STATUSES = (Status.SOLVED, Status.PREVIOUS_PLAN, Status.FEEDFORWARD, Status.STOPPING)
_SOLVER_STATUS = {1: "solved", 2: "solved (soft)", -1: "infeasible", -2: "cycling",
                  -3: "unbounded", -4: "maximum iterations reached", -5: "nonconvex",
                  -6: "initial point infeasible"}


def check_compiled(compiled: object) -> None:
    """``compiled`` one of :data:`COMPILED_CHOICES`, else ControllerError."""
    if not any(compiled is choice or (isinstance(choice, str) and compiled == choice)
               for choice in COMPILED_CHOICES):
        raise ControllerError(f"compiled must be False, True or 'virtual-machine', got "
                              f"{compiled!r}")


class CompiledTick:
    """The tick of ``controller`` (built by it) run by the graphs.

    Args:
        controller: the controller whose model, robot, settings and trajectory it runs.
        compiled: True (compiled where a C compiler works, else the virtual machine) or
            ``"virtual-machine"``.
        max_iter: daqp iterations per solve at most (None: 1000, as the Python tick).
        time_limit: must be 0 (the casadi wheel's daqp has no time limit).
    """

    def __init__(self, controller: Owner, compiled: bool | str, max_iter: int | None,
                 time_limit: float) -> None:
        check_compiled(compiled)
        robot = controller.robot
        wheels = check_supported(robot, controller.solver.name, controller.mode,
                                 controller.delay_ticks, controller.command_ramp, time_limit,
                                 controller.polygon_sides)
        self._controller = controller
        path_mode = controller.mode == "path"
        graphs: TickGraphs
        if path_mode:  # (check_supported refuses path mode on swerve)
            assert isinstance(wheels, ScalarWheels)
            graphs = build_path_graphs(controller.model, wheels, controller.dt)
        else:
            graphs = build_graphs(controller.model, wheels, controller.dt)
        #: The tick's graphs (:func:`~mpc.tick.graphs.build_graphs`).
        self.graphs = graphs
        iterations = 1000 if max_iter is None else int(max_iter)
        budgeted = max_iter is not None
        #: daqp's iteration limit, and whether it was chosen (no second solve then).
        self.max_iter, self.budgeted = iterations, budgeted
        #: The Hessian is rebuilt when the linearisation drifted beyond this
        #: (:data:`mpc.tick.reuse.REBUILD_DRIFT` when the controller was built).
        self.rebuild_drift = float(reuse.REBUILD_DRIFT)
        #: The compiled library's row screen (:mod:`mpc.tick.screen`: rows left out of
        #: daqp's problem after this many ticks unneeded; 0: none).
        self.screen_after = screen.screen_after(graphs.screen_places)
        #: Hessians built so far (for benchmarks: the rest of the ticks kept one).
        self.rebuilds = 0
        runner: TickRunner | None = None
        #: Why the compiled library is not used (None when it is, or was not asked for).
        self.compile_error: str | None = None
        if compiled is True:
            try:
                library, private = compiled_library(graphs)
                try:
                    runner = NativeTick(library, graphs, iterations, budgeted,
                                        self.rebuild_drift, self.screen_after)
                finally:
                    if private:  # (loaded: the file is no longer needed)
                        library.unlink(missing_ok=True)
            except (JitError, OSError) as error:
                self.compile_error = str(error)
                log.info("compiled tick: no compiler works (%s); the virtual machine runs it",
                         error)
        self._runner: TickRunner = runner or VirtualTick(graphs, iterations, budgeted,
                                                         self.rebuild_drift)
        #: Path mode's calls (:mod:`mpc.tick.path_runner`: the progress in the graphs, the
        #: reference sampled at the edge, :mod:`mpc.tick.path_edge`), else None.
        self._path: PathRunner | None = (
            path_runner(self._runner, graphs) if isinstance(graphs, PathGraphs) else None)
        self._wheels = graphs.wheels
        self._dt = float(controller.dt)
        self._horizon = graphs.horizon
        self._trajectory: Trajectory | None = None
        self._lookahead: Lookahead | None = None
        self._first_tick = True
        self._failures = 0
        self._measured: FloatArray | None = None  # casters: this tick's measured angles

    @property
    def path(self) -> str:
        """``"compiled"`` or ``"virtual-machine"``: what runs the tick."""
        return self._runner.path

    def reset(self, last: FloatArray, steer_angles: FloatArray | None = None) -> None:
        """Forget the plan, failures and active set; ``last`` (3,) the twist executing
        (the controller's, checked and scaled into the limits by its ``reset``); swerve:
        ``steer_angles`` (n,) [rad], the modules' angles now (kept if None)."""
        self._runner.reset(np.asarray(last, dtype=float))
        if steer_angles is not None and self.graphs.steer:
            self._runner.set_steer(np.asarray(steer_angles, dtype=float))
        self._first_tick = not np.asarray(last).any()
        self._failures = 0
        if self._path is not None:
            self._path.reset()

    def _window(self, t: float) -> tuple[FloatArray, FloatArray, str | None]:
        """The reference's poses and world velocities at the stage times (N+1, 3), NaN with
        the reason when the trajectory cannot be sampled there."""
        controller = self._controller
        trajectory = controller.trajectory
        if trajectory is not self._trajectory or self._lookahead is None:
            self._trajectory = trajectory
            self._lookahead = Lookahead(trajectory, controller.model.offsets, controller.dt)
        try:
            poses, velocities = self._lookahead.window(t)
        except TrajectoryError as error:  # the reference, not the caller: fall back
            nan = np.full((self._horizon + 1, 3), math.nan)
            return nan, nan.copy(), f"reference failed: {error}"
        return poses, velocities, None

    def step(self, pose: ArrayLike, t: float, steer_angles: ArrayLike | None = None) -> Command:
        """One tick (see :meth:`Controller.step <mpc.control.Controller.step>`)."""
        start = time.perf_counter()
        controller = self._controller
        measured = check_pose(pose, controller.allow_unusual)
        t_now = check_time(t)
        measured_steer = check_steer_angles(controller.robot, steer_angles)
        if measured_steer is not None:  # casters: the tick starts from the measured angles
            self._runner.set_steer(measured_steer)
        self._measured = measured_steer
        if self._path is not None:
            return self._path_step(measured, t_now, start)
        poses, velocities, failure = self._window(t_now)
        if failure is None and self._first_tick:
            check_heading("pose", float(measured[2]), float(poses[0, 2]),
                          controller.allow_unusual, ControllerError)
            self._first_tick = False
        out = self._runner.step(measured, poses, velocities)
        return self._command(out, start, t_now, failure, t_now, int(out[ITERATIONS]),
                             float(out[SOLVE_TIME]))

    def _path_step(self, measured: FloatArray, t_now: float, start: float) -> Command:
        """Path mode's tick: the reference sampled at the times the graphs give (the
        progress guess; :mod:`mpc.tick.path_runner`), solved again while the progress
        settles after a start with no plan (the Python tick's warm-up)."""
        path = self._path
        assert path is not None
        trajectory = self._controller.trajectory
        heading = float(measured[2])
        times = path.times(t_now)
        reference_time = float(times[0])
        samples, failure = sample_at(trajectory, times)
        if failure is not None:  # the reference, not the caller: fall back
            reference_time = t_now
        elif self._first_tick:
            check_heading("pose", heading, float(samples[0][0, 2]),
                          self._controller.allow_unusual, ControllerError)
            self._first_tick = False
        out = path.step(measured, *samples)
        iterations, seconds = int(out[ITERATIONS]), float(out[SOLVE_TIME])
        while failure is None and (again := path.again()) is not None:
            samples, failed = sample_at(trajectory, again)
            if failed is not None:  # (PathProgress.refine: the last solve stands)
                break
            self.rebuilds += int(out[REBUILT])
            out = path.step(measured, *samples)
            iterations += int(out[ITERATIONS])
            seconds += float(out[SOLVE_TIME])
        return self._command(out, start, t_now, failure, reference_time, iterations, seconds)

    def _command(self, out: FloatArray, start: float, t_now: float, failure: str | None,
                 reference_time: float, iterations: int, seconds: float) -> Command:
        """The :class:`~mpc.control.command.Command` of a tick's output array."""
        status = _STATUSES[int(out[STATUS])]
        flag = int(out[FLAG])
        failures = int(out[FAILURES])
        self.rebuilds += int(out[REBUILT])
        self._log(failures, failure or _SOLVER_STATUS.get(flag, f"daqp exit flag {flag}"))
        speeds = TWIST + 3
        # the plan's poses, then (swerve) the steer angles, (path mode) the progress, (a
        # motor model) the feedforward: mpc_tick.h's layout
        poses = speeds + self._wheels
        steer = poses + 3 * (self._horizon + 1)
        feedforward = steer + self.graphs.steer + int(getattr(self.graphs, "progress", 0))
        forces, torques, currents, vectors = self._feedforward(
            out[feedforward:feedforward + self.graphs.feedforward])
        steer_rates = None  # casters: the rates that turn the measured angles to the sent
        if self._measured is not None:
            steer_rates = (out[steer:steer + self.graphs.steer] - self._measured) / self._dt
        return Command(
            wheel_speeds=out[speeds:poses].copy(), twist=out[TWIST:speeds].copy(),
            steer_angles=out[steer:steer + self.graphs.steer].copy() if self.graphs.steer
            else None,
            predicted_poses=out[poses:steer].reshape(self._horizon + 1, 3).copy(),
            status=status,
            solver_status=(failure if flag == UNPLANNED and failure
                           else _SOLVER_STATUS.get(flag, f"daqp exit flag {flag}")),
            solve_time=seconds, tick_time=time.perf_counter() - start,
            iterations=iterations, consecutive_failures=failures,
            clamped=bool(out[CLAMPED]), reference_time=reference_time,
            lag=t_now - reference_time, wheel_forces=forces, motor_torques=torques,
            motor_currents=currents, contact_forces=vectors, steer_rates=steer_rates)

    def _feedforward(self, values: FloatArray) -> tuple[FloatArray | None, ...]:
        """``Command``'s motor feedforward fields (wheel forces, motor torques and currents,
        contact force vectors) from the output's feedforward part (motor-aware robots:
        :func:`mpc.tick.motors.motor_feedforward`'s layout; None otherwise)."""
        if not values.size:
            return None, None, None, None
        n = self._wheels
        return (values[:n].copy(), values[n:2 * n].copy(), values[2 * n:3 * n].copy(),
                values[3 * n:5 * n].reshape(n, 2).copy())

    def _log(self, failures: int, reason: str) -> None:
        """Fallbacks starting and ending, as :class:`~mpc.control.fallback.FallbackPolicy`
        logs them."""
        if failures == 1:
            log.warning("falling back: %s", reason)
        elif failures == 0 and self._failures:
            log.info("solved again after %d failed ticks", self._failures)
        self._failures = failures
