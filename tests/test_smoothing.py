"""Smoothing a path within tolerances (``path_reference(position_tolerance=,
yaw_tolerance=)``, :mod:`trajectories.smoothing`).

Independent answers: the tolerances checked pose by pose against the poses given; the
lap of the path before it was snapped to a grid (smooth by construction) as the yardstick
for the smoothed one; a turn in place and the ends compared with the poses given.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.retiming_cases import _snapped
from mpc.adapters.ros import Nav2Controller
from mpc.errors import ControllerError, TrajectoryError
from mpc.robots import preset
from trajectories import SampledTrajectory, path_reference
from trajectories.smoothing import MIN_POSES, smooth_poses


def _with_turn_in_place(poses: np.ndarray, at: int) -> np.ndarray:
    """``poses`` with a quarter turn in place inserted after pose ``at``."""
    turned = poses[at].copy()
    turned[2] += math.pi / 2
    return np.vstack([poses[:at + 1], turned, poses[at + 1:] + [0.0, 0.0, math.pi / 2]])


def test_smoothed_poses_keep_within_the_tolerances_and_pinned_ones_exact() -> None:
    """A snapped S with a turn in place: every smoothed pose within 0.025 m and 0.4 rad of
    the one given; the ends and the two poses of the turn exactly as given; 0 for a
    tolerance leaves that part as it is; a path too short for a smoothing spline too."""
    poses = _with_turn_in_place(_snapped(200), 100)
    poses[:, 2] = np.unwrap(poses[:, 2])
    pinned = np.zeros(len(poses), dtype=bool)
    pinned[[0, 100, 101, -1]] = True
    smoothed = smooth_poses(poses, 0.025, 0.4, pinned)
    moved = np.hypot(*(smoothed[:, :2] - poses[:, :2]).T)
    assert moved.max() <= 0.025 and np.abs(smoothed[:, 2] - poses[:, 2]).max() <= 0.4
    assert moved.max() > 0.01  # it did smooth: the snap moved poses by up to 2.5 cm
    np.testing.assert_array_equal(smoothed[pinned], poses[pinned])
    positions_only = smooth_poses(poses, 0.025, 0.0, pinned)
    np.testing.assert_array_equal(positions_only[:, 2], poses[:, 2])
    np.testing.assert_array_equal(smooth_poses(poses, 0.0, 0.0, pinned), poses)
    short = poses[:MIN_POSES - 1]
    np.testing.assert_array_equal(smooth_poses(short, 0.025, 0.4, pinned[:len(short)]), short)


def test_a_snapped_path_smoothed_is_timed_about_as_the_path_before_the_snap() -> None:
    """400 poses of a gentle S snapped to a 5 cm grid (``python -m
    benchmarks.retiming_cases``' smoothing case, which the README quotes): the splines
    through every pose bend at every cell and the time-optimal lap takes 5.9x the unsnapped
    path's (measured: 130.0 against 22.0 s); smoothed within half a cell and 0.4 rad,
    within 5 % of it."""
    from benchmarks.retiming_cases import smoothing

    lines: list[str] = []
    as_given, smoothed, before = smoothing(lines.append, counts=(400,))[400]
    assert as_given > 4.0 * before
    assert smoothed <= 1.05 * before
    assert len(lines) == 1 and "400 poses on a 5 cm grid" in lines[0]


def test_the_smoothed_geometry_passes_through_its_knots_within_the_tolerances() -> None:
    """With ``speed=`` the geometry itself: its knots (the smoothed poses) within the
    tolerances of the poses given, a turn in place kept (its position held while it turns),
    and a goal that ends by turning still exact."""
    poses = _with_turn_in_place(_snapped(120), 60)
    poses = np.vstack([poses, poses[-1] + [0.0, 0.0, 1.0]])  # the goal: a turn at the end
    geometry = path_reference(poses, speed=0.5, position_tolerance=0.02, yaw_tolerance=0.3)
    assert isinstance(geometry, SampledTrajectory)
    given = poses.copy()
    given[:, 2] = np.unwrap(given[:, 2])
    knots = geometry.poses
    assert len(knots) == len(given)
    assert np.hypot(*(knots[:, :2] - given[:, :2]).T).max() <= 0.02
    assert np.abs(knots[:, 2] - given[:, 2]).max() <= 0.3
    np.testing.assert_allclose(knots[[0, 60, 61, -2, -1]], given[[0, 60, 61, -2, -1]],
                               rtol=0.0, atol=1e-12)  # (yaw unwrapped again: rounding)
    turn = np.linspace(geometry.times[60], geometry.times[61], 50)
    held = geometry.sample(turn).pose[:, :2]
    np.testing.assert_allclose(held, np.broadcast_to(knots[60, :2], held.shape), atol=1e-12)


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf, True, "0.1"])
def test_bad_tolerances_are_refused(bad: object) -> None:
    poses = _snapped(20)
    with pytest.raises(TrajectoryError, match="position_tolerance \\[m\\] must be a finite "
                                              "number >= 0"):
        path_reference(poses, speed=1.0, position_tolerance=bad)  # type: ignore[arg-type]
    with pytest.raises(TrajectoryError, match="yaw_tolerance \\[rad\\] must be a finite "
                                              "number >= 0"):
        path_reference(poses, speed=1.0, yaw_tolerance=bad)  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match="position_tolerance \\[m\\] must be a finite "
                                              "number >= 0"):
        Nav2Controller(preset("mecanum"), position_tolerance=bad)  # type: ignore[arg-type]


def test_nav2_controller_smooths_its_plans_when_told() -> None:
    """``Nav2Controller(position_tolerance=, yaw_tolerance=)``: the plan it times is the
    smoothed path's (the same lap as ``path_reference`` with them gives)."""
    from types import SimpleNamespace

    from trajectories.rosbag import quaternion_from_yaw

    poses = _snapped(200)

    def message(rows: np.ndarray) -> SimpleNamespace:
        def pose(x: float, y: float, yaw: float) -> SimpleNamespace:
            qx, qy, qz, qw = quaternion_from_yaw(yaw)
            return SimpleNamespace(pose=SimpleNamespace(
                position=SimpleNamespace(x=x, y=y, z=0.0),
                orientation=SimpleNamespace(x=qx, y=qy, z=qz, w=qw)))
        return SimpleNamespace(header=SimpleNamespace(frame_id="map"),
                               poses=[pose(*row) for row in rows])

    mecanum = preset("mecanum")
    plain = Nav2Controller(mecanum, max_speed=1.0)
    smooth = Nav2Controller(mecanum, max_speed=1.0, position_tolerance=0.025,
                            yaw_tolerance=0.4)
    plain.set_plan(message(poses))
    smooth.set_plan(message(poses))
    assert smooth.tolerances == (0.025, 0.4) and plain.tolerances == (0.0, 0.0)
    assert smooth.trajectory.duration is not None and plain.trajectory.duration is not None
    assert smooth.trajectory.duration < 0.5 * plain.trajectory.duration
