"""Closed-loop simulation of a controller on a :class:`~mpc.sim.plant.Plant`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from mpc.control.command import Command
from mpc.errors import SimulationError
from mpc.robots.base import Robot
from mpc.sim.plant import PLANT_PRESETS, Plant, PlantConfig
from mpc.sim.recorder import Recorder
from mpc.sim.result import SimResult
from mpc.validation import MAX_SIMULATION_TICKS, finite_vector, is_finite_number
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
    if ticks > MAX_SIMULATION_TICKS:
        raise SimulationError(f"duration {duration!r} s is {ticks} ticks of {dt} s; at most "
                              f"{MAX_SIMULATION_TICKS} ticks are simulated at once")
    trajectory = controller.trajectory
    if initial_pose is None:
        start = trajectory.sample(0.0).pose
    else:
        start = finite_vector("initial_pose", initial_pose, 3, "(x, y, theta)", SimulationError)
    sim = Plant(robot or controller.robot, dt, start, config, np.random.default_rng(seed))
    controller.reset()
    recorder = Recorder(controller.robot, trajectory, dt)
    for k in range(ticks):
        t = k * dt
        pose, measured = sim.pose, sim.measure()
        command = controller.step(measured, t)
        recorder.record(t, pose, command, measured, sim.apply(command))
        if on_tick is not None:
            on_tick(k, ticks)
    return recorder.result()


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
