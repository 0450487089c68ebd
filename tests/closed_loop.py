"""Helpers shared by the closed-loop tests (imported by test modules; not a test module)."""

from __future__ import annotations

import numpy as np

from mpc import Command, Status
from mpc.robots import PRESETS, Robot, preset
from mpc.sim import Plant, PlantConfig, SimResult, TrackingController
from trajectories import Circle, FigureEight, Trajectory

DT = 0.05  # [s] control tick of every test loop
START_OFFSET = np.array([0.2, 0.0, 0.3])  # [m, m, rad] acceptance runs start this far off
SETTLE = 2.0  # [s] tracking errors are measured after this
#: Presets whose steer angles are not states: the caster preset's acceptance criteria (its
#: steer angles measured, mm-level tracking) are in test_caster.py.
JOINT_FREE_PRESETS = tuple(name for name in PRESETS if not preset(name).steer_states)
#: Presets with acceleration limits (the caster and MPO-700 presets have none).
ACCEL_PRESETS = tuple(name for name in PRESETS if preset(name).max_wheel_accel is not None)


def inside_limits() -> dict[str, Trajectory]:
    """References well inside every preset's wheel limits (peak ratio 0.35..0.80)."""
    return {
        "circle_fixed": Circle(1.0, 12.0, heading=0.0),
        "figure_eight_tangent": FigureEight(1.0, 16.0, heading="tangent"),
    }


def off_start(trajectory: Trajectory) -> np.ndarray:
    return trajectory.sample(0.0).pose + START_OFFSET


def assert_within_limits(result: SimResult) -> None:
    """No speed or acceleration violation and finite commands over the whole run."""
    metrics = result.metrics()
    assert metrics["limit_violations"] == 0
    assert metrics["max_wheel_speed_ratio"] <= 1.0 + 1e-6
    assert metrics["accel_violations"] == 0
    assert np.all(np.isfinite(result.wheel_command))


def statuses_after(result: SimResult, time: float) -> set[str]:
    return {s for s, t in zip(result.status, result.time, strict=True) if t >= time}


def check_command(robot: Robot, command: Command, last: np.ndarray) -> None:
    """Finite, within every speed limit and within the acceleration limit from ``last``."""
    assert np.all(np.isfinite(command.wheel_speeds)) and np.all(np.isfinite(command.twist))
    assert robot.is_feasible(command.twist)
    assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
    change = np.linalg.norm(robot.wheel_velocities(command.twist - last), axis=-1)
    accel = robot.max_wheel_accel
    if accel is None:
        raise AssertionError("check_command needs a robot with acceleration limits")
    assert np.all(change <= accel * DT * (1 + 1e-9))
    assert (command.status is Status.SOLVED) == (command.consecutive_failures == 0)


class Loop:
    """A controller driving a plant tick by tick, checking every command."""

    def __init__(self, controller: TrackingController, start: np.ndarray,
                 config: PlantConfig | None = None) -> None:
        self.controller = controller
        self.plant = Plant(controller.robot, DT, start, config or PlantConfig(),
                           np.random.default_rng(0))
        self.tick = 0
        self.last = np.zeros(3)

    def step(self) -> Command:
        command = self.controller.step(self.plant.measure(), self.tick * DT)
        check_command(self.controller.robot, command, self.last)
        self.last = command.twist
        self.plant.apply(command)
        self.tick += 1
        return command


def too_fast_circle(robot: Robot, overload: float = 1.3) -> Trajectory:
    """A 1 m circle (fixed heading) whose period is cut so that the peak ratio is ``overload``."""
    from trajectories import feasibility

    reference = Circle(1.0, 12.0, heading=0.0)
    period = 12.0 * feasibility(reference, robot).peak_ratio / overload
    return Circle(1.0, period, heading=0.0)
