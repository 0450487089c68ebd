"""do-mpc on the project's tracking problem: an external yardstick for ``mpc-bench perf``.

The ``peers`` extra (``pip install "holonomic-mpc[peers]"``, or ``pip install do-mpc``)
installs do-mpc; nothing else in the project imports it, and this module imports it only
when a :class:`DoMpcController` is built.

The problem is the one :class:`mpc.Controller` poses in time mode, written in do-mpc's own
terms, and solved by IPOPT inside do-mpc:

- **Kinematics**: a ``discrete`` do-mpc model whose pose moves by the exact SE(2) integral
  of the body twist held over the stage (:func:`mpc.model.twist_integral`, the project's
  own model): *integrated exactly*, no collocation. The stage durations are the project's
  two-speed grid (stage 0 one control tick ``dt``, the others ``stage_dt``, by default
  ``2 dt`` in time mode), passed to the model as a time-varying parameter, so the horizon
  covers the same time as the project's.
- **State** ``(x, y, theta, vx_prev, vy_prev, omega_prev)``: the pose [m, m, rad] and the
  twist of the previous stage [m/s, m/s, rad/s] (starting from the last command sent). do-mpc's
  non-linear constraints see only ``(x, u, tvp)`` of one stage, so carrying the previous
  twist in the state is how the acceleration limits and the rate cost see ``u_k - u_{k-1}``.
- **Cost**: the project's :class:`mpc.model.Weights` term by term: pose error on stages
  1..N-1 (with the ``along_track`` relief), deviation from the feedforward twist, the change
  of twist beyond the reference's own change (``rate`` plus ``module_rate`` through the
  robot's module-velocity Gram matrix), terminal pose error at stage N. do-mpc's own
  ``rterm`` is set to zero (the rate term is in the stage cost).
- **Limits**: every wheel's speed ``|W_i u_k| <= max_wheel_speed_i`` and acceleration
  ``|W_i (u_k - u_{k-1})| <= max_wheel_accel_i h`` (``h`` the time between the two twists)
  as do-mpc non-linear constraints from :meth:`mpc.robots.Robot.casadi_limits` (exact: the
  acceleration rows are divided by ``h``, which leaves these homogeneous constraints
  unchanged). Robots with steered wheels are not supported (their NLP limits need the
  present steer angles).
- **Reference**: sampled at the same stage times; the feedforward is the SE(2) logarithm
  between consecutive reference poses (the project's ``reference_terms``), the heading
  shifted by whole turns to within pi of the robot's.
- **IPOPT**: the same ``tol`` (1e-8) and ``max_iter`` (100) as the project's IPOPT path,
  MUMPS; warm started the do-mpc way (the previous solution and its multipliers, not
  shifted). No clamp after it: the command is IPOPT's first twist.
"""

from __future__ import annotations

import importlib.util
import math
import time
import warnings
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.command import Command, Status
from mpc.model import TrackingModel, Weights, make_weights, twist_integral
from mpc.robots import Robot
from trajectories import Trajectory

#: What to tell a user who asked for peers without the extra.
INSTALL_HINT = ('do-mpc not installed: pip install "holonomic-mpc[peers]" (or pip install '
                'do-mpc) to measure it on the same problem; skipped')


def available() -> bool:
    """Whether do-mpc can be imported (without importing it)."""
    return importlib.util.find_spec("do_mpc") is not None


def version() -> str | None:
    """do-mpc's version, or None when it is not installed."""
    if not available():
        return None
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as package_version

    try:
        return package_version("do-mpc")
    except PackageNotFoundError:
        return None


def _import_do_mpc() -> Any:
    with warnings.catch_warnings():  # do-mpc warns about its optional features on import
        warnings.simplefilter("ignore")
        import do_mpc
    return do_mpc


class DoMpcController:
    """The project's time-mode tracking problem built and solved by do-mpc (module docstring).

    Fits :func:`mpc.sim.simulate` (``robot``, ``dt``, ``trajectory``, ``reset``, ``step``).

    Args:
        robot: a robot without steered wheels.
        trajectory: the reference.
        horizon: stages N.
        dt: control tick [s], the duration of stage 0.
        stage_dt: duration of stages 1..N-1 [s] (default ``2 dt``, as the project's time mode).
        weights: :class:`mpc.model.Weights` or overrides (default: the project's).
        max_iter: IPOPT iterations per tick at most.
        tolerance: IPOPT's ``tol``.

    Attributes:
        failures: ticks on which IPOPT did not report success (the command is then its
            last iterate's first twist).
    """

    def __init__(self, robot: Robot, trajectory: Trajectory, horizon: int = 20,
                 dt: float = 0.05, stage_dt: float | None = None,
                 weights: Weights | dict[str, Any] | None = None, max_iter: int = 100,
                 tolerance: float = 1e-8) -> None:
        if robot.steered:
            raise ValueError(f"the do-mpc peer supports robots without steered wheels, "
                             f"got {robot.name!r}")
        do_mpc = _import_do_mpc()
        self.robot = robot
        self.dt = float(dt)
        self._trajectory = trajectory
        self.weights = make_weights(weights)
        # The project's grid and reference terms (durations, offsets, feedforward).
        self.grid = TrackingModel(robot, horizon, 2.0 * dt if stage_dt is None else stage_dt,
                                  self.weights, tick=dt)
        self.horizon = horizon
        self.failures = 0
        self._build(do_mpc, max_iter, tolerance)
        self.reset()

    @property
    def trajectory(self) -> Trajectory:
        return self._trajectory

    def _build(self, do_mpc: Any, max_iter: int, tolerance: float) -> None:
        weights, robot = self.weights, self.robot
        model = do_mpc.model.Model("discrete", "SX")
        pose = model.set_variable("_x", "pose", (3, 1))
        previous = model.set_variable("_x", "previous", (3, 1))
        twist = model.set_variable("_u", "twist", (3, 1))
        pose_ref = model.set_variable("_tvp", "pose_ref", (3, 1))
        twist_ref = model.set_variable("_tvp", "twist_ref", (3, 1))
        ref_change = model.set_variable("_tvp", "twist_ref_change", (3, 1))
        direction = model.set_variable("_tvp", "direction", (2, 1))
        duration = model.set_variable("_tvp", "duration", (1, 1))
        change_time = model.set_variable("_tvp", "change_time", (1, 1))
        pose_on = model.set_variable("_tvp", "pose_on", (1, 1))  # 0 on stage 0 (fixed pose)
        model.set_rhs("pose", twist_integral(pose, twist, duration))
        model.set_rhs("previous", twist)
        model.setup()

        def pose_cost(diagonal: FloatArray) -> ca.SX:
            error = pose - pose_ref
            along = ca.dot(direction, error[:2])
            relief = (1.0 - weights.along_track) * float(min(diagonal[0], diagonal[1]))
            return ca.bilin(ca.DM(np.diag(diagonal)), error, error) - relief * along**2

        deviation = twist - twist_ref
        change = twist - previous - ref_change
        lterm = (pose_on * pose_cost(weights.pose)
                 + ca.bilin(ca.DM(np.diag(weights.twist)), deviation, deviation)
                 + ca.bilin(ca.DM(self.grid.rate_matrix), change, change))
        controller = do_mpc.controller.MPC(model)
        controller.settings.n_horizon = self.horizon
        controller.settings.t_step = self.dt
        controller.settings.n_robust = 0
        controller.settings.store_full_solution = False
        controller.settings.nlpsol_opts.update({
            "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": 0, "record_time": True,
            "ipopt.max_iter": int(max_iter), "ipopt.tol": float(tolerance),
            "ipopt.linear_solver": "mumps"})
        controller.set_objective(lterm=lterm, mterm=pose_cost(weights.terminal))
        controller.set_rterm(twist=0.0)  # the rate term is in lterm (beyond the reference's)
        rows = [robot.casadi_limits(twist, robot.max_wheel_speed)]
        if robot.max_wheel_accel is not None:
            rows.append(robot.casadi_limits((twist - previous) / change_time,
                                            robot.max_wheel_accel))
        for index, (value, lower, upper) in enumerate(rows):
            for side, expression in (("upper", value - ca.DM(upper)),
                                     ("lower", ca.DM(lower) - value)):
                finite = np.isfinite(np.asarray(upper if side == "upper" else lower)).ravel()
                if finite.any():
                    kept = expression[np.flatnonzero(finite).tolist()]
                    controller.set_nl_cons(f"limits_{index}_{side}", kept, ub=0.0)
        template = controller.get_tvp_template()
        controller.set_tvp_fun(lambda _t: template)
        with warnings.catch_warnings():  # do-mpc's set-up calls NumPy on CasADi values
            warnings.simplefilter("ignore", FutureWarning)
            controller.setup()
        self._controller = controller
        self._template = template
        # Flat indices of every stage's parameters in the template, to fill it in one go.
        n = self.horizon
        names = ("pose_ref", "twist_ref", "twist_ref_change", "direction", "duration",
                 "change_time", "pose_on")
        self._index = {name: np.array([template.f["_tvp", k, name] for k in range(n + 1)])
                       for name in names}
        self._values = np.zeros(template.cat.shape[0])
        grid = self.grid
        durations = np.append(grid.durations, grid.durations[-1])  # stage N: unused
        changes = np.append(grid.change_times, grid.change_times[-1])
        self._values[self._index["duration"].ravel()] = durations
        self._values[self._index["change_time"].ravel()] = changes
        pose_flags = np.ones(n + 1)
        pose_flags[0] = 0.0
        self._values[self._index["pose_on"].ravel()] = pose_flags
        middles = grid.offsets[:-1] + 0.5 * grid.durations
        self._slope = (float(grid.durations[0] / (middles[1] - middles[0])) if n >= 2
                       else 0.0)

    def reset(self) -> None:
        """Forget the last solution: the next step starts from its own pose at rest."""
        self._last = np.zeros(3)
        self._fresh = True
        self.failures = 0
        self._controller.reset_history()

    def _fill_reference(self, t: float, heading: float) -> None:
        grid, n = self.grid, self.horizon
        sample = self._trajectory.sample(t + grid.offsets)
        poses = np.array(sample.pose, dtype=float)
        turns = math.floor((poses[0, 2] - heading) / (2.0 * math.pi) + 0.5)
        poses[:, 2] -= 2.0 * math.pi * turns
        feedforward, directions = grid.reference_terms(poses.T, np.asarray(sample.velocity).T)
        feedforward = np.asarray(feedforward).T  # (N, 3)
        changes = np.zeros((n, 3))
        changes[1:] = np.diff(feedforward, axis=0)
        if n >= 2:
            changes[0] = self._slope * (feedforward[1] - feedforward[0])
        values, index = self._values, self._index
        values[index["pose_ref"]] = poses
        values[index["direction"]] = np.asarray(directions).T
        values[index["twist_ref"][:n]] = feedforward
        values[index["twist_ref"][n]] = feedforward[-1]
        values[index["twist_ref_change"][:n]] = changes
        self._template.master = ca.DM(values)

    def step(self, pose: ArrayLike, t: float) -> Command:
        """do-mpc's command for the measured pose (3,) [m, m, rad] at time ``t`` [s]."""
        start = time.perf_counter()
        measured = np.asarray(pose, dtype=float)
        state = np.concatenate((measured, self._last))
        self._fill_reference(float(t), float(measured[2]))
        controller = self._controller
        if self._fresh:  # do-mpc's own start: every stage at the present state
            controller.x0 = state
            controller.u0 = self._last
            controller.set_initial_guess()
            self._fresh = False
        twist = np.asarray(controller.make_step(state), dtype=float).ravel()
        speeds, steer = self.robot.wheel_commands(twist, None)
        tick_time = time.perf_counter() - start
        stats = controller.solver_stats
        success = bool(stats.get("success", False)) and bool(np.all(np.isfinite(twist)))
        self.failures += not success
        self._last = twist
        plan = np.array([np.asarray(x).ravel()[:3]
                         for x in controller.opt_x_num["_x", :, 0, -1]])
        return Command(
            wheel_speeds=speeds, twist=twist, steer_angles=steer, predicted_poses=plan,
            status=Status.SOLVED, solver_status=str(stats.get("return_status", "unknown")),
            solve_time=float(stats.get("t_wall_total", 0.0)), tick_time=tick_time,
            iterations=int(stats.get("iter_count", 0)), consecutive_failures=0,
            clamped=False, reference_time=float(t))
