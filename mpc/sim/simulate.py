"""Closed-loop simulation of a controller on a :class:`~mpc.sim.plant.Plant`."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.command import Command
from mpc.errors import SimulationError
from mpc.plausibility import check_heading
from mpc.robots.base import Robot
from mpc.sim.motor_plant import MotorPlant, MotorPlantConfig
from mpc.sim.plant import PLANT_PRESETS, Plant, PlantConfig
from mpc.sim.recorder import Recorder
from mpc.sim.result import SimResult
from mpc.validation import (
    MAX_SIMULATION_TICKS,
    checked_arguments,
    finite_vector,
    is_finite_number,
    shown,
)
from trajectories import Trajectory


class TrackingController(Protocol):
    """What :func:`simulate` needs: the MPC and the baselines all fit."""

    robot: Robot
    dt: float

    @property
    def trajectory(self) -> Trajectory: ...

    def reset(self) -> None: ...

    def step(self, pose: ArrayLike, t: float) -> Command: ...


class SteerMeasuringController(Protocol):
    """A controller of a robot whose steer angles are states (casters): it takes them."""

    def step(self, pose: ArrayLike, t: float, steer_angles: ArrayLike | None = None
             ) -> Command: ...


#: Plants of wheel types whose joint states the controller takes each tick besides the pose
#: (sliders), by :attr:`~mpc.robots.Robot.kind`, registered by their modules: built as
#: :class:`~mpc.sim.plant.Plant` is, they also have ``joint_states()`` (the keyword
#: arguments of the controller's ``step``) and ``start_along(trajectory)`` (the joints at
#: the start of a run).
_JOINT_PLANTS: dict[str, Callable[..., Any]] = {}


def register_plant(kind: str, plant: Callable[..., Any]) -> None:
    """Make :func:`simulate` of a robot of ``kind`` run on ``plant`` (not the motor plant)."""
    _JOINT_PLANTS[kind] = plant


@checked_arguments(SimulationError)
def simulate(
    controller: TrackingController,
    duration: float,
    initial_pose: ArrayLike | None = None,
    plant: PlantConfig | str | None = None,
    seed: int | None = None,
    robot: Robot | None = None,
    on_tick: Callable[[int, int], None] | None = None,
    initial_steer_angles: ArrayLike | None = None,
) -> SimResult:
    """Run ``controller`` in closed loop for ``duration`` seconds.

    Args:
        controller: anything with ``step(pose, t) -> Command`` (resets first).
        duration: simulated time [s] (> 0), ``round(duration / dt)`` ticks.
        initial_pose: true start pose (x, y, theta) [m, m, rad]; default the reference at
            t = 0. A heading more than a turn from both 0 and the reference's at t = 0 (a
            heading in degrees: :func:`~mpc.plausibility.check_heading`) raises
            SimulationError unless the controller has ``allow_unusual=True``.
        plant: a :class:`~mpc.sim.plant.PlantConfig`, a preset name from
            :data:`~mpc.sim.plant.PLANT_PRESETS`, or None for the ideal plant; a
            :class:`~mpc.sim.motor_plant.MotorPlantConfig` (``"motor"``) drives the robot
            through its motors (it needs dynamics) and records its events in
            ``SimResult.plant_events``.
        seed: seeds measurement noise and slip.
        robot: the true robot, if it differs from the controller's (e.g. a
            wheel the controller does not know has failed); default the same.
        on_tick: called as ``on_tick(k, ticks)`` after each tick (progress).
        initial_steer_angles: the true robot's steer angles at the start [rad] (n,). Default:
            for robots whose steer angles are states (casters), trailing the reference's
            first direction of travel (:func:`trailing_start`); for others, 0.

    A controller of a robot whose steer angles are states is stepped as
    ``step(measured_pose, t, steer_angles=measured_angles)`` (the plant's angles).
    """
    true_robot = _check_arguments(controller, robot, on_tick)
    if not is_finite_number(duration) or duration <= 0:
        raise SimulationError(f"duration must be a finite number of seconds > 0, "
                              f"got {shown(duration)}")
    config = _plant_config(plant)
    dt = controller.dt
    ticks = max(1, round(duration / dt))
    if ticks > MAX_SIMULATION_TICKS:
        raise SimulationError(f"duration {shown(duration)} s is {ticks} ticks of {dt} s; at most "
                              f"{MAX_SIMULATION_TICKS} ticks are simulated at once")
    trajectory = controller.trajectory
    if initial_pose is None:
        start = trajectory.sample(0.0).pose
    else:
        start = finite_vector("initial_pose", initial_pose, 3, "(x, y, theta)", SimulationError)
        # a heading in degrees, checked as the controller's first tick checks it
        check_heading("initial_pose", float(start[2]), float(trajectory.sample(0.0).pose[2]),
                      getattr(controller, "allow_unusual", False) is True, SimulationError)
    joint_plant = _JOINT_PLANTS.get(true_robot.kind)
    kind = (MotorPlant if isinstance(config, MotorPlantConfig) else joint_plant or Plant)
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))
                             or seed < 0):
        raise SimulationError(f"seed must be None or an integer >= 0, got {shown(seed)}")
    sim = kind(true_robot, dt, start, config, np.random.default_rng(seed))
    if initial_steer_angles is not None:
        sim.steer_angles = finite_vector("initial_steer_angles", initial_steer_angles,
                                         true_robot.n_wheels, "steer angles [rad]",
                                         SimulationError)
    elif joint_plant is not None and kind is joint_plant:
        sim.start_along(trajectory)  # type: ignore[union-attr]
    elif true_robot.steer_states:
        sim.steer_angles = trailing_start(true_robot, trajectory)
    joints = getattr(sim, "joint_states", None)
    measuring = controller.robot.steer_states
    controller.reset()
    recorder = Recorder(controller.robot, trajectory, dt)
    for k in range(ticks):
        t = k * dt
        pose, measured = sim.pose, sim.measure()
        if joints is not None:
            command = controller.step(measured, t, **joints())  # type: ignore[call-arg]
        elif measuring and sim.steer_angles is not None:
            command = cast(SteerMeasuringController, controller).step(
                measured, t, steer_angles=sim.steer_angles.copy())
        else:
            command = controller.step(measured, t)
        recorder.record(t, pose, command, measured, sim.apply(command))
        if on_tick is not None:
            on_tick(k, ticks)
    if isinstance(sim, MotorPlant):
        return dataclasses.replace(recorder.result(), plant_events=sim.events())
    return recorder.result()


def _check_arguments(controller: object, robot: object, on_tick: object) -> Robot:
    """The true robot (``robot``, default the controller's), after checking that
    ``controller`` is one (a ``step``, a ``robot`` and a tick ``dt``), that ``robot`` is the
    same kind with as many wheels, and that ``on_tick`` is None or callable."""
    ours = getattr(controller, "robot", None)
    tick = getattr(controller, "dt", None)
    if not (callable(getattr(controller, "step", None)) and isinstance(ours, Robot)
            and is_finite_number(tick) and tick > 0):  # type: ignore[operator]
        raise SimulationError("controller must be a Controller (or have step(), a robot and "
                              f"a tick dt > 0), got {type(controller).__name__}")
    if on_tick is not None and not callable(on_tick):
        raise SimulationError(f"on_tick must be None or a callable on_tick(k, ticks), "
                              f"got {shown(on_tick)}")
    if robot is None:
        return ours
    if not isinstance(robot, Robot):
        raise SimulationError(f"robot must be None or an mpc.robots.Robot (the true robot), "
                              f"got {type(robot).__name__}")
    if robot.kind != ours.kind or robot.n_wheels != ours.n_wheels:
        raise SimulationError(
            f"robot (the true robot) must be of the controller's kind with as many wheels: "
            f"{ours.kind} with {ours.n_wheels}, got {robot.kind} with {robot.n_wheels}")
    return robot


def trailing_start(robot: Robot, trajectory: Trajectory) -> FloatArray:
    """Steer angles [rad] trailing the reference's first direction of travel: each caster
    along its axis's velocity at the first of 200 samples over the reference's first
    period (or span, or 10 s) where the robot moves; 0 if it never does."""
    span = trajectory.period or trajectory.duration or 10.0
    times = trajectory.start_time + np.linspace(0.0, span, 201)
    twists = trajectory.body_twist(times)
    positions = robot.wheel_positions
    for twist in twists:
        velocity = np.stack([twist[0] - twist[2] * positions[:, 1],
                             twist[1] + twist[2] * positions[:, 0]], axis=1)
        if np.hypot(velocity[:, 0], velocity[:, 1]).min() > 1e-9:
            return np.arctan2(velocity[:, 1], velocity[:, 0])
    return np.zeros(robot.n_wheels)


def _plant_config(plant: PlantConfig | str | None) -> PlantConfig:
    if plant is None:
        return PlantConfig()
    if isinstance(plant, PlantConfig):
        return plant
    if isinstance(plant, str) and plant in PLANT_PRESETS:
        return PLANT_PRESETS[plant]
    raise SimulationError(
        f"plant must be a PlantConfig or one of {sorted(PLANT_PRESETS)}, got {shown(plant)}"
    )
