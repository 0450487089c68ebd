"""Record any control loop tick by tick into a :class:`~mpc.sim.result.SimResult`.

:func:`~mpc.sim.simulate.simulate` uses it, and so can a loop of your own
(a real robot, another simulator)::

    recorder = Recorder(controller.robot, controller.trajectory, controller.dt)
    while running:
        command = controller.step(pose, t)
        recorder.record(t, pose, command)
    result = recorder.result()       # metrics, figures: as for simulate()
    mpc.plot.plot_run(result, skip=1.0).savefig("run.png")
    mpc.plot.report({"mpc": result}, "report", skip=1.0)     # report/index.html

Every ``predict_every``-th tick (the first included) it also keeps the plan's predicted
poses (``Command.predicted_poses``), for the predicted-path overlay of
:func:`mpc.plot.plot_run`: a copy of (N+1, 3) floats, about 0.5 KB at horizon 20.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, IntArray
from mpc.control.command import Command
from mpc.errors import SimulationError
from mpc.robots.base import Robot
from mpc.sim.result import SimResult
from mpc.validation import MAX_TIME, finite_vector, is_finite_number, positive, shown
from trajectories import Trajectory


class Recorder:
    """Collects ticks; :meth:`result` packs them as a :class:`SimResult`.

    Args:
        robot: the controller's robot (its limits are what the metrics check).
        trajectory: the reference (errors are measured against it).
        dt: control tick [s].
        predict_every: keep the plan's predicted poses every this many ticks (>= 1; 0:
            never). Commands without a plan (one predicted pose) are not kept.
    """

    def __init__(self, robot: Robot, trajectory: Trajectory, dt: float,
                 predict_every: int = 10) -> None:
        if not isinstance(robot, Robot):
            raise SimulationError(f"robot must be an mpc.robots.Robot, got {shown(robot)}")
        if not isinstance(trajectory, Trajectory):
            raise SimulationError(f"trajectory must be a Trajectory, got {shown(trajectory)}")
        self.robot, self.trajectory = robot, trajectory
        self.dt = positive("dt [s]", dt, SimulationError)
        if (isinstance(predict_every, bool) or not isinstance(predict_every, int)
                or predict_every < 0):
            raise SimulationError(
                f"predict_every must be an integer >= 0 (ticks), got {shown(predict_every)}")
        self.predict_every = predict_every
        self._rows: list[tuple[float, FloatArray, FloatArray, FloatArray, Command]] = []
        self._plans: list[tuple[int, FloatArray]] = []  # (tick, predicted poses (N+1, 3))
        self._references: dict[int, FloatArray] = {}  # tick -> reference pose given

    def __len__(self) -> int:
        return len(self._rows)

    def record(self, t: float, pose: ArrayLike, command: Command,
               measured: ArrayLike | None = None, wheel_actual: ArrayLike | None = None,
               reference: ArrayLike | None = None) -> None:
        """One tick at time ``t`` [s]: the true ``pose`` (x, y, theta) [m, m, rad] when the
        command was computed, the ``command`` (from ``Controller.step``), the pose the
        controller saw (default: the true pose), the wheel speeds actually reached [rad/s]
        (default: the command's) and the reference pose tracked at this tick [m, m, rad]
        (default: the trajectory at ``t - command.lag``, what the controller tracked)."""
        if not is_finite_number(t) or abs(float(t)) > MAX_TIME:  # type: ignore[arg-type]
            raise SimulationError(f"t must be a finite time in seconds within +-{MAX_TIME:g} "
                                  f"(step()'s bound), got {shown(t)}")
        if not isinstance(command, Command):
            raise SimulationError("command must be the Command step() returned, "
                                  f"got {shown(command)}")
        if np.shape(command.wheel_speeds) != (self.robot.n_wheels,):
            raise SimulationError(
                f"command must be a Command of the recorder's robot {self.robot.name!r} "
                f"({self.robot.n_wheels} wheel speeds), got one with "
                f"{np.size(command.wheel_speeds)} wheel speeds (another robot's)")
        if self._rows and t < self._rows[-1][0]:
            raise SimulationError(f"t must not decrease: {shown(t)} s after "
                                  f"{self._rows[-1][0]!r} s")
        true = finite_vector("pose", pose, 3, "(x, y, theta)", SimulationError)
        seen = true if measured is None else finite_vector(
            "measured", measured, 3, "(x, y, theta)", SimulationError)
        tracked = None if reference is None else finite_vector(
            "reference", reference, 3, "(x, y, theta)", SimulationError)
        reached = command.wheel_speeds if wheel_actual is None else finite_vector(
            "wheel_actual", wheel_actual, self.robot.n_wheels, "wheel speeds", SimulationError)
        tick = len(self._rows)  # every argument checked: nothing of a refused call is kept
        if tracked is not None:
            self._references[tick] = tracked
        if self.predict_every and tick % self.predict_every == 0:
            plan = np.asarray(command.predicted_poses, dtype=float)
            if plan.ndim == 2 and plan.shape[0] > 1 and plan.shape[1] == 3:
                self._plans.append((tick, plan.copy()))
        self._rows.append((float(t), true, seen, np.array(reached, dtype=float), command))

    def result(self) -> SimResult:
        """Everything recorded so far (at least one tick)."""
        if not self._rows:
            raise SimulationError("nothing recorded: call record() at least once")
        times, poses, measured, actual, commands = zip(*self._rows, strict=True)
        robot = self.robot
        predicted_ticks, predicted_poses = self._predicted()
        time = np.array(times)
        lag = np.array([c.lag for c in commands])
        reference = self.trajectory.sample(time - lag).pose
        for tick, pose in self._references.items():
            reference[tick] = pose
        velocities = np.array([robot.command_velocities(c.wheel_speeds, c.steer_angles)
                               for c in commands])
        return SimResult(
            time=time, pose=np.array(poses), measured=np.array(measured),
            reference=reference, lag=lag,
            wheel_command=np.array([c.wheel_speeds for c in commands]),
            wheel_actual=np.array(actual),
            wheel_limit=robot.max_wheel_speed.copy(), wheel_accel_limit=robot.max_wheel_accel,
            twist_command=np.array([c.twist for c in commands]),
            status=tuple(c.status.value for c in commands),
            tick_time=np.array([c.tick_time for c in commands]),
            solve_time=np.array([c.solve_time for c in commands]),
            iterations=np.array([float(c.iterations) for c in commands]),
            dt=self.dt, trajectory=self.trajectory, wheel_blocks=robot.wheel_blocks,
            wheel_velocity_command=velocities,
            steer_command=(None if robot.max_steer_rates is None
                           else np.array([c.steer_angles for c in commands])),
            steer_rate_limit=robot.max_steer_rates,
            steer_rate_command=(np.array([c.steer_rates for c in commands])
                                if all(c.steer_rates is not None for c in commands) else None),
            predicted_ticks=predicted_ticks, predicted_poses=predicted_poses,
            robot=robot)

    def _predicted(self) -> tuple[IntArray | None, FloatArray | None]:
        """The kept plans' ticks (M,) and poses (M, P, 3), shorter plans padded with NaN."""
        if not self._plans:
            return None, None
        length = max(plan.shape[0] for _, plan in self._plans)
        poses = np.full((len(self._plans), length, 3), np.nan)
        for row, (_, plan) in enumerate(self._plans):
            poses[row, : plan.shape[0]] = plan
        return np.array([tick for tick, _ in self._plans], dtype=np.intp), poses
