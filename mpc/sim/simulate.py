"""Closed-loop simulation of a controller on a :class:`~mpc.sim.plant.Plant`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.command import Command
from mpc.errors import SimulationError
from mpc.robots.base import Robot
from mpc.sim.plant import PLANT_PRESETS, Plant, PlantConfig
from mpc.sim.result import SimResult
from mpc.validation import is_finite_number
from trajectories import Trajectory


class TrackingController(Protocol):
    """What :func:`simulate` needs: the MPC and the baselines all fit."""

    robot: Robot
    dt: float

    @property
    def trajectory(self) -> Trajectory: ...

    def reset(self) -> None: ...

    def step(self, pose: ArrayLike, t: float) -> Command: ...


def simulate(
    controller: TrackingController,
    duration: float,
    initial_pose: ArrayLike | None = None,
    plant: PlantConfig | str | None = None,
    seed: int | None = None,
    robot: Robot | None = None,
    on_tick: Callable[[int, int], None] | None = None,
) -> SimResult:
    """Run ``controller`` in closed loop for ``duration`` seconds.

    Args:
        controller: anything with ``step(pose, t) -> Command`` (resets first).
        duration: simulated time [s] (> 0), ``round(duration / dt)`` ticks.
        initial_pose: true start pose; default the reference at t = 0.
        plant: a :class:`~mpc.sim.plant.PlantConfig`, a preset name from
            :data:`~mpc.sim.plant.PLANT_PRESETS`, or None for the ideal plant.
        seed: seeds measurement noise and slip.
        robot: the true robot, if it differs from the controller's (e.g. a
            wheel the controller does not know has failed); default the same.
        on_tick: called as ``on_tick(k, ticks)`` after each tick (progress).
    """
    if not is_finite_number(duration) or duration <= 0:
        raise SimulationError(f"duration must be a finite number of seconds > 0, got {duration!r}")
    config = _plant_config(plant)
    dt = controller.dt
    ticks = max(1, round(duration / dt))
    trajectory = controller.trajectory
    true_robot = robot or controller.robot
    if initial_pose is None:
        start = trajectory.sample(0.0).pose
    else:
        start = np.asarray(initial_pose, dtype=float)
        if start.shape != (3,) or not np.all(np.isfinite(start)):
            raise SimulationError(f"initial_pose must be a finite (3,) pose, got {initial_pose!r}")
    sim = Plant(true_robot, dt, start, config, np.random.default_rng(seed))
    controller.reset()
    n = true_robot.n_wheels
    time: FloatArray = dt * np.arange(ticks, dtype=np.float64)
    poses, measured = np.empty((ticks, 3)), np.empty((ticks, 3))
    commands, actual = np.empty((ticks, n)), np.empty((ticks, n))
    twists = np.empty((ticks, 3))
    tick_time, solve_time, iterations = np.empty(ticks), np.empty(ticks), np.empty(ticks)
    status: list[str] = []
    for k in range(ticks):
        poses[k] = sim.pose
        measured[k] = sim.measure()
        command = controller.step(measured[k], float(time[k]))
        commands[k] = command.wheel_speeds
        twists[k] = command.twist
        tick_time[k], solve_time[k] = command.tick_time, command.solve_time
        iterations[k] = command.iterations
        status.append(command.status.value)
        actual[k] = sim.apply(command)
        if on_tick is not None:
            on_tick(k, ticks)
    reference = trajectory.sample(time).pose
    return SimResult(
        time=time, pose=poses, measured=measured, reference=reference,
        wheel_command=commands, wheel_actual=actual,
        wheel_limit=controller.robot.max_wheel_speed.copy(),
        wheel_accel_limit=controller.robot.max_wheel_accel,
        twist_command=twists, status=tuple(status), tick_time=tick_time,
        solve_time=solve_time, iterations=iterations, dt=dt, trajectory=trajectory,
        wheel_blocks=controller.robot.wheel_blocks,
    )


def _plant_config(plant: PlantConfig | str | None) -> PlantConfig:
    if plant is None:
        return PlantConfig()
    if isinstance(plant, PlantConfig):
        return plant
    if isinstance(plant, str) and plant in PLANT_PRESETS:
        return PLANT_PRESETS[plant]
    raise SimulationError(
        f"plant must be a PlantConfig or one of {sorted(PLANT_PRESETS)}, got {plant!r}"
    )
