"""Steering ranges (issue 42): absolute module angles kept within ``steer_range``, flips
chosen over the horizon; bad ranges refused; robots without a range unchanged."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mpc import Controller
from mpc.errors import RobotError
from mpc.robots import SwerveRobot, preset
from mpc.robots.description.files import from_dict
from mpc.robots.wheels.swerve import swerve
from mpc.robots.wheels.swerve.ranges import candidates, nearest_branch, plan_branch
from mpc.sim.plant import Plant, PlantConfig
from mpc.sim.recorder import Recorder
from mpc.sim.result import SimResult
from trajectories import Circle, SpinHeading

PI = math.pi
SQUARE = [[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3], [-0.3, -0.3]]


def ranged(name: str, plan: str = "horizon") -> SwerveRobot:
    robot = preset(name)
    assert isinstance(robot, SwerveRobot)
    return dataclasses.replace(robot, steer_range=(-PI, PI), steer_plan=plan)


@pytest.mark.parametrize("bad", [(1.0, 0.0), (0.0, 3.0), (0.0, math.inf), (math.nan, 4.0),
                                 "ab", (1.0, 2.0, 3.0), 5.0])
def test_bad_ranges_are_refused(bad: object) -> None:
    with pytest.raises(RobotError, match="steer_range must be"):
        swerve(module_positions=SQUARE, wheel_radius=0.05, max_wheel_speed=30.0,
               max_steer_rate=12.0, steer_range=bad)
    with pytest.raises(RobotError, match="steer_range must be"):
        from_dict({"type": "swerve", "module_positions": SQUARE, "wheel_radius": 0.05,
                   "max_wheel_speed": 30.0, "max_steer_rate": 12.0,
                   "steer_range": list(bad) if isinstance(bad, tuple) else bad})


def test_bad_plan_is_refused() -> None:
    with pytest.raises(RobotError, match="steer_plan must be one of"):
        swerve(module_positions=SQUARE, wheel_radius=0.05, max_wheel_speed=30.0,
               max_steer_rate=12.0, steer_range=(-PI, PI), steer_plan="greedy")


def test_presets_carry_their_range() -> None:
    for name, lever in (("swerve-cable", 0.0), ("mpo700-cable", 0.045)):
        robot = preset(name)
        assert isinstance(robot, SwerveRobot)
        assert robot.steer_angle_range() == pytest.approx((-PI, PI))
        assert robot.axle_offset == lever
        assert from_dict(robot.description()).steer_range == robot.steer_range
    assert preset("swerve").steer_angle_range() is None


def test_branches_by_hand() -> None:
    # direction -3.0 rad in [-pi, pi]: itself (forwards) or -3.0 + pi (backwards)
    assert candidates(-3.0, -PI, PI) == [(-3.0, 1), (pytest.approx(PI - 3.0), -1)]
    # at +3.0 the module cannot follow on to -3.0 + 2 pi = 3.28 (beyond pi): it flips
    assert nearest_branch(3.0, -3.0, -PI, PI) == pytest.approx(PI - 3.0)
    assert nearest_branch(-2.9, -3.0, -PI, PI) == -3.0


def test_horizon_unwinds_where_the_module_is_slow() -> None:
    # A module at -2.9 rad turning clockwise (towards the stop at -pi) at 0.1 rad a
    # stage, fast except at stage 3: the plan turns it to the other branch there, not
    # at the stop (the per-tick rule stays until it must flip at speed).
    directions: list[float | None] = [-2.9 - 0.1 * k for k in range(8)]
    speeds = [0.8, 0.8, 0.8, 0.02, 0.8, 0.8, 0.8, 0.8]
    reaches = [0.6] * 8
    first = plan_branch(-2.9, directions, speeds, reaches, -PI, PI)
    assert first == pytest.approx(-2.9)  # no turn yet: it waits for the slow stage
    at_slow = plan_branch(-3.2 + 2 * PI - PI, directions[3:], speeds[3:], reaches[3:],
                          -PI, PI)
    assert -PI <= at_slow <= PI
    # at the slow stage, from the old branch: it takes the one with room ahead
    turned = plan_branch(-3.2, [-3.2 - 0.1 * k for k in range(5)],
                         [0.02, 0.8, 0.8, 0.8, 0.8], [0.6] * 5, -PI - 0.1, PI)
    assert turned > 0.0


def test_commands_without_a_range_are_todays() -> None:
    rng = np.random.default_rng(3)
    robot = preset("swerve")
    for _ in range(50):
        twist, angles = rng.normal(size=3), rng.uniform(-PI, PI, 4)
        plan = rng.normal(size=(5, 3))
        mine = robot.planned_wheel_commands(twist, angles, twist, 0.05, plan,
                                            np.full(5, 0.1), rng.normal(size=4))
        today = robot.wheel_commands(twist, angles, twist, 0.05)
        assert np.array_equal(mine.speeds, today.speeds)
        assert np.array_equal(mine.steer_angles, today.steer_angles)


def spin_reference() -> Circle:
    """A 1 m circle at 0.6 m/s whose heading spins two full turns in the lap."""
    period = 2.0 * PI / 0.6
    return Circle(1.0, period, heading=SpinHeading(rate=2.0 * 2.0 * PI / period))


def closed_loop(robot: SwerveRobot, solver: str = "daqp") -> tuple[SimResult, float, float]:
    """One lap on the ideal plant; the plant's own (absolute) angles' extremes [rad]."""
    reference = spin_reference()
    controller = Controller(robot, reference, solver=solver)
    plant = Plant(robot, controller.dt, reference.sample(0.0).pose, PlantConfig(),
                  np.random.default_rng(0))
    recorder = Recorder(robot, reference, controller.dt)
    low, high = math.inf, -math.inf
    for k in range(round(reference.period / controller.dt)):
        t = k * controller.dt
        command = controller.step(plant.measure(), t)
        pose = plant.pose
        recorder.record(t, pose, command, wheel_actual=plant.apply(command))
        assert plant.steer_angles is not None
        low, high = min(low, plant.steer_angles.min()), max(high, plant.steer_angles.max())
    return recorder.result(), low, high


@pytest.mark.parametrize("name", ["swerve", "mpo700"])
def test_range_is_kept_with_fewer_flips_than_the_tick_rule(name: str) -> None:
    horizon, low, high = closed_loop(ranged(name))
    tick, tick_low, tick_high = closed_loop(ranged(name, "tick"))
    free, free_low, free_high = closed_loop(preset(name))  # type: ignore[arg-type]
    for result, lo, hi in ((horizon, low, high), (tick, tick_low, tick_high)):
        assert -PI <= lo and hi <= PI  # the plant's absolute angles
        assert result.steer_range_exits() == 0
        metrics = result.metrics()
        assert metrics["limit_violations"] == 0
        assert metrics["accel_violations"] == 0
        assert metrics["steer_violations"] == 0
    horizon_flips, tick_flips = horizon.steer_flips(), tick.steer_flips()
    assert horizon_flips is not None and tick_flips is not None
    assert horizon_flips.sum() < tick_flips.sum()
    # without a range the modules wind beyond half a turn (the range matters here) ...
    assert free_high - free_low > 2 * PI
    # ... and the planned flips track far closer than the per-tick rule
    assert (horizon.metrics(skip=2.0)["rms_position_error"]
            < 0.5 * tick.metrics(skip=2.0)["rms_position_error"])
