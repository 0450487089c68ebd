"""The reference window (:mod:`mpc.control.timing`): feedforward twists consistent with the
dynamics, heading wrapping; and the SE(2) logarithm behind the feedforward.

The feedforward twist of stage k is the constant body twist that drives the
model exactly from reference pose k to k + 1 (the SE(2) logarithm); the
independent check is the model's own dynamics (itself checked against RK4 in
test_model.py).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from mpc.control.timing import PROGRESS_TRUST, PathProgress, ReferenceWindow
from mpc.model import (
    DIRECTION_SPEED,
    SMALL_ROTATION,
    TickInput,
    TrackingModel,
    Weights,
    twist_logarithm,
)
from mpc.robots import preset
from trajectories import Circle, FigureEight, SpinHeading, Trajectory, TrajectoryError

DT = 0.05
HORIZON = 10
TWO_PI = 2.0 * math.pi


class Window:
    """A ReferenceWindow and the tick it fills; ``at`` returns copies of what it wrote."""

    def __init__(self, trajectory: Trajectory, model: TrackingModel) -> None:
        self.tick = TickInput(model.layouts)
        self.window = ReferenceWindow(trajectory, model, self.tick)

    def at(self, time: float, heading: float,
           rate: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.window.fill(time, heading, rate)
        tick = self.tick
        return tick.poses_ref.copy(), tick.twists_ref.copy(), tick.directions.copy()


def make_window(trajectory: Trajectory) -> tuple[Window, TrackingModel]:
    model = TrackingModel(preset("omni4"), HORIZON, DT, Weights())
    return Window(trajectory, model), model


def step_model(model: TrackingModel, pose: np.ndarray, twist: np.ndarray) -> np.ndarray:
    return np.asarray(model.dynamics(pose, twist).full()).ravel()


# Heading rate [rad/s] so that |omega dt| sits at interesting places relative to the switch.
TRAJECTORIES = {
    "circle_fixed_heading": Circle(1.0, 12.0, heading=0.3),  # omega = 0 exactly
    "circle_tangent": Circle(1.0, 12.0, heading="tangent"),
    "figure_eight_tangent": FigureEight(1.0, 16.0, heading="tangent"),
    "tiny_spin_below_switch": Circle(1.0, 12.0, heading=SpinHeading(0.5 * SMALL_ROTATION / DT)),
    "spin_just_above_switch": Circle(
        1.0, 12.0, heading=SpinHeading(1.0001 * SMALL_ROTATION / DT)),
    "fast_spin": FigureEight(0.5, 8.0, heading=SpinHeading(6.0, initial=-1.0)),
}


@pytest.mark.parametrize("trajectory", TRAJECTORIES.values(), ids=TRAJECTORIES.keys())
@pytest.mark.parametrize("time", [0.0, 1.37, 7.9])
def test_feedforward_drives_the_model_exactly_from_pose_k_to_k_plus_1(
    trajectory: Trajectory, time: float
) -> None:
    window, model = make_window(trajectory)
    poses, feedforward, _ = window.at(time, heading=float(trajectory.sample(time).pose[2]))
    for k in range(HORIZON):
        np.testing.assert_allclose(step_model(model, poses[k], feedforward[k]), poses[k + 1],
                                   rtol=0, atol=1e-12, err_msg=f"stage {k}")


def test_window_poses_are_the_trajectory_samples() -> None:
    trajectory = TRAJECTORIES["figure_eight_tangent"]
    window, _ = make_window(trajectory)
    poses, _, _ = window.at(2.0, heading=float(trajectory.sample(2.0).pose[2]))
    np.testing.assert_allclose(poses, trajectory.sample(2.0 + DT * np.arange(HORIZON + 1)).pose,
                               atol=1e-15)


def test_feedforward_is_close_to_the_instantaneous_body_twist() -> None:
    """The SE(2) logarithm over one tick is the mid-tick body twist up to O(dt^2)."""
    trajectory = TRAJECTORIES["figure_eight_tangent"]
    window, _ = make_window(trajectory)
    _, feedforward, _ = window.at(3.0, heading=float(trajectory.sample(3.0).pose[2]))
    mid = trajectory.body_twist(3.0 + DT * (np.arange(HORIZON) + 0.5))
    np.testing.assert_allclose(feedforward, mid, atol=2e-3)


def test_rate_plays_the_reference_slower() -> None:
    trajectory = TRAJECTORIES["circle_tangent"]
    window, model = make_window(trajectory)
    poses, feedforward, _ = window.at(1.0, heading=float(trajectory.sample(1.0).pose[2]), rate=0.5)
    expected = trajectory.sample(1.0 + 0.5 * DT * np.arange(HORIZON + 1)).pose
    np.testing.assert_allclose(poses, expected, atol=1e-15)
    # The feedforward still drives the model from pose to pose in one tick (at half speed).
    for k in range(HORIZON):
        np.testing.assert_allclose(step_model(model, poses[k], feedforward[k]), poses[k + 1],
                                   atol=1e-12)


def test_directions_are_unit_directions_of_travel_fading_with_speed() -> None:
    trajectory = TRAJECTORIES["circle_fixed_heading"]
    window, _ = make_window(trajectory)
    _, _, directions = window.at(0.5, heading=0.3)
    velocity = trajectory.sample(0.5 + DT * np.arange(HORIZON + 1)).velocity[:, :2]
    speed = np.linalg.norm(velocity, axis=1, keepdims=True)
    np.testing.assert_allclose(directions, velocity / np.sqrt(speed**2 + DIRECTION_SPEED**2),
                               atol=1e-14)
    # 0.52 m/s against a fading speed of 0.01 m/s: unit length to 2e-4.
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=2e-4)


# Heading wrapping --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("robot_heading", "expected_turns"),
    [
        (TWO_PI * 3 + 0.1, 3),
        (-TWO_PI * 3 - 0.1, -3),
        (TWO_PI * 3 - 0.1, 3),
        (math.pi - 1e-9, 0),  # within pi: unchanged
        (math.pi + 1e-9, 1),  # just past pi: shifted by one turn
        (0.2, 0),
    ],
)
def test_reference_heading_shifted_by_whole_turns_to_within_pi_of_robot(
    robot_heading: float, expected_turns: int
) -> None:
    trajectory = Circle(1.0, 12.0, heading=0.0)
    window, _ = make_window(trajectory)
    poses, feedforward, _ = window.at(0.0, heading=robot_heading)
    raw = trajectory.sample(DT * np.arange(HORIZON + 1)).pose
    np.testing.assert_allclose(poses[:, 2], raw[:, 2] + TWO_PI * expected_turns, atol=1e-12)
    np.testing.assert_array_equal(poses[:, :2], raw[:, :2])
    assert abs(poses[0, 2] - robot_heading) <= math.pi
    # The shift does not change the feedforward.
    unshifted, _ = make_window(trajectory)
    np.testing.assert_allclose(feedforward, unshifted.at(0.0, heading=0.0)[1], atol=1e-12)


def test_heading_wrapping_property_on_random_headings() -> None:
    """For seeded random robot headings and times on a spinning reference, the first
    reference heading lies within pi of the robot's and differs from the trajectory's
    own heading by a whole number of turns; the whole window is shifted alike."""
    trajectory = FigureEight(1.0, 16.0, heading=SpinHeading(2.0, initial=0.5))
    window, _ = make_window(trajectory)
    rng = np.random.default_rng(3)
    for _ in range(50):
        time, heading = rng.uniform(0.0, 30.0), rng.uniform(-60.0, 60.0)
        poses, _, _ = window.at(time, heading=heading)
        raw = trajectory.sample(time + DT * np.arange(HORIZON + 1)).pose[:, 2]
        assert abs(poses[0, 2] - heading) <= math.pi + 1e-12
        turns = (poses[:, 2] - raw) / TWO_PI
        np.testing.assert_allclose(turns, np.round(turns[0]), atol=1e-9)


# twist_logarithm directly (tiny rotations and continuity across its switch) -----------


def logarithm_function() -> ca.Function:
    start, end = ca.SX.sym("a", 3), ca.SX.sym("b", 3)
    return ca.Function("log", [start, end], [twist_logarithm(start, end, DT)])


@pytest.mark.parametrize("rotation", [0.0, 1e-12, 1e-6, 0.999e-3, 1.001e-3, 0.3, -2.9])
def test_twist_logarithm_inverts_the_dynamics(rotation: float) -> None:
    model = TrackingModel(preset("mecanum"), 1, DT, Weights())
    log = logarithm_function()
    rng = np.random.default_rng(9)
    for _ in range(5):
        start = rng.uniform([-2, -2, -4], [2, 2, 4])
        end = start + np.array([*rng.uniform(-0.1, 0.1, 2), rotation])
        twist = np.asarray(log(start, end).full()).ravel()
        np.testing.assert_allclose(step_model(model, start, twist), end, rtol=0, atol=1e-13)


def test_twist_logarithm_continuous_across_its_switch() -> None:
    log = logarithm_function()
    start = np.array([0.2, -0.4, 0.7])
    below = start + np.array([0.03, 0.01, np.nextafter(SMALL_ROTATION, 0.0)])
    above = start + np.array([0.03, 0.01, np.nextafter(SMALL_ROTATION, 1.0)])
    np.testing.assert_allclose(np.asarray(log(start, below).full()),
                               np.asarray(log(start, above).full()), rtol=0, atol=1e-13)


# Path mode's progress ------------------------------------------------------------------


def path_timing(trajectory: Trajectory) -> tuple[PathProgress, TickInput]:
    model = TrackingModel(preset("omni4"), HORIZON, DT, Weights(), path=True)
    tick = TickInput(model.layouts)
    return PathProgress(ReferenceWindow(trajectory, model, tick), model), tick


def test_first_path_tick_samples_on_the_clock_with_the_stated_bounds() -> None:
    trajectory = TRAJECTORIES["figure_eight_tangent"]
    timing, tick = path_timing(trajectory)
    assert tick.path is not None
    start = timing.fill(3.0, 3.1, heading=float(trajectory.sample(3.1).pose[2]))
    clock = 3.1 + DT * np.arange(HORIZON + 1)
    assert start == 3.1
    np.testing.assert_allclose(tick.path.progress_guess, clock)
    np.testing.assert_allclose(tick.poses_ref, trajectory.sample(clock).pose, atol=1e-12)
    np.testing.assert_allclose(tick.path.path_rates, trajectory.sample(clock).velocity)
    assert tick.path.lower[0] == tick.path.upper[0] == 3.1  # s_0 fixed
    np.testing.assert_allclose(tick.path.upper[1:], clock[1:])  # never ahead of the clock
    np.testing.assert_allclose(tick.path.lower[1:], clock[1:] - PROGRESS_TRUST)
    # The feedforward per unit progress rate, at rate 1, is the sampled feedforward.
    np.testing.assert_allclose(tick.path.feedforward_rates, tick.twists_ref)


def test_progress_is_carried_from_the_plan_and_resynchronised_after_a_jump() -> None:
    trajectory = TRAJECTORIES["circle_tangent"]
    timing, tick = path_timing(trajectory)
    timing.fill(0.0, 0.0, heading=0.0)
    plan: np.ndarray = 0.5 * DT * np.arange(HORIZON + 1, dtype=float)  # half the pace
    timing.solved(plan)
    assert timing.refine(plan, 0.0)  # no settled plan yet: the first tick is refined
    timing.solved(plan)
    assert timing.fill(DT, DT, heading=0.0) == pytest.approx(plan[1])
    assert tick.path is not None
    steps = np.diff(tick.path.progress_guess)
    np.testing.assert_allclose(steps, 0.5 * DT)  # the plan's pace, shifted
    assert not timing.refine(tick.path.progress_guess, 0.0)  # settled: no more rounds
    timing.solved(tick.path.progress_guess)
    assert timing.fill(5.0, 5.0, heading=0.0) == 5.0  # t jumped: back on the clock
    assert timing.fill(4.0, 4.0, heading=0.0) == 4.0  # and backwards


def test_a_failed_solve_keeps_the_guess_and_warms_up_again() -> None:
    trajectory = TRAJECTORIES["circle_tangent"]
    timing, tick = path_timing(trajectory)
    timing.fill(0.0, 0.0, heading=0.0)
    timing.solved(DT * np.arange(HORIZON + 1, dtype=float))
    timing.fill(DT, DT, heading=0.0)
    timing.solved(None)  # failure
    assert timing.fill(2 * DT, 2 * DT, heading=0.0) == pytest.approx(2 * DT)
    assert tick.path is not None
    assert timing.refine(tick.path.progress_guess + 1e-2, 0.0)  # warming up again


def test_a_warm_up_round_the_reference_cannot_be_sampled_for_ends_the_warm_up() -> None:
    """A round whose planned progress reaches where the trajectory fails: no round more
    (the last solve stands), nothing written, no TrajectoryError out of the tick."""

    class Failing(Circle):
        """Samples only on the clock's grid (k DT): the first fill's times."""

        def sample(self, t: object) -> object:  # type: ignore[override]
            ticks = np.asarray(t, dtype=float) / DT
            if np.any(np.abs(ticks - np.round(ticks)) > 1e-9):
                raise TrajectoryError("no reference between the ticks")
            return super().sample(t)  # type: ignore[arg-type]

    timing, tick = path_timing(Failing(1.0, 12.0, heading="tangent"))
    timing.fill(0.0, 0.0, heading=0.0)
    assert tick.path is not None
    guess = tick.path.progress_guess.copy()
    poses = tick.poses_ref.copy()
    planned = guess - 0.01  # (behind the clock, within the trust region; s_0 stays)
    assert not timing.refine(planned, 0.0)
    np.testing.assert_array_equal(tick.path.progress_guess, guess)
    np.testing.assert_array_equal(tick.poses_ref, poses)
