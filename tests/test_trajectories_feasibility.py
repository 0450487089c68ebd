"""Tests of the wheel-speed feasibility check, on a fake Mecanum robot."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from trajectories import (
    Circle,
    FeasibilityReport,
    FigureEight,
    PathDerivatives,
    SpinHeading,
    Trajectory,
    TrajectoryError,
    Waypoints,
    feasibility,
)


@dataclass(frozen=True)
class FakeMecanum:
    """Mecanum inverse kinematics (README, Conventions), order FL, FR, RL, RR."""

    wheel_radius: float = 0.05  # [m]
    half_wheelbase: float = 0.15  # lx [m]
    half_track: float = 0.125  # ly [m]
    max_wheel_speed: np.ndarray = field(default_factory=lambda: np.full(4, 30.0))  # [rad/s]

    def wheel_speeds(self, twists: np.ndarray) -> np.ndarray:
        reach = self.half_wheelbase + self.half_track
        jacobian = np.array(
            [[1.0, -1.0, -reach], [1.0, 1.0, reach], [1.0, 1.0, -reach], [1.0, -1.0, reach]]
        )
        return twists @ jacobian.T / self.wheel_radius


def test_fake_robot_reproduces_the_worked_check_values() -> None:
    robot = FakeMecanum()
    surface = robot.wheel_speeds(np.eye(3)) * robot.wheel_radius
    np.testing.assert_allclose(
        surface,
        [[1.0, 1.0, 1.0, 1.0], [-1.0, 1.0, 1.0, -1.0], [-0.275, 0.275, -0.275, 0.275]],
    )


@pytest.mark.parametrize("speed", [1.0, 1.5])
def test_circle_with_fixed_heading(speed: float) -> None:
    # Heading 0: body twist = world velocity = v (-sin, cos), omega = 0. Surface speeds
    # FL = RR = vx - vy = -v (sin + cos) peak at v sqrt(2) when w t = pi/4 (mod pi), and
    # FR = RL = vx + vy = v (cos - sin) when w t = 3 pi/4 (mod pi).
    robot = FakeMecanum()
    circle = Circle.with_speed(1.0, speed, heading=0.0)
    report = feasibility(circle, robot)
    expected = speed * math.sqrt(2.0) / (robot.wheel_radius * 30.0)
    assert report.peak_ratio == pytest.approx(expected, rel=1e-12)
    assert report.is_feasible == (expected <= 1.0)
    period = circle.period
    eighths = report.time / (period / 8)  # w t = eighths * pi / 4
    assert eighths == pytest.approx(round(eighths), abs=1e-9)
    assert round(eighths) % 2 == 1
    assert report.wheel in ((0, 3) if round(eighths) % 4 == 1 else (1, 2))
    assert report.ratios.shape == (2001,) and report.times.shape == (2001,)
    assert report.times[0] == 0.0 and report.times[-1] == pytest.approx(period)
    assert report.ratios.max() == report.peak_ratio
    assert report.ratios.min() == pytest.approx(speed / (robot.wheel_radius * 30.0), rel=1e-4)


def test_circle_with_tangent_heading_has_constant_demand() -> None:
    # body twist (v, 0, w): FR and RR surface speed v + (lx + ly) w
    robot = FakeMecanum()
    circle = Circle(2.0, 8.0, heading="tangent")
    w = 2.0 * math.pi / 8.0
    expected = (2.0 * w + 0.275 * w) / (0.05 * 30.0)
    report = feasibility(circle, robot, samples=101)
    np.testing.assert_allclose(report.ratios, expected, rtol=1e-9)
    assert report.wheel in (1, 3)
    assert isinstance(report, FeasibilityReport)


def test_spinning_demands_more_than_a_fixed_heading() -> None:
    robot = FakeMecanum()
    fixed = feasibility(FigureEight(1.0, 10.0, heading=0.0), robot)
    spinning = feasibility(FigureEight(1.0, 10.0, heading=SpinHeading(3.0)), robot)
    assert spinning.peak_ratio > fixed.peak_ratio
    # the spin term alone: (lx + ly) * 3 rad/s on top of the path speed at some wheel
    assert spinning.peak_ratio <= fixed.peak_ratio + 0.275 * 3.0 / (0.05 * 30.0) + 1e-12


def test_per_wheel_limits_pick_the_weakest_wheel() -> None:
    limits = np.array([30.0, 30.0, 30.0, 10.0])
    robot = FakeMecanum(max_wheel_speed=limits)
    report = feasibility(Circle.with_speed(1.0, 1.0), robot)
    assert report.wheel == 3
    assert report.peak_ratio == pytest.approx(math.sqrt(2.0) / (0.05 * 10.0))


def test_failed_wheel_with_limit_zero() -> None:
    robot = FakeMecanum(max_wheel_speed=np.array([30.0, 30.0, 0.0, 30.0]))
    report = feasibility(Circle.with_speed(1.0, 1.0), robot)
    assert report.peak_ratio == math.inf and report.wheel == 2
    assert not report.is_feasible
    # moving along body (1, -1) leaves RL (vx + vy - (lx + ly) omega) at rest
    diagonal = Waypoints([0.0, 2.0], [[0.0, 0.0, 0.0], [1.0, -1.0, 0.0]], heading=0.0)
    report = feasibility(diagonal, robot)
    assert report.is_feasible
    assert report.peak_ratio == pytest.approx(0.75 * 2.0 / (0.05 * 30.0))  # FL, RR: vx - vy


def test_one_shared_limit() -> None:
    shared = feasibility(Circle(1.0, 5.0), FakeMecanum(max_wheel_speed=np.array(30.0)))
    per_wheel = feasibility(Circle(1.0, 5.0), FakeMecanum())
    assert shared.peak_ratio == per_wheel.peak_ratio


def test_waypoints_default_to_their_span() -> None:
    waypoints = Waypoints([2.0, 4.0], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    report = feasibility(waypoints, FakeMecanum(), samples=201)
    assert report.times[0] == 2.0 and report.times[-1] == 4.0
    # smoothstep x(t): peak speed 1.5 * 1 m / 2 s at the middle
    assert report.peak_ratio == pytest.approx(0.75 / (0.05 * 30.0))
    assert report.time == pytest.approx(3.0)


def test_explicit_duration() -> None:
    report = feasibility(Circle(1.0, 4.0), FakeMecanum(), duration=0.5, samples=11)
    np.testing.assert_allclose(report.times, np.linspace(0.0, 0.5, 11))


class _Endless(Trajectory):
    def _path(self, t: np.ndarray) -> PathDerivatives:
        zero = np.zeros(np.shape(t) + (2,))
        velocity = zero.copy()
        velocity[..., 0] = 1.0
        position = velocity * np.asarray(t)[..., np.newaxis]
        return PathDerivatives(position, velocity, zero, zero)


def test_endless_trajectory_needs_a_duration() -> None:
    with pytest.raises(TrajectoryError, match="needs a duration"):
        feasibility(_Endless(0.0), FakeMecanum())
    report = feasibility(_Endless(0.0), FakeMecanum(), duration=3.0)
    assert report.peak_ratio == pytest.approx(1.0 / 1.5)


class _WrongShapeRobot:
    max_wheel_speed = np.ones(4)

    def wheel_speeds(self, twists: np.ndarray) -> np.ndarray:
        return np.zeros((len(twists), 4, 1))


@pytest.mark.parametrize(
    ("kwargs", "robot", "message"),
    [
        ({"samples": 1}, FakeMecanum(),
         r"samples must be an integer from 2 to 1000000 \(times checked; .*got 1"),
        ({"samples": 10.0}, FakeMecanum(),
         r"samples must be an integer from 2 to 1000000 .*got 10.0"),
        ({"samples": True}, FakeMecanum(), r"samples must be an integer from 2 to 1000000"),
        ({"duration": -1.0}, FakeMecanum(), r"duration \[s\] must be a finite number > 0"),
        ({"duration": math.nan}, FakeMecanum(), r"duration \[s\] must be a finite number > 0"),
        ({}, _WrongShapeRobot(), r"wheel_speeds must return an array of shape \(2001, n_wheels\)"),
        ({}, FakeMecanum(max_wheel_speed=np.ones(3)), r"max_wheel_speed must be 4 finite limits"),
        ({}, FakeMecanum(max_wheel_speed=-np.ones(4)), r"max_wheel_speed must be 4 finite limits"),
        ({}, FakeMecanum(max_wheel_speed=np.full(4, np.nan)), r"finite limits >= 0 \[rad/s\]"),
    ],
)
def test_feasibility_validation(kwargs: dict[str, object], robot: object, message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        feasibility(Circle(1.0, 1.0), robot, **kwargs)  # type: ignore[arg-type]
