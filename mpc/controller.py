"""The embeddable tracking controller: ``Controller(robot, trajectory).step(pose, t)``."""

from __future__ import annotations

import math
import time
from collections import deque

import numpy as np
from numpy.typing import ArrayLike

from mpc.command import Command, Status
from mpc.errors import ControllerError, is_finite_number, is_integer
from mpc.limits import clamp_command
from mpc.model import TrackingModel
from mpc.nlp import NlpSolver
from mpc.qp import QpSolver
from mpc.reference import ReferenceWindow
from mpc.robots.base import FloatArray, Robot
from mpc.robots.swerve import SwerveRobot
from mpc.solution import TrackingSolver
from mpc.weights import Weights, make_weights
from trajectories import Trajectory

#: Valid ``solver=`` names: the OSQP fast path and the exact IPOPT path.
SOLVERS: tuple[str, ...] = ("osqp", "ipopt")

#: With time scaling, the fraction of a wheel's limit the reference's own
#: feedforward may use; the rest is left for feedback.
REFERENCE_MARGIN = 0.9


class Controller:
    """Model-predictive tracking of a reference trajectory within wheel limits.

    Each :meth:`step` plans ``horizon`` ticks of ``dt`` seconds from the
    measured pose and returns the first twist as wheel speeds. The command
    never exceeds a wheel's speed or acceleration limit: the solver plans
    within them, and a final clamp (:func:`~mpc.limits.clamp_command`: scale
    into the speed limits, then step from the last command only as far as
    the acceleration limits allow) removes solver tolerance. If the solver
    fails, the command comes from the shifted previous plan (while it lasts,
    ``horizon`` ticks), then from the reference feedforward scaled into the
    limits (another ``horizon`` ticks), then from a stop ramp;
    :attr:`Command.status` says which.

    Time scaling (``time_scaling=True``; off by default): if the reference
    window's own feedforward would need more than ``REFERENCE_MARGIN`` of a
    wheel's limit, the controller plays the reference slower (it tracks the
    reference at an internal time that lags ``t``) so that the robot slows
    down on the path instead of chasing a point it cannot reach and cutting
    corners; it catches up when the reference allows. On references inside
    the limits nothing changes. ``Command.reference_time`` says where on the
    reference the controller is.

    Swerve steering rate: modules steer at a finite rate, so the cost
    penalises the change of every module's ground velocity between ticks
    (``Weights.module_rate``), in both solvers. This keeps the module
    directions changing smoothly; the steer angles follow the 90-degree flip
    rule against the previous command.

    Args:
        robot: the drive layout and its wheel limits.
        trajectory: the reference to track.
        horizon: control intervals in the plan, >= 1.
        dt: control interval [s], > 0; also the tick of :meth:`step`.
        solver: ``"osqp"`` (fast real-time iteration) or ``"ipopt"`` (exact NLP).
        weights: :class:`~mpc.weights.Weights` or a dict of overrides.
        polygon_sides: sides of the polygon inside a swerve module's speed
            disk in the QP (even, >= 4; the NLP uses the exact disk).
        max_iter: solver iterations per tick at most (default 500 OSQP, 100 IPOPT).
        time_limit: solver time per tick at most [s]; 0 for none.
        delay_ticks: known command latency in whole ticks; the controller
            predicts the pose forward through the commands already sent.
        time_scaling: slow the reference down where it asks for more than the
            wheels can give (see above); False tracks ``t`` strictly.
    """

    _guess: tuple[FloatArray, FloatArray] | None  # last plan (poses, twists), for the warm start
    _plan_twists: FloatArray | None  # last successful plan's twists, for the fallback
    _previous_t: float | None  # t of the last step, for time scaling

    def __init__(
        self,
        robot: Robot,
        trajectory: Trajectory,
        horizon: int = 20,
        dt: float = 0.05,
        solver: str = "osqp",
        weights: Weights | dict[str, ArrayLike] | None = None,
        *,
        polygon_sides: int = 16,
        max_iter: int | None = None,
        time_limit: float = 0.0,
        delay_ticks: int = 0,
        time_scaling: bool = False,
    ) -> None:
        if not isinstance(robot, Robot):
            raise ControllerError(f"robot must be an mpc.robots.Robot, got {type(robot).__name__}")
        self._check_trajectory(trajectory)
        if not is_integer(horizon) or horizon < 1:
            raise ControllerError(f"horizon must be an integer >= 1, got {horizon!r}")
        if not is_finite_number(dt) or dt <= 0.0:
            raise ControllerError(f"dt must be a finite number of seconds > 0, got {dt!r}")
        if solver not in SOLVERS:
            raise ControllerError(f"unknown solver {solver!r}; expected one of {list(SOLVERS)}")
        if not is_integer(delay_ticks) or delay_ticks < 0:
            raise ControllerError(f"delay_ticks must be an integer >= 0, got {delay_ticks!r}")
        if max_iter is not None and (not is_integer(max_iter) or max_iter < 1):
            raise ControllerError(f"max_iter must be an integer >= 1, got {max_iter!r}")
        if not is_finite_number(time_limit) or time_limit < 0.0:
            raise ControllerError(f"time_limit must be a finite number >= 0, got {time_limit!r}")
        self.robot = robot
        self.horizon = int(horizon)
        self.dt = float(dt)
        self.delay_ticks = int(delay_ticks)
        self.time_scaling = bool(time_scaling)
        self.weights = make_weights(weights)
        self.model = TrackingModel(robot, self.horizon, self.dt, self.weights)
        self.solver: TrackingSolver
        if solver == "osqp":
            self.solver = QpSolver(self.model, polygon_sides=polygon_sides,
                                   max_iter=max_iter or 500, time_limit=time_limit)
        else:
            self.solver = NlpSolver(self.model, max_iter=max_iter or 100, time_limit=time_limit)
        self.solver_name = solver
        self._reference = ReferenceWindow(trajectory, self.model)
        self._jacobian = robot.wheel_blocks[:, 0, :]  # Swedish wheels: speeds = J @ twist
        self._swerve = robot if isinstance(robot, SwerveRobot) else None
        working = robot.max_wheel_speed > 0.0  # a failed wheel does not slow the reference
        self._scaling_blocks = robot.wheel_blocks[working].reshape(-1, 3)
        self._scaling_limits = robot.max_wheel_speed[working]
        self.reset()

    @staticmethod
    def _check_trajectory(trajectory: object) -> None:
        if not isinstance(trajectory, Trajectory):
            raise ControllerError(
                f"trajectory must be a trajectories.Trajectory, got {type(trajectory).__name__}"
            )

    @property
    def trajectory(self) -> Trajectory:
        return self._reference.trajectory

    @trajectory.setter
    def trajectory(self, trajectory: Trajectory) -> None:
        """Track a new trajectory from the next tick on (the plan is dropped)."""
        self._check_trajectory(trajectory)
        self._reference = ReferenceWindow(trajectory, self.model)
        self._plan_twists = None
        self._guess = None
        self._lag = 0.0
        self._previous_t = None
        self.solver.reset()

    def reset(self, last_twist: ArrayLike | None = None) -> None:
        """Forget the plan and warm start; the robot is at rest unless ``last_twist`` says.

        Args:
            last_twist: the body twist the robot is executing now [m/s, m/s, rad/s].
        """
        last = np.zeros(3) if last_twist is None else np.asarray(last_twist, dtype=float)
        if last.shape != (3,) or not np.all(np.isfinite(last)):
            raise ControllerError(f"last_twist must be a finite (3,) twist, got {last_twist!r}")
        self._last = last
        self._sent: deque[FloatArray] = deque([last] * self.delay_ticks, maxlen=self.delay_ticks)
        self._guess = None
        self._plan_twists = None
        self._failures = 0
        self._lag = 0.0  # [s] how far the reference time lags t (time scaling)
        self._previous_t = None
        self._steer = np.zeros(self.robot.n_wheels)  # swerve steer angles commanded last [rad]
        self.solver.reset()

    def step(self, pose: ArrayLike, t: float) -> Command:
        """Plan from the measured pose at time ``t`` and return this tick's command.

        Args:
            pose: measured world pose (x, y, theta) [m, m, rad], shape (3,).
            t: the current time on the trajectory's clock [s].
        """
        start = time.perf_counter()
        x0 = self._check_pose(pose)
        if not is_finite_number(t):
            raise ControllerError(f"t must be a finite time in seconds, got {t!r}")
        for twist in self._sent:  # commands still in the pipe (known delay)
            x0 = self.model.dynamics(x0, twist).full().ravel()
        t_plan = float(t) + self.delay_ticks * self.dt
        if self.time_scaling:
            t_plan, (poses_ref, twists_ref, directions) = self._scaled_reference(
                float(t), t_plan, float(x0[2]))
        else:
            poses_ref, twists_ref, directions = self._reference.at(t_plan, float(x0[2]))
        guess_poses, guess_twists = self._warm_start(x0, poses_ref, twists_ref)
        result = self.solver.solve(x0, poses_ref, twists_ref, directions, self._last,
                                   guess_poses, guess_twists)

        if result.success:
            self._failures = 0
            status = Status.SOLVED
            target = result.twists[0]
            self._plan_twists = result.twists
            self._guess = (result.poses, result.twists)
            plan = result.poses
        else:
            self._failures += 1
            self._guess = None
            self.solver.reset()
            status, target = self._fallback(twists_ref[0])
            plan = poses_ref.copy()
        twist, clamped = clamp_command(self.robot, target, self._last, self.dt)
        self._last = twist
        if self.delay_ticks:
            self._sent.append(twist)
        if self._swerve is not None:
            wheel_speeds, steer = self._swerve.module_states(twist, self._steer)
            self._steer = steer
        else:
            wheel_speeds, steer = self._jacobian @ twist, None
        return Command(
            wheel_speeds=wheel_speeds,
            twist=twist,
            steer_angles=steer,
            predicted_poses=plan,
            status=status,
            solver_status=result.status,
            solve_time=result.solve_time,
            tick_time=time.perf_counter() - start,
            iterations=result.iterations,
            consecutive_failures=self._failures,
            clamped=clamped,
            reference_time=t_plan,
        )

    def _scaled_reference(
        self, t: float, t_plan: float, heading: float
    ) -> tuple[float, tuple[FloatArray, FloatArray, FloatArray]]:
        """The reference window at the lagging internal time, played at a feasible rate."""
        elapsed = None if self._previous_t is None else t - self._previous_t
        self._previous_t = t
        if elapsed is None or not 0.0 < elapsed <= 2.0 * self.dt:
            self._lag = 0.0  # first tick, or the caller jumped in time: resynchronise
            elapsed = self.dt
        time_ref = t_plan - self._lag
        window = self._reference.at(time_ref, heading)
        velocity = (window[1] @ self._scaling_blocks.T).reshape(self.horizon, -1,
                                                                 self.robot.wheel_dim)
        need = (np.sqrt((velocity * velocity).sum(axis=2)) / self._scaling_limits).max()
        room = REFERENCE_MARGIN / need if need > 0.0 else math.inf
        # Slow down where the reference is too fast; catch up over a horizon when it allows.
        rate = min(room, 1.0 + self._lag / (self.horizon * self.dt))
        if rate != 1.0:
            rate = max(rate, 0.0)
            window = self._reference.at(time_ref, heading, rate)
        self._lag = max(0.0, self._lag + (1.0 - rate) * elapsed)
        return time_ref, window

    def _check_pose(self, pose: ArrayLike) -> FloatArray:
        try:
            x0 = np.array(pose, dtype=float)
        except (TypeError, ValueError):
            raise ControllerError(f"pose must be 3 numbers (x, y, theta), got {pose!r}") from None
        if x0.shape != (3,):
            raise ControllerError(
                f"pose must have shape (3,) as (x, y, theta), got shape {x0.shape}")
        if not math.isfinite(x0.sum()):  # a NaN or an infinity anywhere
            raise ControllerError(f"pose must be finite, got {x0.tolist()}")
        return x0

    def _warm_start(
        self, x0: FloatArray, poses_ref: FloatArray, twists_ref: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """The previous plan shifted one tick (or the reference), starting at ``x0``."""
        if self._guess is None:
            poses, twists = poses_ref.copy(), twists_ref.copy()
        else:
            plan_poses, plan_twists = self._guess
            poses = np.empty_like(plan_poses)
            poses[:-1] = plan_poses[1:]
            poses[-1] = plan_poses[-1]
            twists = np.empty_like(plan_twists)
            twists[:-1] = plan_twists[1:]
            twists[-1] = plan_twists[-1]
            turns = math.floor((poses[0, 2] - x0[2]) / (2.0 * math.pi) + 0.5)
            if turns:  # the measured heading was wrapped
                poses[:, 2] -= 2.0 * math.pi * turns
        poses[0] = x0
        return poses, twists

    def _fallback(self, feedforward: FloatArray) -> tuple[Status, FloatArray]:
        """The fallback twist after ``self._failures`` failed ticks in a row."""
        if self._plan_twists is not None and self._failures < self.horizon:
            return Status.PREVIOUS_PLAN, self._plan_twists[self._failures]
        if self._failures < 2 * self.horizon:
            return Status.FEEDFORWARD, self.robot.desaturate(feedforward)
        return Status.STOPPING, np.zeros(3)
