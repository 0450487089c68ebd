"""Tests of trajectories: circle, figure-eight, heading profiles and body twists.

Known answers are hand-derived values and central finite differences at
seeded random times; invariants are checked with hypothesis (derandomized).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trajectories import (
    Circle,
    FigureEight,
    FixedHeading,
    FunctionHeading,
    HeadingProfile,
    HeadingSpec,
    PathDerivatives,
    SpinHeading,
    TangentHeading,
    Trajectory,
    TrajectoryError,
    TrajectorySample,
    body_twist,
    make_heading,
)

TWO_PI = 2.0 * math.pi
FD_STEP = 1e-6  # [s] central differences in the tests

PROPERTY_SETTINGS = settings(max_examples=40, deadline=None, derandomize=True, database=None)


def _angle(t: np.ndarray) -> np.ndarray:
    return 0.3 * np.sin(1.7 * t) + 0.2 * t


def _rate(t: np.ndarray) -> np.ndarray:
    return 0.51 * np.cos(1.7 * t) + 0.2


def _accel(t: np.ndarray) -> np.ndarray:
    return -0.867 * np.sin(1.7 * t)


HEADINGS: dict[str, HeadingSpec] = {
    "float": 0.3,
    "fixed": "fixed",
    "tangent": "tangent",
    "tangent-offset": TangentHeading(offset=-0.7),
    "spin": SpinHeading(rate=1.3, initial=0.2),
    "function": FunctionHeading(_angle),
    "function-rate": FunctionHeading(_angle, rate=_rate),
    "function-all": FunctionHeading(_angle, rate=_rate, accel=_accel),
    "callable": _angle,
}

SHAPES: dict[str, Callable[..., Trajectory]] = {
    "circle": lambda heading: Circle(1.3, 7.0, center=(0.4, -0.2), heading=heading, phase=0.3),
    "figure-eight": lambda heading: FigureEight(0.9, 6.0, center=(-1.0, 0.5), heading=heading),
}


def _random_times(seed: int, count: int = 25) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-10.0, 20.0, count)


# --- hand-derived values -------------------------------------------------------------


def test_circle_at_zero_and_quarter_period() -> None:
    radius, period, center = 2.0, 8.0, np.array([1.0, -3.0])
    w = TWO_PI / period
    circle = Circle(radius, period, center=center, heading=0.25)

    start = circle.sample(0.0)
    np.testing.assert_allclose(start.pose, [3.0, -3.0, 0.25], atol=1e-12)
    np.testing.assert_allclose(start.velocity, [0.0, radius * w, 0.0], atol=1e-12)
    np.testing.assert_allclose(start.acceleration, [-radius * w**2, 0.0, 0.0], atol=1e-12)

    quarter = circle.sample(period / 4.0)
    np.testing.assert_allclose(quarter.pose, [1.0, -1.0, 0.25], atol=1e-12)
    np.testing.assert_allclose(quarter.velocity, [-radius * w, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(quarter.acceleration, [0.0, -radius * w**2, 0.0], atol=1e-12)

    jerk = circle.path(0.0).jerk
    np.testing.assert_allclose(jerk, [0.0, -radius * w**3], atol=1e-12)


def test_circle_phase_moves_the_start_point() -> None:
    circle = Circle(1.0, 4.0, phase=math.pi / 2)
    np.testing.assert_allclose(circle.sample(0.0).pose[:2], [0.0, 1.0], atol=1e-12)


def test_circle_tangent_heading_hand_values() -> None:
    period = 5.0
    w = TWO_PI / period
    circle = Circle(1.5, period, heading="tangent")
    start = circle.sample(0.0)
    assert start.pose[2] == pytest.approx(math.pi / 2)
    assert start.velocity[2] == pytest.approx(w)
    assert start.acceleration[2] == pytest.approx(0.0, abs=1e-12)
    assert circle.sample(period / 4).pose[2] == pytest.approx(math.pi)
    # heading grows without bound: w t + pi/2
    assert circle.sample(1000.3 * period).pose[2] == pytest.approx(
        w * 1000.3 * period + math.pi / 2
    )
    assert circle.sample(-2.25 * period).pose[2] == pytest.approx(-w * 2.25 * period + math.pi / 2)


def test_figure_eight_at_zero_and_quarter_period() -> None:
    amplitude, period = 1.2, 9.0
    w = TWO_PI / period
    eight = FigureEight(amplitude, period, center=(0.5, 0.25), heading="tangent")

    start = eight.sample(0.0)
    np.testing.assert_allclose(start.pose, [0.5, 0.25, math.pi / 4], atol=1e-12)
    np.testing.assert_allclose(start.velocity[:2], [amplitude * w, amplitude * w], atol=1e-12)
    np.testing.assert_allclose(start.acceleration[:2], [0.0, 0.0], atol=1e-12)
    jerk = eight.path(0.0).jerk
    np.testing.assert_allclose(jerk, [-amplitude * w**3, -4.0 * amplitude * w**3], atol=1e-12)
    # thetadot = cross(v, a) / |v|^2 = 0; thetaddot = cross(v, j) / |v|^2 = -1.5 w^2
    assert start.velocity[2] == pytest.approx(0.0, abs=1e-12)
    assert start.acceleration[2] == pytest.approx(-1.5 * w**2)

    quarter = eight.sample(period / 4)
    np.testing.assert_allclose(quarter.pose[:2], [0.5 + amplitude, 0.25], atol=1e-12)
    np.testing.assert_allclose(quarter.velocity[:2], [0.0, -amplitude * w], atol=1e-12)
    np.testing.assert_allclose(quarter.acceleration[:2], [-amplitude * w**2, 0.0], atol=1e-12)


def test_max_speed_and_with_speed() -> None:
    circle = Circle.with_speed(2.0, 1.5, heading="tangent", center=(1.0, 1.0))
    assert circle.period == pytest.approx(TWO_PI * 2.0 / 1.5)
    assert circle.max_speed == pytest.approx(1.5)
    assert isinstance(circle.heading, TangentHeading)
    speeds = np.linalg.norm(
        circle.sample(np.linspace(0.0, circle.period, 101)).velocity[:, :2], axis=1
    )
    np.testing.assert_allclose(speeds, 1.5)

    eight = FigureEight.with_speed(0.8, 1.1, heading=0.5)
    assert eight.max_speed == pytest.approx(1.1)
    grid = np.linspace(0.0, eight.period, 4001)
    speeds = np.linalg.norm(eight.sample(grid).velocity[:, :2], axis=1)
    assert speeds.max() == pytest.approx(1.1, rel=1e-9)


def test_time_properties_of_periodic_shapes() -> None:
    for shape in SHAPES.values():
        trajectory = shape(0.0)
        assert trajectory.period is not None and trajectory.period > 0
        assert trajectory.duration is None
        assert trajectory.end_time is None
        assert trajectory.start_time == 0.0


def test_periodic_shapes_repeat() -> None:
    times = _random_times(7)
    for shape in SHAPES.values():
        trajectory = shape("tangent")
        period = trajectory.period
        assert period is not None
        now, later = trajectory.sample(times), trajectory.sample(times + period)
        np.testing.assert_allclose(later.pose[:, :2], now.pose[:, :2], atol=1e-9)
        np.testing.assert_allclose(later.velocity, now.velocity, atol=1e-9)


# --- finite differences ---------------------------------------------------------------


@pytest.mark.parametrize("heading_name", sorted(HEADINGS))
@pytest.mark.parametrize("shape_name", sorted(SHAPES))
def test_derivatives_match_finite_differences(shape_name: str, heading_name: str) -> None:
    trajectory = SHAPES[shape_name](HEADINGS[heading_name])
    times = _random_times(seed=len(shape_name) * 31 + len(heading_name))
    now = trajectory.sample(times)
    after, before = trajectory.sample(times + FD_STEP), trajectory.sample(times - FD_STEP)
    velocity_fd = (after.pose - before.pose) / (2 * FD_STEP)
    acceleration_fd = (after.velocity - before.velocity) / (2 * FD_STEP)
    np.testing.assert_allclose(now.velocity, velocity_fd, rtol=1e-6, atol=1e-6)
    # a heading rate that is itself a finite difference (h = 1e-5 s) carries ~1e-10 rad/s
    # of rounding noise, which a second difference with step 1e-6 s amplifies
    heading_tolerance = 5e-4 if heading_name in ("function", "callable") else 1e-5
    np.testing.assert_allclose(
        now.acceleration[:, :2], acceleration_fd[:, :2], rtol=1e-5, atol=1e-5
    )
    np.testing.assert_allclose(
        now.acceleration[:, 2], acceleration_fd[:, 2], rtol=1e-5, atol=heading_tolerance
    )

    path, path_after, path_before = (
        trajectory.path(times),
        trajectory.path(times + FD_STEP),
        trajectory.path(times - FD_STEP),
    )
    jerk_fd = (path_after.acceleration - path_before.acceleration) / (2 * FD_STEP)
    np.testing.assert_allclose(path.jerk, jerk_fd, rtol=1e-6, atol=1e-6)


def test_function_heading_finite_differences_match_exact_derivatives() -> None:
    times = _random_times(3)
    path = Circle(1.0, 5.0).path(times)
    exact = FunctionHeading(_angle, _rate, _accel).evaluate(times, path)
    for profile in (FunctionHeading(_angle), FunctionHeading(_angle, rate=_rate)):
        approximate = profile.evaluate(times, path)
        np.testing.assert_allclose(approximate.angle, exact.angle)
        np.testing.assert_allclose(approximate.rate, exact.rate, atol=1e-8)
        np.testing.assert_allclose(approximate.acceleration, exact.acceleration, atol=1e-6)


def test_function_heading_accepts_scalar_results() -> None:
    circle = Circle(1.0, 5.0, heading=FunctionHeading(lambda t: 0.7))
    sample = circle.sample(np.linspace(0.0, 1.0, 4))
    np.testing.assert_allclose(sample.pose[:, 2], 0.7)
    np.testing.assert_allclose(sample.velocity[:, 2], 0.0)


# --- tangent heading ------------------------------------------------------------------


@pytest.mark.parametrize("shape_name", sorted(SHAPES))
def test_tangent_heading_is_continuous_across_separate_calls(shape_name: str) -> None:
    trajectory = SHAPES[shape_name]("tangent")
    period = trajectory.period
    assert period is not None
    times = np.linspace(-1.5 * period, 3.5 * period, 1001)
    separate = np.array([trajectory.sample(float(t)).pose[2] for t in times])
    together = trajectory.sample(times)
    np.testing.assert_allclose(separate, together.pose[:, 2], atol=1e-12)

    step_bound = np.abs(together.velocity[:, 2]).max() * (times[1] - times[0]) * 1.01
    assert np.abs(np.diff(separate)).max() <= step_bound < 0.5

    velocity = together.velocity
    tangent = np.arctan2(velocity[:, 1], velocity[:, 0])
    difference = np.angle(np.exp(1j * (separate - tangent)))
    np.testing.assert_allclose(difference, 0.0, atol=1e-9)


def test_tangent_heading_winding() -> None:
    circle = Circle(1.0, 3.0, heading=TangentHeading(offset=0.5))
    eight = FigureEight(1.0, 3.0, heading="tangent")
    for turns in (1, 2, 5):
        assert circle.sample(turns * 3.0 + 0.4).pose[2] - circle.sample(0.4).pose[2] == (
            pytest.approx(turns * TWO_PI)
        )
        # the two lobes turn opposite ways: no net winding
        assert eight.sample(turns * 3.0 + 0.4).pose[2] == pytest.approx(eight.sample(0.4).pose[2])
    clockwise = Circle(1.0, 3.0, heading="tangent", phase=0.0)
    assert clockwise.sample(0.0).pose[2] == pytest.approx(math.pi / 2)


class _BackAndForth(Trajectory):
    """x = cos(t): stops at both ends of a segment (periodic, 2 pi)."""

    def __init__(self, heading: object) -> None:
        super().__init__(heading)  # type: ignore[arg-type]

    @property
    def period(self) -> float:
        return TWO_PI

    def _path(self, t: np.ndarray) -> PathDerivatives:
        zero = np.zeros_like(t)
        return PathDerivatives(
            np.stack((np.cos(t), zero), axis=-1),
            np.stack((-np.sin(t), zero), axis=-1),
            np.stack((-np.cos(t), zero), axis=-1),
            np.stack((np.sin(t), zero), axis=-1),
        )


class _Endless(Trajectory):
    """A straight line at 1 m/s, neither periodic nor finite."""

    def _path(self, t: np.ndarray) -> PathDerivatives:
        zero = np.zeros_like(t)
        one = np.ones_like(t)
        return PathDerivatives(
            np.stack((t, zero), axis=-1),
            np.stack((one, zero), axis=-1),
            np.stack((zero, zero), axis=-1),
            np.stack((zero, zero), axis=-1),
        )


def test_tangent_heading_needs_a_moving_path() -> None:
    with pytest.raises(TrajectoryError, match="tangent heading needs a moving path"):
        _BackAndForth("tangent")
    assert _BackAndForth(0.0).sample(1.0).pose[0] == pytest.approx(math.cos(1.0))


def test_tangent_heading_needs_a_bounded_time_span() -> None:
    with pytest.raises(TrajectoryError, match="periodic or finite"):
        _Endless("tangent")
    line = _Endless(SpinHeading(0.5))
    np.testing.assert_allclose(line.sample(4.0).pose, [4.0, 0.0, 2.0])
    assert line.period is None and line.duration is None


def test_unbound_tangent_heading_refuses_to_evaluate() -> None:
    path = Circle(1.0, 1.0).path(np.zeros(3))
    with pytest.raises(TrajectoryError, match="must be bound"):
        TangentHeading().evaluate(np.zeros(3), path)


def test_bound_tangent_heading_equals_its_description() -> None:
    circle = Circle(1.0, 2.0, heading=TangentHeading(0.25))
    assert circle.heading == TangentHeading(0.25)
    assert repr(circle.heading) == "TangentHeading(offset=0.25)"


# --- body twist -----------------------------------------------------------------------


def test_body_twist_hand_example() -> None:
    # heading pi/2 (facing world +y), moving along world +y: straight ahead
    sample = TrajectorySample(
        pose=np.array([1.0, 2.0, math.pi / 2]),
        velocity=np.array([0.0, 1.5, 0.3]),
        acceleration=np.zeros(3),
    )
    np.testing.assert_allclose(body_twist(sample), [1.5, 0.0, 0.3], atol=1e-12)
    # facing +y, moving along world +x: to the robot's right (negative y, REP-103)
    sample = TrajectorySample(
        np.array([0.0, 0.0, math.pi / 2]), np.array([2.0, 0.0, 0.0]), np.zeros(3)
    )
    np.testing.assert_allclose(body_twist(sample), [0.0, -2.0, 0.0], atol=1e-12)


def test_body_twist_of_a_tangent_circle_is_constant() -> None:
    circle = Circle(2.0, 4.0, heading="tangent")
    w = TWO_PI / 4.0
    twists = circle.body_twist(np.linspace(-3.0, 9.0, 50))
    np.testing.assert_allclose(twists, np.tile([2.0 * w, 0.0, w], (50, 1)), atol=1e-9)


@pytest.mark.parametrize("heading_name", sorted(HEADINGS))
def test_body_twist_rotated_back_is_world_velocity(heading_name: str) -> None:
    trajectory = FigureEight(1.0, 5.0, heading=HEADINGS[heading_name])
    times = _random_times(11).reshape(5, 5)
    sample = trajectory.sample(times)
    twist = trajectory.body_twist(times)
    np.testing.assert_allclose(twist, body_twist(sample))
    theta = sample.pose[..., 2]
    cos, sin = np.cos(theta), np.sin(theta)
    world = np.stack(
        (cos * twist[..., 0] - sin * twist[..., 1], sin * twist[..., 0] + cos * twist[..., 1]),
        axis=-1,
    )
    np.testing.assert_allclose(world, sample.velocity[..., :2], atol=1e-12)
    np.testing.assert_allclose(twist[..., 2], sample.velocity[..., 2])


def test_body_twist_rejects_bad_shapes() -> None:
    sample = TrajectorySample(np.zeros((4, 3)), np.zeros((4, 2)), np.zeros((4, 3)))
    with pytest.raises(TrajectoryError, match=r"same shape \(\.\.\., 3\)"):
        body_twist(sample)


# --- shapes of inputs and outputs -----------------------------------------------------


@pytest.mark.parametrize(
    ("t", "shape"),
    [
        (0.5, ()),
        (np.float64(0.5), ()),
        (np.array(0.5), ()),
        (3, ()),
        ([0.1, 0.2], (2,)),
        (np.zeros(21), (21,)),
        (np.zeros((2, 3)), (2, 3)),
        (np.zeros(0), (0,)),
    ],
)
@pytest.mark.parametrize("heading_name", ["fixed", "tangent", "spin", "function"])
def test_sample_shapes(t: object, shape: tuple[int, ...], heading_name: str) -> None:
    trajectory = FigureEight(1.0, 4.0, heading=HEADINGS[heading_name])
    sample = trajectory.sample(t)  # type: ignore[arg-type]
    for array in (sample.pose, sample.velocity, sample.acceleration):
        assert isinstance(array, np.ndarray)
        assert array.shape == shape + (3,)
        assert array.dtype == np.float64
    assert trajectory.body_twist(t).shape == shape + (3,)  # type: ignore[arg-type]
    path = trajectory.path(t)  # type: ignore[arg-type]
    assert all(part.shape == shape + (2,) for part in path)


def test_array_sample_equals_scalar_samples() -> None:
    trajectory = Circle(1.0, 3.0, heading=SpinHeading(2.0))
    times = _random_times(5, count=6)
    together = trajectory.sample(times)
    for k, t in enumerate(times):
        alone = trajectory.sample(float(t))
        np.testing.assert_array_equal(alone.pose, together.pose[k])
        np.testing.assert_array_equal(alone.velocity, together.velocity[k])


@pytest.mark.parametrize(
    "bad", [math.nan, math.inf, [0.0, -math.inf], "soon", None, [[1.0], [2.0, 3.0]]]
)
def test_sample_rejects_non_finite_times(bad: object) -> None:
    with pytest.raises(TrajectoryError, match="t must be a finite number"):
        Circle(1.0, 1.0).sample(bad)  # type: ignore[arg-type]


# --- property tests -------------------------------------------------------------------

finite_times = st.floats(min_value=-100.0, max_value=100.0, allow_nan=False)
angles = st.floats(min_value=-10.0, max_value=10.0, allow_nan=False)
sizes = st.floats(min_value=0.05, max_value=20.0)
periods = st.floats(min_value=0.5, max_value=60.0)


@PROPERTY_SETTINGS
@given(size=sizes, period=periods, t=finite_times, angle=angles, offset=angles, rate=angles)
def test_heading_does_not_change_the_path(
    size: float, period: float, t: float, angle: float, offset: float, rate: float
) -> None:
    for make in (Circle, FigureEight):
        references = [
            make(size, period, heading=heading).sample(t)
            for heading in (angle, TangentHeading(offset), SpinHeading(rate), "tangent")
        ]
        for sample in references[1:]:
            np.testing.assert_array_equal(sample.pose[:2], references[0].pose[:2])
            np.testing.assert_array_equal(sample.velocity[:2], references[0].velocity[:2])
            np.testing.assert_array_equal(sample.acceleration[:2], references[0].acceleration[:2])
        # a tangent offset shifts theta only
        shifted, plain = references[1], references[3]
        assert shifted.pose[2] - plain.pose[2] == pytest.approx(offset, abs=1e-9)
        assert shifted.velocity[2] == plain.velocity[2]


@PROPERTY_SETTINGS
@given(size=sizes, period=periods, t=finite_times, angle=angles, rate=angles)
def test_body_twist_norm_is_path_speed(
    size: float, period: float, t: float, angle: float, rate: float
) -> None:
    for heading in (angle, SpinHeading(rate, angle), "tangent"):
        trajectory = FigureEight(size, period, heading=heading)
        sample = trajectory.sample(t)
        twist = body_twist(sample)
        speed = math.hypot(sample.velocity[0], sample.velocity[1])
        assert math.hypot(twist[0], twist[1]) == pytest.approx(speed, rel=1e-12, abs=1e-12)
        assert twist[2] == sample.velocity[2]


@PROPERTY_SETTINGS
@given(radius=sizes, period=periods, t=finite_times, shift=st.floats(-5.0, 5.0))
def test_circle_tangent_heading_leads_the_position_angle(
    radius: float, period: float, t: float, shift: float
) -> None:
    circle = Circle(radius, period, center=(shift, -shift), heading="tangent")
    pose = circle.sample(t).pose
    direction = math.atan2(pose[1] + shift, pose[0] - shift)
    assert math.remainder(pose[2] - direction - math.pi / 2, TWO_PI) == pytest.approx(0.0, abs=1e-7)
    assert pose[2] == pytest.approx(TWO_PI / period * t + math.pi / 2, abs=1e-7)


# --- heading specs and validation -----------------------------------------------------


def test_make_heading_accepted_forms() -> None:
    assert make_heading(0.4) == FixedHeading(0.4)
    assert make_heading(2) == FixedHeading(2.0)
    assert make_heading(np.float64(-1.0)) == FixedHeading(-1.0)
    assert make_heading("fixed") == FixedHeading(0.0)
    assert make_heading("tangent") == TangentHeading()
    spin = SpinHeading(1.0)
    assert make_heading(spin) is spin
    function = make_heading(_angle)
    assert isinstance(function, FunctionHeading) and function.angle is _angle
    assert isinstance(function, HeadingProfile)


@pytest.mark.parametrize("bad", ["tangential", "", None, [0.0, 1.0], True, math.nan, -math.inf])
def test_make_heading_rejects_other_forms(bad: object) -> None:
    with pytest.raises(TrajectoryError, match="heading must be a finite angle .* 'tangent'"):
        make_heading(bad)  # type: ignore[arg-type]
    with pytest.raises(TrajectoryError, match="heading must be"):
        Circle(1.0, 1.0, heading=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: Circle(-1.0, 1.0), r"radius \[m\] must be a finite number > 0, got -1.0"),
        (lambda: Circle(0.0, 1.0), r"radius \[m\] must be a finite number > 0, got 0.0"),
        (lambda: Circle(math.nan, 1.0), r"radius .* got nan"),
        (lambda: Circle("1", 1.0), r"radius .* got '1'"),  # type: ignore[arg-type]
        (lambda: Circle(True, 1.0), r"radius .* got True"),
        (lambda: Circle(1.0, 0.0), r"period \[s\] must be a finite number > 0, got 0.0"),
        (lambda: Circle(1.0, math.inf), r"period .* got inf"),
        (lambda: Circle(1.0, 1.0, center=(0.0, 1.0, 2.0)), r"center must be 2 finite numbers"),
        (lambda: Circle(1.0, 1.0, center=(0.0, math.nan)), r"center must be 2 finite numbers"),
        (lambda: Circle(1.0, 1.0, center="origin"), r"center must be 2 finite numbers"),
        (lambda: Circle(1.0, 1.0, phase=math.inf), r"phase \[rad\] must be a finite number"),
        (lambda: FigureEight(-2.0, 1.0), r"amplitude \[m\] must be a finite number > 0, got -2.0"),
        (lambda: FigureEight(1.0, -1.0), r"period \[s\] must be a finite number > 0, got -1.0"),
        (lambda: Circle.with_speed(1.0, 0.0), r"speed \[m/s\] must be a finite number > 0"),
        (lambda: FigureEight.with_speed(0.0, 1.0), r"amplitude \[m\] must be a finite number > 0"),
        (lambda: FixedHeading(math.inf), r"FixedHeading angle \[rad\] must be a finite number"),
        (lambda: SpinHeading(math.nan), r"SpinHeading rate \[rad/s\] must be a finite number"),
        (lambda: SpinHeading(1.0, "north"), r"SpinHeading initial \[rad\] must be a finite"),  # type: ignore[arg-type]
        (lambda: TangentHeading("x"), r"TangentHeading offset \[rad\] must be a finite"),  # type: ignore[arg-type]
        (lambda: FunctionHeading(1.0), r"FunctionHeading angle must be a callable"),  # type: ignore[arg-type]
        (lambda: FunctionHeading(_angle, rate=2.0), r"FunctionHeading rate must be None"),  # type: ignore[arg-type]
        (lambda: FunctionHeading(_angle, accel="a"), r"FunctionHeading accel must be None"),  # type: ignore[arg-type]
    ],
)
def test_constructor_validation(build: Callable[[], object], message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        build()


def test_function_heading_with_wrong_output_shape() -> None:
    circle = Circle(1.0, 1.0, heading=lambda t: np.zeros(7))
    with pytest.raises(TrajectoryError, match=r"angle\(t\) must return an array of the shape"):
        circle.sample(np.zeros(3))


def test_trajectory_error_is_a_value_error() -> None:
    assert issubclass(TrajectoryError, ValueError)


def test_center_is_read_only() -> None:
    circle = Circle(1.0, 1.0, center=[1.0, 2.0])
    with pytest.raises(ValueError):
        circle.center[0] = 5.0
    assert "Circle(radius=1.0, period=1.0, center=(1.0, 2.0)" in repr(circle)


def test_sampling_copies_the_times_and_refuses_non_finite_ones() -> None:
    """Float64 arrays take the fast way in: still a copy of the caller's times (the sample
    never aliases them), and still refused when not finite."""
    from trajectories._validation import as_times

    times = np.linspace(0.0, 1.0, 5)
    copied = as_times(times)
    assert copied is not times and not np.shares_memory(copied, times)
    np.testing.assert_array_equal(copied, times)
    circle = Circle(1.0, 4.0)
    sample = circle.sample(times)
    times[:] = 99.0
    np.testing.assert_array_equal(sample.pose, circle.sample(np.linspace(0.0, 1.0, 5)).pose)
    for bad in (np.array([0.0, np.nan]), np.array([np.inf])):
        with pytest.raises(TrajectoryError, match="finite"):
            circle.sample(bad)
