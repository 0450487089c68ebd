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
from mpc.robots.wheels.swerve.ranges import (
    BranchWeights,
    candidates,
    nearest_branch,
    plan_path,
    steer_coupling,
    steer_reaches,
)
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


def test_plan_unwinds_inside_a_slow_stretch() -> None:
    # A module at -2 rad whose direction turns clockwise 0.1 rad a stage reaches the stop
    # at -pi at stage 12; it is slow (2 % of its limit) over stages 3-9 only. The plan
    # turns it to the other branch inside that stretch: not now, not at the stop.
    directions: list[float | None] = [-2.0 - 0.1 * k for k in range(16)]
    speeds = [0.02 if 3 <= k <= 9 else 0.8 for k in range(16)]
    path = plan_path(-2.0, directions, speeds, [0.6] * 16, -PI, PI)
    jumps = [k for k in range(1, 16) if abs(path[k] - path[k - 1]) > 1.0]
    assert len(jumps) == 1 and 3 <= jumps[0] <= 9
    assert path[0] == pytest.approx(-2.0)
    assert all(-PI <= b <= PI for b in path)
    for b, d in zip(path, directions, strict=True):  # every stage on a branch of its direction
        assert d is not None
        assert math.remainder(b - d, PI) == pytest.approx(0.0, abs=1e-12)


def test_plan_follows_far_from_the_stops() -> None:
    directions: list[float | None] = [-0.05 * k for k in range(16)]
    path = plan_path(0.0, directions, [0.02] * 16, [0.6] * 16, -PI, PI)
    assert path == pytest.approx([-0.05 * k for k in range(16)])
    # at rest throughout: it stays where it is
    assert plan_path(0.5, [None] * 4, [0.0] * 4, [0.6] * 4, -PI, PI) == [0.5] * 4


def test_plant_turns_ranged_modules_the_absolute_way() -> None:
    # from 2.5 rad to a command of -2.5 rad: the short way crosses pi (no range), the
    # absolute way goes back through 0 (a range: the cable unwinds)
    for robot, sign in ((preset("swerve"), 1.0), (ranged("swerve"), -1.0)):
        plant = Plant(robot, 0.05, np.zeros(3), PlantConfig(substeps=1),
                      np.random.default_rng(0))
        plant.steer_angles = np.full(4, 2.5)
        command = Controller(robot, spin_reference()).step(np.zeros(3), 0.0)
        plant.apply(dataclasses.replace(command, wheel_speeds=np.zeros(4),
                                        steer_angles=np.full(4, -2.5)))
        assert plant.steer_angles is not None
        turned = math.remainder(plant.steer_angles[0] - 2.5, 2 * PI)
        assert turned == pytest.approx(sign * robot.max_steer_rate * 0.05)


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


def spin_reference(turns: float = 2.0, speed: float = 0.6) -> Circle:
    """A 1 m circle at ``speed`` [m/s] whose heading spins ``turns`` turns in the lap."""
    period = 2.0 * PI / speed
    return Circle(1.0, period, heading=SpinHeading(rate=turns * 2.0 * PI / period))


def closed_loop(robot: SwerveRobot, solver: str = "daqp", duration: float | None = None,
                turns: float = 2.0, speed: float = 0.6) -> tuple[SimResult, float, float]:
    """One lap (or ``duration`` [s]) on the ideal plant; the plant's own (absolute) angles'
    extremes [rad]."""
    reference = spin_reference(turns, speed)
    controller = Controller(robot, reference, solver=solver)
    plant = Plant(robot, controller.dt, reference.sample(0.0).pose, PlantConfig(),
                  np.random.default_rng(0))
    recorder = Recorder(robot, reference, controller.dt)
    low, high = math.inf, -math.inf
    for k in range(round((duration or reference.period) / controller.dt)):
        t = k * controller.dt
        command = controller.step(plant.measure(), t)
        pose = plant.pose
        recorder.record(t, pose, command, wheel_actual=plant.apply(command))
        assert plant.steer_angles is not None
        low, high = min(low, plant.steer_angles.min()), max(high, plant.steer_angles.max())
    return recorder.result(), low, high


@pytest.mark.parametrize(("name", "turns", "speed"), [
    ("swerve", 2.0, 0.6),    # the heading turns with the path: modules wind once a lap
    ("swerve", -2.0, 0.6),   # against it: they wind three times, slow three times a lap
    ("mpo700", 2.0, 0.6),    # axle offset: a turn takes drive rate
    ("mpo700", -2.0, 0.5),
])
def test_range_kept_as_closely_with_fewer_flips(name: str, turns: float, speed: float) -> None:
    # the done-when: inside the range on every tick, RMS within 10 % of the same
    # robot without a range, fewer flips than the per-tick rule (counted alike for both)
    horizon, low, high = closed_loop(ranged(name), turns=turns, speed=speed)
    tick, tick_low, tick_high = closed_loop(ranged(name, "tick"), turns=turns, speed=speed)
    free = closed_loop(preset(name), turns=turns, speed=speed)[0]  # type: ignore[arg-type]
    for result, lo, hi in ((horizon, low, high), (tick, tick_low, tick_high)):
        assert -PI <= lo and hi <= PI  # the plant's own absolute angles
        assert result.steer_range_exits() == 0
        metrics = result.metrics()
        assert (metrics["limit_violations"], metrics["accel_violations"],
                metrics["steer_violations"], metrics["failures"]) == (0, 0, 0, 0)
    # the range matters: without it the modules wind more than a turn
    assert np.ptp(np.unwrap(free.steer_command, axis=0)) > 2 * PI
    horizon_flips, tick_flips = horizon.steer_flips(), tick.steer_flips()
    assert horizon_flips is not None and tick_flips is not None
    assert horizon_flips.sum() < tick_flips.sum()
    rms = horizon.metrics()["rms_position_error"]
    assert rms <= 1.1 * free.metrics()["rms_position_error"]
    if name == "swerve":  # slow steering: the per-tick rule unwinds at its stops at speed
        assert rms < 0.7 * tick.metrics()["rms_position_error"]


def test_offset_module_reach_by_hand() -> None:
    # mpo700: L / r = 0.045 / 0.09 = 0.5, drive limit 12.267 rad/s, steering 24.4 rad/s
    robot = preset("mpo700")
    assert isinstance(robot, SwerveRobot)
    assert steer_coupling(robot) == pytest.approx(np.full(4, min(1.0, 0.5 * 24.4 / 12.267)))
    magnitude = np.array([[0.0] * 4, [6.0] * 4, [12.267] * 4])  # [rad/s]
    reach = steer_reaches(robot, magnitude, np.array([0.0, 2.0, 0.0]), np.full(3, 0.05))
    # at rest: the full rate; at 6 rad/s and omega 2 rad/s: (12.267 - 6 - 1) / 0.5 rad/s
    assert reach[:, 0] == pytest.approx([24.4 * 0.05, (12.267 - 6.0 - 1.0) / 0.5 * 0.05, 0.0])
    plain = preset("swerve")
    assert isinstance(plain, SwerveRobot)
    assert steer_coupling(plain) == pytest.approx(np.zeros(4))
    assert steer_reaches(plain, magnitude, np.zeros(3), np.full(3, 0.05)) == pytest.approx(
        np.full((3, 4), plain.max_steer_rate * 0.05))


def test_coupled_flip_costs_its_speed() -> None:
    # The module's direction reverses at stage 5 (0 -> 3.0 rad): it turns 3.0 rad on, or
    # flips to 3.0 - pi (a 0.14 rad turn, the drive reversed). Only the turn and the
    # speed-weighted flip cost here: an uncoupled module flips; a coupled one turns on
    # when fast (a flip costs 2 x 0.9 > 0.05 x 3.0) and flips when slow.
    weights = BranchWeights(flip=0.0, room=0.0)
    directions: list[float | None] = [0.0 if k < 5 else 3.0 for k in range(16)]
    for coupling, speed, end in ((0.0, 0.9, 3.0 - PI), (1.0, 0.9, 3.0), (1.0, 0.02, 3.0 - PI)):
        path = plan_path(0.0, directions, [speed] * 16, [3.5] * 16, -PI, PI, weights,
                         coupling)
        assert path[:5] == pytest.approx([0.0] * 5)
        assert path[5:] == pytest.approx([end] * 11), (coupling, speed)


def test_fast_winding_asks_for_room_early() -> None:
    # Room asked within 2 rad of a stop (margin). A module at 0.5 rad (2.64 rad from its
    # stop at pi: no room asked by the margin alone) whose direction turns 2 rad along the
    # plan, to 2.5 rad, slow over stages 0-5: with ``spread`` (2 x 2 rad > 2.64) it takes
    # the other branch while slow (ending at 2.5 - pi); with spread 0 it follows on.
    directions: list[float | None] = [0.5 + 2.0 * k / 15 for k in range(16)]
    speeds = [0.02 if k <= 5 else 0.8 for k in range(16)]
    eager = plan_path(0.5, directions, speeds, [0.6] * 16, -PI, PI, BranchWeights(margin=2.0))
    lazy = plan_path(0.5, directions, speeds, [0.6] * 16, -PI, PI,
                     BranchWeights(margin=2.0, spread=0.0))
    assert lazy == pytest.approx([d for d in directions if d is not None])
    assert eager[-1] == pytest.approx(2.5 - PI)
    assert all(-PI <= b <= PI for b in eager)


def test_ipopt_keeps_the_range() -> None:
    # the first 3.5 s: module 3 reaches its stop at 1.5 s and unwinds
    result, low, high = closed_loop(ranged("swerve"), "ipopt", 3.5)
    assert -PI <= low and high <= PI
    metrics = result.metrics()
    assert (metrics["limit_violations"], metrics["accel_violations"],
            metrics["steer_violations"], metrics["failures"]) == (0, 0, 0, 0)
    assert metrics["rms_position_error"] < 0.05
