"""Bad input never gets past the front door (stated bounds, our own errors, no silent
acceptance), and the loop degrades safely when the reference itself fails.

The property suites search instead of enumerate: hypothesis draws robot descriptions,
CSV text, trajectory parameters and ``step()`` arguments, extreme and malformed ones
included; the property is our own error (an ``MpcError``, a ``ValueError``) with a message,
or a finite result within every limit. Derandomized, no example database: the same
examples every run.
"""

from __future__ import annotations

import math
import string
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from closed_loop import Loop
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mpc import Controller, ControllerError, MpcError, Status
from mpc.errors import RobotError, SimulationError
from mpc.robots import from_dict, load, mecanum, omni, preset, swerve
from mpc.sim import simulate
from mpc.validation import (
    MAX_COORDINATE,
    MAX_DELAY_TICKS,
    MAX_HORIZON,
    MAX_ITERATIONS,
    MAX_POLYGON_SIDES,
    MAX_SIMULATION_TICKS,
    MAX_TIME,
    MAX_WHEELS,
)
from trajectories import Circle, FigureEight, Trajectory, TrajectoryError, Waypoints
from trajectories.base import TrajectorySample

SEARCH = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                  suppress_health_check=[HealthCheck.too_slow])
DT = 0.05


# Stated bounds -------------------------------------------------------------------------


@pytest.mark.parametrize(("option", "value", "bound"), [
    ("horizon", MAX_HORIZON + 1, MAX_HORIZON),
    ("delay_ticks", MAX_DELAY_TICKS + 1, MAX_DELAY_TICKS),
    ("max_iter", MAX_ITERATIONS + 1, MAX_ITERATIONS),
    ("polygon_sides", MAX_POLYGON_SIDES + 2, MAX_POLYGON_SIDES),
])
def test_sizes_beyond_their_bound_fail_at_once_naming_it(option: str, value: int,
                                                          bound: int) -> None:
    with pytest.raises(ControllerError, match=rf"{option} must be at most {bound}"):
        options: dict[str, Any] = {option: value}
        Controller(preset("swerve"), Circle(1.0, 12.0), **options)


def test_wheel_count_and_simulation_length_are_bounded() -> None:
    with pytest.raises(RobotError, match=f"at most {MAX_WHEELS}"):
        omni(n_wheels=10**8, base_radius=0.2, wheel_radius=0.05, max_wheel_speed=10.0)
    many = {"type": "swerve", "module_positions": [[math.cos(a), math.sin(a)] for a in
                                                    np.linspace(0, 6, MAX_WHEELS + 1)],
            "wheel_radius": 0.05, "max_wheel_speed": 10.0, "max_steer_rate": 10.0}
    with pytest.raises(RobotError, match=f"at most {MAX_WHEELS}"):
        from_dict(many)
    controller = Controller(preset("mecanum"), Circle(1.0, 12.0))
    with pytest.raises(SimulationError, match=str(MAX_SIMULATION_TICKS)):
        simulate(controller, 1e12)


@pytest.mark.parametrize("pose", [[1e300, 0.0, 0.0], [0.0, -2 * MAX_COORDINATE, 0.0],
                                  [0.0, 0.0, 1e12]])
def test_poses_beyond_the_coordinate_bound_are_refused(pose: list[float]) -> None:
    controller = Controller(preset("mecanum"), Circle(1.0, 12.0))
    with pytest.raises(ControllerError, match="pose must lie within"):
        controller.step(pose, 0.0)
    with pytest.raises(ControllerError, match="t must be"):
        controller.step([0.0, 0.0, 0.0], 10 * MAX_TIME)


# Files ---------------------------------------------------------------------------------


def test_files_that_are_not_utf8_or_too_large_are_named(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    latin = tmp_path / "robot.toml"
    latin.write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(RobotError, match=r"robot\.toml.*not UTF-8"):
        load(latin)
    with pytest.raises(RobotError, match=r"robot file .*missing\.toml' does not exist"):
        load(tmp_path / "missing.toml")
    with pytest.raises(RobotError, match="cannot read robot file"):
        load(tmp_path)  # a folder
    marked = tmp_path / "marked.toml"
    marked.write_bytes(b"\xef\xbb\xbf" + (Path(__file__).parent.parent / "mpc" / "robots"
                                          / "presets" / "mecanum.toml").read_bytes())
    assert load(marked).n_wheels == 4  # a byte-order mark is fine
    import mpc.validation

    monkeypatch.setattr(mpc.validation, "MAX_FILE_BYTES", 10)
    with pytest.raises(RobotError, match="bytes; at most 10"):
        load(marked)
    waypoints = tmp_path / "path.csv"
    waypoints.write_text("t,x,y,theta\n0,0,0,0\n1,1,0,0\n")
    with pytest.raises(TrajectoryError, match=r"waypoint file .*path\.csv"):
        Waypoints.from_csv(waypoints)


# References that overflow ----------------------------------------------------------------


def test_a_reference_whose_numbers_overflow_is_named_not_sampled_to_nan() -> None:
    with pytest.raises(TrajectoryError, match="Circle reference gives a non-finite"):
        Circle(1e308, 1e-300).sample(1.0)
    with pytest.raises(TrajectoryError, match=r"waypoint times are too close together .* "
                                              r"overflows double precision near times\[0\]"):
        Waypoints([0.0, 1e-300, 2e-300], [[0, 0, 0], [1, 0, 0], [2, 0, 0]])


class BreaksAt(Trajectory):
    """A circle that gives NaN from ``t_break`` on: a reference failing mid-run."""

    def __init__(self, t_break: float) -> None:
        self.inner = Circle(1.0, 12.0, heading=0.0)
        self.t_break = t_break
        super().__init__(0.0)

    def _path(self, t: np.ndarray) -> Any:
        return self.inner._path(t)

    def sample(self, t: Any) -> TrajectorySample:
        sample = self.inner.sample(t)
        if np.any(np.asarray(t) >= self.t_break):
            self._not_finite(np.asarray(t, dtype=float), sample.pose * np.nan,
                             sample.velocity, sample.acceleration)
        return sample


@pytest.mark.parametrize("solver", ["daqp", "ipopt"])
def test_a_reference_failing_mid_run_falls_back_and_says_why(solver: str) -> None:
    """step() raises only for its own bad arguments: a reference that starts giving NaN
    sends the robot through the fallbacks that do not need it (the last plan, then a stop
    ramp within the limits), with the reason in solver_status; the commands stay finite
    (Loop checks every one against the speed and acceleration limits)."""
    robot = preset("mecanum")
    reference = BreaksAt(3.0)
    loop = Loop(Controller(robot, reference, solver=solver), reference.inner.sample(0.0).pose)
    commands = [loop.step() for _ in range(120)]
    statuses = [c.status for c in commands]
    assert set(statuses[:20]) == {Status.SOLVED}  # the 1.95 s plan reaches 3 s at tick 21
    failing = statuses[40:]
    assert Status.FEEDFORWARD not in failing
    assert Status.PREVIOUS_PLAN in failing and failing[-1] is Status.STOPPING
    final = commands[-1]
    assert "reference failed" in final.solver_status
    assert "non-finite pose" in final.solver_status
    assert np.all(np.isfinite(final.predicted_poses))
    np.testing.assert_array_equal(final.twist, np.zeros(3))


# Property suites -----------------------------------------------------------------------

numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
                    st.booleans(), st.text(max_size=4), st.none())
small_lists = st.lists(numbers, max_size=4)
values = st.one_of(numbers, small_lists, st.lists(small_lists, max_size=4))
keys = st.sampled_from(["type", "wheelbase", "track", "wheel_radius", "max_wheel_speed",
                        "max_wheel_accel", "n_wheels", "base_radius", "module_positions",
                        "max_steer_rate", "ball_positions", "wheels", "name", "derating"])
types = st.sampled_from(["mecanum", "omni", "swerve", "spherical", "swedish", "x", 3])


def check_robot(robot: Any) -> None:
    twist = np.array([0.3, -0.2, 0.5])
    speeds = robot.wheel_speeds(twist)
    assert np.all(np.isfinite(speeds))


@SEARCH
@given(kind=types, entries=st.dictionaries(keys, values, max_size=8))
def test_robot_descriptions_give_a_robot_or_our_error(kind: Any, entries: dict[str, Any]) -> None:
    description = {"type": kind, **entries}
    try:
        robot = from_dict(description)
    except MpcError as error:
        assert str(error)
        return
    check_robot(robot)


@SEARCH
@given(wheelbase=numbers, track=numbers, radius=numbers, speed=numbers, accel=numbers)
def test_robot_factories_give_a_robot_or_our_error(wheelbase: Any, track: Any, radius: Any,
                                                    speed: Any, accel: Any) -> None:
    for build in (
        lambda: mecanum(wheelbase=wheelbase, track=track, wheel_radius=radius,
                        max_wheel_speed=speed, max_wheel_accel=accel),
        lambda: swerve(module_positions=[[wheelbase, track], [track, wheelbase],
                                         [0.0, 1.0]], wheel_radius=radius,
                       max_wheel_speed=speed, max_steer_rate=10.0),
    ):
        try:
            robot = build()
        except MpcError as error:
            assert str(error)
            continue
        check_robot(robot)


csv_text = st.text(alphabet=string.digits + ".,-+eE naNifx\n\t" + "txyth", max_size=200)


@SEARCH
@given(body=csv_text)
def test_waypoint_csv_gives_a_trajectory_or_our_error(body: str, tmp_path_factory:
                                                      pytest.TempPathFactory) -> None:
    path = tmp_path_factory.mktemp("csv") / "w.csv"
    path.write_text("t,x,y,theta\n" + body)
    try:
        reference = Waypoints.from_csv(path)
    except MpcError as error:
        assert str(error)
        return
    times = np.linspace(reference.start_time, reference.end_time or reference.start_time, 7)
    try:
        sample = reference.sample(times)
    except TrajectoryError as error:  # sizes that overflow: named at sampling
        assert "non-finite" in str(error) or "too large" in str(error)
        return
    assert np.all(np.isfinite(sample.pose)) and np.all(np.isfinite(sample.velocity))


@SEARCH
@given(size=numbers, period=numbers, t=st.floats(-1e12, 1e12))
def test_shapes_give_finite_samples_or_our_error(size: Any, period: Any, t: float) -> None:
    for shape in (Circle, FigureEight):
        try:
            sample = shape(size, period, heading="tangent").sample(t)
        except MpcError as error:
            assert str(error)
            continue
        assert np.all(np.isfinite(sample.pose)) and np.all(np.isfinite(sample.velocity))


poses = st.one_of(
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=4),
    st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3),
    st.text(max_size=5), st.none(),
)
times = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-100.0, 100.0),
                  st.booleans(), st.text(max_size=3))


@settings(max_examples=80, deadline=None, derandomize=True, database=None)
@given(steps=st.lists(st.tuples(poses, times), min_size=1, max_size=12))
def test_step_gives_a_safe_command_or_our_error(steps: list[tuple[Any, Any]]) -> None:
    """Whatever arrives, in any order (time jumps, wild poses): our ControllerError, or a
    finite command within every wheel limit relative to the command before."""
    robot = preset("mecanum")
    controller = Controller(robot, FigureEight(1.0, 12.0, heading="tangent"), horizon=8)
    last = np.zeros(3)
    accel = robot.max_wheel_accel
    assert accel is not None
    for pose, t in steps:
        try:
            command = controller.step(pose, t)
        except ControllerError as error:
            assert str(error)
            continue
        assert np.all(np.isfinite(command.wheel_speeds)) and np.all(np.isfinite(command.twist))
        assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        change = robot.wheel_speeds(command.twist - last)
        assert np.all(np.abs(change) <= accel * DT * (1 + 1e-6))
        last = command.twist


def test_inputs_the_second_adversarial_pass_found() -> None:
    """Found by an independent pass of 692 inputs (2026-11-27): each now gets the project's
    own error naming the input instead of a foreign one or silence."""
    from mpc.model.weights import load_weights

    with pytest.raises(RobotError, match="robot file must be a path"):
        load(None)  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match="weights file must be a path"):
        load_weights(123)  # type: ignore[arg-type]
    if Path("/dev/zero").exists():  # a device reports size 0: the read itself is bounded
        with pytest.raises(RobotError, match="bytes; at most 67108864 are read"):
            load("/dev/zero")
    with pytest.raises(ControllerError, match="'pose' and 'terminal' are all zero"):
        Controller(preset("mecanum"), Circle(1.0, 10.0),
                   weights={"pose": 0.0, "twist": 0.0, "rate": 0.0, "terminal": 0.0})
    control = Controller(preset("mecanum"), Circle(1.0, 10.0))
    for seed in (-1, 1.5, "a", True):
        with pytest.raises(SimulationError, match="seed must be None or an integer >= 0"):
            simulate(control, 1.0, seed=seed)  # type: ignore[arg-type]
