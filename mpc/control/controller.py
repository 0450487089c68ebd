"""The embeddable tracking controller: ``Controller(robot, trajectory).step(pose, t)``."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.clamp import clamp_command
from mpc.control.command import Command, Status
from mpc.control.delay import DelayCompensator
from mpc.control.fallback import FallbackPolicy
from mpc.control.measurements import check_pose, check_steer_angles, check_time
from mpc.control.settings import (
    MODES,
    SOLVERS,
    check_jit,
    check_mode,
    check_progress_rate,
    check_stage_dt,
    check_step,
    check_trajectory,
    make_solver,
)
from mpc.control.timing import PathProgress, ReferenceWindow, TimeIndexed
from mpc.control.warm_start import WarmStart
from mpc.control.wheel_output import feedforward_fields, prepare_commands, wheel_commands
from mpc.errors import ControllerError
from mpc.model.jit import JitError, jitted
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from mpc.model.weights import Weights, make_weights
from mpc.plausibility import check_heading
from mpc.profiling import TickProfile
from mpc.robots.base import Robot
from mpc.robots.drive.motor_step import first_step_feedforward
from mpc.robots.limits import DEFAULT_POLYGON_SIDES
from mpc.solvers import SolveResult
from mpc.validation import (
    MAX_DELAY_TICKS,
    MAX_HORIZON,
    checked_arguments,
    finite_vector,
    flag,
    integer_in,
)
from trajectories import Trajectory, TrajectoryError

if TYPE_CHECKING:
    from mpc.tick import CompiledTick

__all__ = ["DEFAULT_POLYGON_SIDES", "MEASURED_SLACK", "MODES", "SOLVERS", "Controller",
           "register_controller"]

#: How far beyond the wheels' speed limits a measured ``last_twist`` (:meth:`Controller.reset`)
#: may be and be scaled into them (odometry noise at top speed); further is refused (a
#: twist in the wrong units, or a robot pushed far past what its wheels drive).
MEASURED_SLACK = 0.10


#: Controllers of wheel types whose joint states each tick takes besides the pose (sliders),
#: by :attr:`~mpc.robots.Robot.kind`: ``Controller(robot, ...)`` builds one of these for
#: such a robot. Registered by their modules (:func:`register_controller`).
_JOINT_CONTROLLERS: dict[str, type[Controller]] = {}


def register_controller(kind: str, controller: type[Controller]) -> None:
    """Make ``Controller(robot, ...)`` of a robot of ``kind`` a ``controller`` (a subclass
    of :class:`Controller` taking the same arguments)."""
    _JOINT_CONTROLLERS[kind] = controller


class Controller:
    """Model-predictive tracking of a reference trajectory within wheel limits.

    Each :meth:`step` plans ``horizon`` stages from the measured pose (the first
    one control tick of ``dt`` seconds, the others ``stage_dt``) and returns the
    first twist as wheel commands for the next tick. The command
    never exceeds a wheel's speed or acceleration limit: the solver plans
    within them and a final clamp (:func:`~mpc.control.clamp.clamp_command`)
    removes solver tolerance. If the solver fails, the command comes from
    the fallback policy (:mod:`mpc.control.fallback`: the previous plan, the
    feedforward scaled into the limits, a stop ramp); ``Command.status`` says which.

    Modes: ``"time"`` tracks the reference pose at ``t`` (the default);
    ``"path"`` follows the reference's path with the progress along it planned
    too (contouring, :class:`~mpc.control.timing.PathProgress`): on time where
    the reference is feasible, as fast as the wheels allow and on the path
    where it is not, never ahead of the reference's own timing.
    ``Command.reference_time`` is the reference time being tracked and
    ``Command.lag`` how far it trails ``t``.

    Swerve steering rate: the cost penalises the change of every module's
    ground velocity between ticks (``Weights.module_rate``), in both solvers,
    so module directions change smoothly; steer angles follow the 90-degree
    flip rule against the previous command.

    Args:
        robot: the drive layout and its wheel limits.
        trajectory: the reference to track.
        horizon: stages in the plan, >= 1.
        dt: control interval [s], > 0: the tick of :meth:`step`.
        stage_dt: duration of the plan's stages after the first [s], >= ``dt``; the first
            stage is one tick (the command sent). Longer stages look further ahead for the
            same work a tick. Default: ``2 dt`` in time mode (the defaults plan 1.95 s
            ahead: beyond the wheel limits that foresight keeps the robot much closer to a
            reference it cannot follow), ``dt`` in path mode (the progress keeps the
            reference within reach, and finer stages follow the path's bends closer);
            measured in docs/benchmarks/index.md, "When the reference is too fast".
        solver: ``"daqp"`` (the fast path: real-time iteration on the condensed QP,
            :mod:`mpc.solvers.dense`), ``"osqp"`` (real-time iteration on the sparse QP)
            or ``"ipopt"`` (the exact NLP).
        weights: :class:`~mpc.model.weights.Weights` or a dict of overrides.
        polygon_sides: QP paths only: take each swerve module's speed and acceleration
            disks as a constant polygon of this many sides (even, >= 4) instead of the
            default: the speed disk's faces turned each tick to the planned direction (the
            disk linearised: exact at a converged plan), the acceleration disk a constant
            16-gon; casters and modules with an axle offset always take a polygon (default
            16 sides). IPOPT uses the exact disks.
        max_iter: solver iterations per tick at most (default 1000 daqp, 500 OSQP,
            100 IPOPT).
        time_limit: solver time per tick at most [s]; 0 for none. Without either, a tick
            that fails from a cold guess (the reference's twists: the first tick after
            construction or :meth:`reset`, and every tick after a failed one) is solved
            once more from the last command held: at most two solves a tick, each within
            the solver's default iterations.
        delay_ticks: known command latency in whole ticks; the controller
            predicts the pose forward through the commands already sent.
        command_ramp: the drive ramps each command from the last one over the tick (a
            first-order hold: :class:`~mpc.sim.motor_plant.MotorPlant`'s wheel loops, a
            motion-profiled velocity loop) instead of stepping to it. Such a drive is a
            held one half a tick late: the controller plans from half a tick ahead
            (:mod:`mpc.control.delay`). Default False: a command acts at once.
        mode: ``"time"`` or ``"path"`` (see above).
        max_progress_rate: path mode, how much faster than the reference the progress may
            run while catching up (>= 1).
        time_scaling: deprecated; ``True`` is ``mode="path"``.
        jit: ``solver="daqp"`` only: compile the tick's CasADi functions to C with the
            system's C compiler (CasADi's JIT: gcc, or ``$CC``), about 1.5 s the first
            time a problem is built (~0.1 s after: the libraries are cached,
            :func:`~mpc.model.jit.cache_folder`), for a quicker tick at N = 20
            (docs/design/jit.md); the same commands. ``True``: a
            :class:`~mpc.errors.ControllerError` if it cannot compile; ``"auto"``: compiled
            where a compiler works, CasADi's virtual machine otherwise (and for the other
            solvers); :attr:`jit` says which.
        allow_unusual: accept measured headings that look like degrees: one more than a
            turn from both 0 and the reference's heading at the first tick of a start from
            rest (after construction, :meth:`reset` without a moving ``last_twist``, a
            new trajectory while at rest), or beyond 10,000 turns at any tick
            (:mod:`mpc.plausibility`). Without it they raise ControllerError. A heading
            is used modulo whole turns, so wrapping a multi-turn one
            (``math.remainder(theta, 2 * math.pi)``) changes no command.
        compiled: run the tick as one program (:mod:`mpc.tick`, opt-in; constant-Jacobian
            robots, with or without a motor model, and swerve without axle offset,
            steering range or motor model; time mode, and path mode on constant-Jacobian
            robots without a motor model; ``solver="daqp"`` for now, else a
            ControllerError naming what is supported): ``True`` compiles it to C (seconds
            the first time, then cached) and runs CasADi's virtual machine where no
            compiler works;
            ``"virtual-machine"`` runs the virtual machine. The same commands as the Python
            tick under the same Hessian-reuse rule (docs/guide/compiled-tick.md).
            :attr:`tick_path` says which path runs.
    """

    def __new__(cls, *args: Any, **kwargs: Any) -> Controller:
        robot = args[0] if args else kwargs.get("robot")
        chosen = _JOINT_CONTROLLERS.get(getattr(robot, "kind", "")) if cls is Controller else None
        return super().__new__(chosen or cls)

    @checked_arguments(ControllerError)
    def __init__(
        self,
        robot: Robot,
        trajectory: Trajectory,
        horizon: int = 20,
        dt: float = 0.05,
        solver: str = "daqp",
        weights: Weights | Mapping[str, ArrayLike] | None = None,
        *,
        stage_dt: float | None = None,
        polygon_sides: int | None = None,
        max_iter: int | None = None,
        time_limit: float = 0.0,
        delay_ticks: int = 0,
        command_ramp: bool = False,
        mode: str = "time",
        max_progress_rate: float = 2.0,
        time_scaling: bool | None = None,
        jit: bool | str = False,
        allow_unusual: bool = False,
        compiled: bool | str = False,
    ) -> None:
        if not isinstance(robot, Robot):
            raise ControllerError(f"robot must be an mpc.robots.Robot, got {type(robot).__name__}")
        check_trajectory(trajectory)
        self.robot = robot
        self.horizon = integer_in("horizon", horizon, 1, MAX_HORIZON, ControllerError)
        self.dt = check_step("dt", dt)
        self.delay_ticks = integer_in("delay_ticks", delay_ticks, 0, MAX_DELAY_TICKS,
                                      ControllerError)
        self.command_ramp = flag("command_ramp", command_ramp, ControllerError)
        #: Whether headings that look like degrees are accepted (see the Args).
        self.allow_unusual = flag("allow_unusual", allow_unusual, ControllerError)
        self._first_tick = True  # a start from rest: the heading is checked once
        self.mode = check_mode(mode, time_scaling)
        self.stage_dt = check_stage_dt(stage_dt, self.dt, self.mode)
        self.polygon_sides = polygon_sides  # (checked by the solver; read by mpc.tick)
        rate = check_progress_rate(max_progress_rate)
        self.weights = make_weights(weights)
        self.model = TrackingModel(robot, self.horizon, self.stage_dt, self.weights,
                                   path=self.mode == "path", max_progress_rate=rate,
                                   tick=self.dt)
        compile_terms = check_jit(jit, solver)
        try:
            self.solver = make_solver(self.model, solver, polygon_sides, max_iter, time_limit,
                                      compile_terms)
            self._reference_terms = (jitted(self.model.reference_terms) if compile_terms
                                     else self.model.reference_terms)
        except JitError as error:
            if jit is True:
                raise ControllerError(f"jit=True: {error}") from None
            compile_terms = False  # no compiler that works here: CasADi's virtual machine
            self.solver = make_solver(self.model, solver, polygon_sides, max_iter, time_limit)
            self._reference_terms = self.model.reference_terms
        #: Whether the tick's CasADi terms run as compiled C (``jit=True``, or ``"auto"``
        #: where a compiler worked).
        self.jit = compile_terms
        # (both checked) a first tick solved again would spend two budgets
        self._budgeted = float(time_limit) > 0.0 or max_iter is not None
        prepare_commands(robot, self.dt, self.model.durations)
        self._profile: TickProfile | None = None
        self._tick = TickInput(self.model.layouts)
        self._warm = WarmStart(self._tick, self.model.offsets, self.dt)
        self._fallback = FallbackPolicy(robot, self.model.offsets, self.dt)
        self._delay = DelayCompensator(self.delay_ticks, self.dt, self.command_ramp)
        self._last = np.zeros(3)  # the last command's twist; reset() sets these
        self._steer: FloatArray | None = None  # steered wheels' commanded angles [rad]
        self._compiled: CompiledTick | None = None  # the tick as one program (mpc.tick)
        # what the robot's wheel commands keep between ticks (steering ranges' turns)
        self._memory: dict[str, FloatArray] = {}
        self._set_reference(trajectory)
        self.reset()
        if compiled is not False:
            from mpc.tick import CompiledTick, check_compiled

            check_compiled(compiled)
            self._compiled = CompiledTick(self, compiled, max_iter, time_limit)
            self._compiled.reset(self._last, self._steer)

    @property
    def tick_path(self) -> str:
        """What runs :meth:`step`: ``"python"`` (the default), ``"compiled"`` or
        ``"virtual-machine"`` (``compiled=``)."""
        return "python" if self._compiled is None else self._compiled.path

    @property
    def profile(self) -> TickProfile | None:
        """A :class:`~mpc.profiling.TickProfile` that ``step`` (and the solver) mark, or None."""
        return self._profile

    @profile.setter
    def profile(self, profile: TickProfile | None) -> None:
        if profile is not None and not isinstance(profile, TickProfile):
            raise ControllerError(f"profile must be a TickProfile or None, got {profile!r}")
        self._profile = profile
        self.solver.profile = profile

    def _set_reference(self, trajectory: Trajectory) -> None:
        self._window = ReferenceWindow(trajectory, self.model, self._tick,
                                       self._reference_terms, grid=self.mode == "time")
        self._timing: TimeIndexed | PathProgress = (
            PathProgress(self._window, self.model) if self.mode == "path"
            else TimeIndexed(self._window))

    @property
    def trajectory(self) -> Trajectory:
        return self._window.trajectory

    @trajectory.setter
    def trajectory(self, trajectory: Trajectory) -> None:
        """Track a new trajectory from the next tick on (the plan is dropped, the robot's
        present motion is kept)."""
        check_trajectory(trajectory)
        self._set_reference(trajectory)
        self.reset(self._last, self._steer if not self.robot.steer_states else None)

    def reset(self, last_twist: ArrayLike | None = None,
              steer_angles: ArrayLike | None = None) -> None:
        """Forget the plan, warm start, failures and timing; the robot is at rest unless
        ``last_twist`` (the body twist it is executing now [m/s, m/s, rad/s]) says. A
        measured twist up to :data:`MEASURED_SLACK` beyond the wheels' speed limits
        (odometry noise at top speed) is scaled into them; one further beyond is refused.

        Swerve modules are at ``steer_angles`` [rad] (n,) if given; else a module moving
        in ``last_twist`` points along it (flip rule from its last commanded angle) and one
        at rest where it was last commanded (straight ahead at first)."""
        last = np.zeros(3) if last_twist is None else finite_vector(
            "last_twist", last_twist, 3, "(vx, vy, omega) [m/s, m/s, rad/s]", ControllerError)
        # Casters are left out: their drive joints' speeds depend on the measured steer
        # angles, and the clamp takes them at those angles.
        speeds = self.robot.wheel_magnitudes(last)
        limit = self.robot.max_wheel_speed
        over = speeds - limit * (1.0 + MEASURED_SLACK) > 1e-9 * np.maximum(limit, 1.0)
        if not self.robot.steer_states and np.any(over):
            wheel = int(np.argmax(speeds - limit))
            raise ControllerError(
                f"last_twist {last.tolist()} drives wheel {wheel} at {speeds[wheel]:.6g} "
                f"rad/s, beyond its limit {limit[wheel]:.6g} rad/s by more than "
                f"{MEASURED_SLACK:.0%}: the twist the robot is executing must be one its "
                "wheels can drive")
        if not self.robot.steer_states:
            # Noise at top speed: into the limits. Failed wheels are put at rest first: the
            # rounding they may read would scale the whole twist to 0.
            if self.robot.rest_projector is not None:
                last = self.robot.rest_projector @ last
            last = self.robot.desaturate(last)
        self._last = last
        steer = self._steer if self._steer is not None else self.robot.initial_steer_angles()
        if steer_angles is not None:
            if steer is None or self.robot.steer_states:
                raise ControllerError(f"steer_angles apply to swerve robots only, not "
                                      f"{self.robot.name!r}")
            steer = finite_vector("steer_angles", steer_angles, self.robot.n_wheels,
                                  "[rad], one a module", ControllerError)
        elif steer is not None and last.any() and not self.robot.steer_states:
            steer = self.robot.wheel_commands(last, steer)[1]
        self._steer = steer
        self._memory.clear()
        self._delay.reset(last)
        self._first_tick = not last.any()  # never refuse a tick of a robot in motion
        self._warm.reset()
        self._fallback.reset()
        self._timing.reset()
        self.solver.reset()
        if self._compiled is not None:
            self._compiled.reset(last, self._steer)

    @checked_arguments(ControllerError)
    def step(self, pose: ArrayLike, t: float, steer_angles: ArrayLike | None = None) -> Command:
        """Plan from the measured pose at time ``t`` and return this tick's command.

        Args:
            pose: measured world pose (x, y, theta) [m, m, rad], shape (3,).
            t: the current time on the trajectory's clock [s].
            steer_angles: robots whose steer angles are states (casters, required): the
                measured steer angles [rad], shape (n,). Other robots: must be None (swerve
                modules follow the controller's own commanded angles).
        """
        if self._compiled is not None:
            command = self._compiled.step(pose, t, steer_angles)
            self._last = command.twist
            if command.steer_angles is not None:  # swerve: the angles commanded
                self._steer = command.steer_angles
            return command
        start = time.perf_counter()
        profile = self._profile
        if profile is not None:
            profile.start()
        measured_pose = check_pose(pose, self.allow_unusual)
        x0 = self._delay.predict(measured_pose)
        t_now = check_time(t)
        measured = check_steer_angles(self.robot, steer_angles)
        if measured is not None:
            self._steer = measured
        t_plan = t_now + self._delay.lead
        if profile is not None:
            profile.mark("check and predict")
        try:
            reference_time = self._timing.fill(t_now, t_plan, float(x0[2]))
        except TrajectoryError as error:  # the reference, not the caller: fall back
            reference_time, result = t_plan, self._unplanned(f"reference failed: {error}")
        else:
            if self._first_tick:
                self._check_heading(float(measured_pose[2]))
            result = self._solve(x0)
        status, target, plan = self._outcome(result, x0)
        twist, clamped = clamp_command(self.robot, target, self._last, self.dt, self._steer)
        twist, speeds, steer_rates, steer_prediction, self._steer = wheel_commands(
            self.robot, twist, target, self._steer, measured,
            result.twists if result.success else None, self.dt, self.model.durations,
            self._memory)
        feedforward = first_step_feedforward(self.robot, self._last, twist, self.dt, self._steer)
        self._last = twist
        self._delay.sent(twist)
        if profile is not None:
            profile.mark("clamp and commands")
        return Command(
            wheel_speeds=speeds, twist=twist, steer_angles=self._steer,
            predicted_poses=plan, status=status, solver_status=result.status,
            solve_time=result.solve_time, tick_time=time.perf_counter() - start,
            iterations=result.iterations, consecutive_failures=self._fallback.failures,
            clamped=clamped, reference_time=reference_time, lag=t_plan - reference_time,
            steer_rates=steer_rates, steer_prediction=steer_prediction,
            **feedforward_fields(feedforward))

    def _check_heading(self, heading: float) -> None:
        """The measured heading [rad] at the first tick of a start from rest, against the
        reference's: ControllerError if it is more than a turn from both 0 and the
        reference's (a heading in degrees; :func:`~mpc.plausibility.check_heading`).
        Ticks of a robot in motion are not checked: a heading can legitimately drift
        whole turns from a spinning reference, and a moving robot must not be stopped."""
        reference = float(self._tick.poses_ref[0, 2]) + 2.0 * math.pi * self._window.turns
        check_heading("pose", heading, reference, self.allow_unusual, ControllerError)
        self._first_tick = False

    def _solve(self, x0: FloatArray) -> SolveResult:
        """Plan from ``x0`` on the reference the tick holds (warm started; path mode: solved
        again while the progress settles after a reset)."""
        tick, profile = self._tick, self._profile
        tick.pose[:] = x0
        tick.last_twist[:] = self._last
        if tick.steer_angles is not None and self._steer is not None:
            tick.steer_angles[:] = self._steer
        if profile is not None:
            profile.mark("reference")
        cold = self._warm.cold
        self._warm.fill(x0)
        if profile is not None:
            profile.mark("warm start")
        result = self.solver.solve(tick)
        if not result.success and cold and not self._budgeted:
            # A cold guess is the reference's twists: far from a robot that lags the
            # reference (at rest at the first tick, or behind it after a failure), the
            # limits linearised there can be an empty set (the omni-3 motor preset's first
            # tick; a motor plan whose guess jumps to the reference draws more power than
            # the battery has, and its voltage rows then exclude the robot's own speed).
            # Solve it again from the last command held (not with a time or iteration
            # budget, which it would spend twice).
            self._warm.hold(self._last)
            self.solver.reset()
            result = self.solver.solve(tick)
        while result.success and self._timing.refine(result.progress, float(x0[2])):
            self._warm.store(result.poses, result.twists)  # solve again from this plan
            self._warm.fill(x0, shift=False)
            self.solver.reset()
            result = self.solver.solve(tick)
        if profile is not None:
            profile.mark("solve (rest)")
        return result

    def _outcome(self, result: SolveResult, x0: FloatArray
                 ) -> tuple[Status, FloatArray, FloatArray]:
        """The tick's status, target twist and plan from the solve: the plan's first twist,
        or the fallback policy's with the reference as the plan (``x0`` where that is not
        finite); the warm start, solver and timing told either way."""
        if result.success:
            self._fallback.succeeded(result.twists)
            self._warm.store(result.poses, result.twists)
            self._timing.solved(result.progress)
            return Status.SOLVED, result.twists[0], result.poses
        self._warm.reset()
        self.solver.reset()
        self._timing.solved(None)
        status, target = self._fallback.failed(self._tick.twists_ref[0], result.status)
        plan = self._tick.poses_ref.copy()
        if not math.isfinite(float(plan.sum())):
            plan[:] = x0
        return status, target, plan

    def _unplanned(self, status: str) -> SolveResult:
        """A failed solve that never ran (``status`` says why); the reference in the tick is
        not to be trusted, so the fallback skips its feedforward."""
        self._tick.twists_ref[:] = np.nan
        self._tick.poses_ref[:] = np.nan
        n = self.horizon
        return SolveResult(success=False, status=status, poses=np.full((n + 1, 3), np.nan),
                           twists=np.full((n, 3), np.nan), solve_time=0.0, iterations=0)
