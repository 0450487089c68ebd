"""Tests of timed waypoints: splines, holding the end poses, headings and CSV files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from trajectories import (
    SpinHeading,
    TangentHeading,
    TrajectoryError,
    Waypoints,
    read_waypoint_csv,
)

FD_STEP = 1e-6  # [s]

TIMES = np.array([1.0, 2.0, 3.5, 4.0, 6.0])
POSES = np.array(
    [
        [0.0, 0.0, 3.0],
        [1.0, 0.5, -3.0],  # unwraps to 2 pi - 3 = 3.28
        [2.0, 2.0, -2.5],
        [2.5, 2.2, 0.0],
        [4.0, 1.0, 1.0],
    ]
)


def _inside_times(seed: int, count: int = 40) -> np.ndarray:
    return np.random.default_rng(seed).uniform(TIMES[0], TIMES[-1], count)


def test_spline_matches_scipy_clamped_cubic_spline() -> None:
    waypoints = Waypoints(TIMES, POSES)
    times = np.concatenate((_inside_times(1), TIMES))
    sample = waypoints.sample(times)
    path = waypoints.path(times)
    xy = CubicSpline(TIMES, POSES[:, :2], bc_type="clamped", axis=0)
    theta = CubicSpline(TIMES, np.unwrap(POSES[:, 2]), bc_type="clamped")
    np.testing.assert_allclose(sample.pose[:, :2], xy(times), atol=1e-12)
    np.testing.assert_allclose(sample.velocity[:, :2], xy.derivative(1)(times), atol=1e-12)
    np.testing.assert_allclose(sample.acceleration[:, :2], xy.derivative(2)(times), atol=1e-12)
    np.testing.assert_allclose(path.jerk, xy.derivative(3)(times), atol=1e-12)
    np.testing.assert_allclose(sample.pose[:, 2], theta(times), atol=1e-12)
    np.testing.assert_allclose(sample.velocity[:, 2], theta.derivative(1)(times), atol=1e-12)
    np.testing.assert_allclose(sample.acceleration[:, 2], theta.derivative(2)(times), atol=1e-12)


def test_passes_through_the_waypoints_at_rest_at_the_ends() -> None:
    waypoints = Waypoints(TIMES, POSES)
    sample = waypoints.sample(TIMES)
    expected = POSES.copy()
    expected[:, 2] = np.unwrap(POSES[:, 2])
    np.testing.assert_allclose(sample.pose, expected, atol=1e-12)
    np.testing.assert_allclose(sample.velocity[[0, -1]], 0.0, atol=1e-12)


def test_theta_column_is_unwrapped() -> None:
    waypoints = Waypoints([0.0, 1.0], [[0.0, 0.0, 3.1], [1.0, 0.0, -3.1]])
    thetas = waypoints.sample(np.linspace(0.0, 1.0, 11)).pose[:, 2]
    assert thetas[-1] == pytest.approx(2 * math.pi - 3.1)
    assert np.all(np.diff(thetas) >= 0.0)  # turns the short way, by 0.08 rad


@pytest.mark.parametrize(
    "heading", [None, 0.4, "tangent", TangentHeading(1.0), SpinHeading(0.7, 0.1), np.sin]
)
def test_derivatives_match_finite_differences(heading: object) -> None:
    waypoints = Waypoints(TIMES, POSES, heading=heading)  # type: ignore[arg-type]
    times = _inside_times(2)
    now = waypoints.sample(times)
    after, before = waypoints.sample(times + FD_STEP), waypoints.sample(times - FD_STEP)
    np.testing.assert_allclose(
        now.velocity, (after.pose - before.pose) / (2 * FD_STEP), rtol=1e-6, atol=1e-6
    )
    np.testing.assert_allclose(
        now.acceleration, (after.velocity - before.velocity) / (2 * FD_STEP), rtol=1e-5, atol=1e-4
    )
    path_after, path_before = waypoints.path(times + FD_STEP), waypoints.path(times - FD_STEP)
    np.testing.assert_allclose(
        waypoints.path(times).jerk,
        (path_after.acceleration - path_before.acceleration) / (2 * FD_STEP),
        rtol=1e-6,
        atol=1e-5,
    )


@pytest.mark.parametrize("heading", [None, 0.4, "tangent", SpinHeading(0.7, 0.1)])
def test_end_poses_are_held_outside_the_span(heading: object) -> None:
    waypoints = Waypoints(TIMES, POSES, heading=heading)  # type: ignore[arg-type]
    first, last = waypoints.sample(TIMES[0]), waypoints.sample(TIMES[-1])
    before = waypoints.sample(np.array([-100.0, 0.0, TIMES[0] - 1e-9]))
    after = waypoints.sample(np.array([TIMES[-1] + 1e-9, 7.0, 1e4]))
    np.testing.assert_allclose(before.pose, np.tile(first.pose, (3, 1)))
    np.testing.assert_allclose(after.pose, np.tile(last.pose, (3, 1)))
    for held in (before, after):
        np.testing.assert_array_equal(held.velocity, 0.0)
        np.testing.assert_array_equal(held.acceleration, 0.0)
    assert np.all(waypoints.path(np.array([0.0, 9.0])).jerk == 0.0)


def test_time_properties() -> None:
    waypoints = Waypoints(TIMES, POSES)
    assert waypoints.start_time == 1.0
    assert waypoints.end_time == 6.0
    assert waypoints.duration == 5.0
    assert waypoints.period is None
    np.testing.assert_array_equal(waypoints.times, TIMES)
    np.testing.assert_array_equal(waypoints.poses, POSES)
    with pytest.raises(ValueError):
        waypoints.poses[0, 0] = 1.0


def test_tangent_heading_along_waypoints() -> None:
    waypoints = Waypoints(TIMES, POSES, heading="tangent")
    times = np.linspace(TIMES[0] - 1.0, TIMES[-1] + 1.0, 2001)
    separate = np.array([waypoints.sample(float(t)).pose[2] for t in times[::10]])
    together = waypoints.sample(times)
    np.testing.assert_allclose(separate, together.pose[::10, 2], atol=1e-12)
    assert np.abs(np.diff(together.pose[:, 2])).max() < 0.05  # no 2 pi jumps, even at rest

    moving = (times > TIMES[0]) & (times < TIMES[-1])
    velocity = together.velocity[moving]
    tangent = np.arctan2(velocity[:, 1], velocity[:, 0])
    difference = np.angle(np.exp(1j * (together.pose[moving, 2] - tangent)))
    np.testing.assert_allclose(difference, 0.0, atol=1e-9)


def test_tangent_heading_at_the_resting_ends_is_the_limit_direction() -> None:
    waypoints = Waypoints([0.0, 2.0], [[0.0, 0.0, 0.0], [-1.0, -1.0, 0.0]], heading="tangent")
    start, end = waypoints.sample(0.0), waypoints.sample(2.0)
    assert start.pose[2] == pytest.approx(-3 * math.pi / 4)
    assert end.pose[2] == pytest.approx(-3 * math.pi / 4)
    assert start.velocity[2] == 0.0 and end.velocity[2] == 0.0


def test_tangent_heading_refuses_a_path_that_stops_midway() -> None:
    times = [0.0, 1.0, 2.0, 3.0]
    poses = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
    with pytest.raises(TrajectoryError, match="tangent heading needs a path whose direction"):
        Waypoints(times, poses, heading="tangent")
    with pytest.raises(TrajectoryError, match="tangent heading needs a moving path"):
        Waypoints([0.0, 1.0], [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0]], heading="tangent")


def test_two_waypoints() -> None:
    waypoints = Waypoints([0.0, 2.0], [[0.0, 0.0, 0.0], [2.0, 0.0, 1.0]])
    middle = waypoints.sample(1.0)
    np.testing.assert_allclose(middle.pose, [1.0, 0.0, 0.5])
    np.testing.assert_allclose(middle.velocity, [1.5, 0.0, 0.75])  # smoothstep peak


@pytest.mark.parametrize(
    ("times", "poses", "message"),
    [
        ([0.0], [[0.0, 0.0, 0.0]], r"at least 2 times .* got shape \(1,\)"),
        ([[0.0, 1.0]], [[0.0, 0.0, 0.0]] * 2, r"1-D array of at least 2 times"),
        ([0.0, math.nan], [[0.0, 0.0, 0.0]] * 2, r"must be finite .* times\[1\]=nan"),
        ([0.0, "b"], [[0.0, 0.0, 0.0]] * 2, r"waypoint times must be a 1-D array of finite"),
        ([0.0, 1.0, 1.0], [[0.0, 0.0, 0.0]] * 3, r"strictly increasing, got times\[2\]=1.0 after"),
        ([0.0, 2.0, 1.0], [[0.0, 0.0, 0.0]] * 3, r"times\[2\]=1.0 after times\[1\]=2.0"),
        ([0.0, 1.0], [[0.0, 0.0]] * 2, r"shape \(2, 3\) .* got shape \(2, 2\)"),
        ([0.0, 1.0], [[0.0, 0.0, 0.0]] * 3, r"shape \(2, 3\) .* got shape \(3, 3\)"),
        ([0.0, 1.0], [[0.0, 0.0, 0.0], [0.0, math.inf, 0.0]], r"poses\[1, 1\]=inf"),
        ([0.0, 1.0], "path", r"waypoint poses must be an array of shape \(2, 3\)"),
    ],
)
def test_constructor_validation(times: object, poses: object, message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        Waypoints(times, poses)  # type: ignore[arg-type]


def test_bad_heading_is_rejected() -> None:
    with pytest.raises(TrajectoryError, match="heading must be"):
        Waypoints(TIMES, POSES, heading="interpolate")


# --- CSV ------------------------------------------------------------------------------


def test_csv_round_trip(tmp_path: Path) -> None:
    original = Waypoints(TIMES + 0.1, POSES + 1e-3)
    file = tmp_path / "path.csv"
    original.to_csv(file)
    assert file.read_text().splitlines()[0] == "t,x,y,theta"
    loaded = Waypoints.from_csv(file)
    np.testing.assert_array_equal(loaded.times, original.times)
    np.testing.assert_array_equal(loaded.poses, original.poses)
    times = np.linspace(0.0, 7.0, 31)
    np.testing.assert_array_equal(loaded.sample(times).pose, original.sample(times).pose)


def test_csv_columns_in_any_order_extra_columns_and_blank_lines(tmp_path: Path) -> None:
    file = tmp_path / "shuffled.csv"
    file.write_text(
        "speed, Theta ,y,x, T\n9,0.5,0.0,0.0,0.0\n\n9,0.25,1.0,2.0,1.5\n9,0.0,3.0,4.0,3.0\n"
    )
    times, poses = read_waypoint_csv(file)
    np.testing.assert_array_equal(times, [0.0, 1.5, 3.0])
    np.testing.assert_array_equal(poses, [[0.0, 0.0, 0.5], [2.0, 1.0, 0.25], [4.0, 3.0, 0.0]])
    waypoints = Waypoints.from_csv(str(file), heading=SpinHeading(1.0))
    assert waypoints.sample(1.0).pose[2] == pytest.approx(1.0)


def test_csv_theta_is_optional(tmp_path: Path) -> None:
    file = tmp_path / "no_theta.csv"
    file.write_text("t,x,y\n0,0,0\n1,1,0\n")
    waypoints = Waypoints.from_csv(file)
    np.testing.assert_array_equal(waypoints.poses[:, 2], 0.0)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", r"is empty, expected a header row"),
        ("\n\n", r"is empty"),
        ("t,x,theta\n0,0,0\n1,1,0\n", r"missing column\(s\) y"),
        ("time,x,y\n0,0,0\n1,1,0\n", r"missing column\(s\) t"),
        ("t,x,y,x\n0,0,0,0\n1,1,0,0\n", r"column 'x' more than once"),
        ("t,x,y\n0,0,0\n1,one,0\n", r"line 3, column 'x': expected a number, got 'one'"),
        ("t,x,y\n0,0,0\n1,,0\n", r"line 3, column 'x': expected a number, got ''"),
        ("t,x,y,theta\n0,0,0,nan\n1,1,0,0\n", r"line 2, column 'theta': expected a finite number"),
        ("t,x,y\n0,0,0\n1,1\n", r"line 3: expected at least 3 fields .* got 2"),
        ("t,x,y\n0,0,0\n", r"needs at least 2 waypoint rows, got 1"),
        ("t,x,y\n", r"needs at least 2 waypoint rows, got 0"),
        ("t,x,y\n0,0,0\n1,1,0\n\n1,2,0\n", r"line 5 has t=1.0 after t=1.0 on line 3"),
        ("t,x,y\n0,0,0\n2,1,0\n1,2,0\n", r"strictly increasing, but line 4 has t=1.0 after t=2.0"),
    ],
)
def test_csv_validation(tmp_path: Path, text: str, message: str) -> None:
    file = tmp_path / "bad.csv"
    file.write_text(text)
    with pytest.raises(TrajectoryError, match=message):
        Waypoints.from_csv(file)


def test_csv_missing_file(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.csv"
    with pytest.raises(TrajectoryError, match=r"waypoint file '.*nowhere.csv' does not exist"):
        Waypoints.from_csv(missing)


def test_csv_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(TrajectoryError, match="cannot read waypoint file"):
        Waypoints.from_csv(tmp_path)  # a directory
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"\xff\xfe\x00t,x,y")
    with pytest.raises(TrajectoryError, match=r"waypoint file .*binary\.csv' is not UTF-8"):
        Waypoints.from_csv(binary)
