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
from collections.abc import Callable
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
                                          / "description" / "presets" / "mecanum.toml"
                                          ).read_bytes())
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


# Found by the third adversarial pass (2026-11-28) --------------------------------------

OMNI: dict[str, Any] = {"n_wheels": 3, "base_radius": 0.15, "wheel_radius": 0.03,
                        "max_wheel_speed": 31.4, "max_wheel_accel": 60.0}
MECANUM: dict[str, Any] = {"wheelbase": 0.3, "track": 0.25, "wheel_radius": 0.05,
                           "max_wheel_speed": 20.0, "max_wheel_accel": 40.0}
SWERVE: dict[str, Any] = {"module_positions": [[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3],
                                               [-0.3, -0.3]],
                          "wheel_radius": 0.05, "max_wheel_speed": 30.0, "max_steer_rate": 12.0}
BALLS: dict[str, Any] = {"positions": [[0.2, 0.0], [-0.1, 0.17], [-0.1, -0.17]],
                         "wheel_radius": 0.05, "max_wheel_speed": 20.0}
CASTERS: dict[str, Any] = {"positions": [[0.2, 0.2], [0.2, -0.2], [-0.2, 0.2], [-0.2, -0.2]],
                           "offset": 0.02, "wheel_radius": 0.05, "max_wheel_speed": 20.0,
                           "max_steer_rate": 10.0}


@pytest.mark.parametrize("factory", ["omni", "mecanum"])
@pytest.mark.parametrize("key", ["wheel_radius", "max_wheel_speed", "max_wheel_accel"])
@pytest.mark.parametrize("value", [math.nan, -1.0, 0.0, True, "0.1", [0.1], 1j])
def test_swedish_factories_name_the_keyword_the_caller_passed(factory: str, key: str,
                                                              value: Any) -> None:
    build, base = (omni, OMNI) if factory == "omni" else (mecanum, MECANUM)
    with pytest.raises(RobotError, match=rf"^{key} must be"):
        build(**{**base, key: value})


@pytest.mark.parametrize(("build", "key", "bound"), [
    (lambda: omni(**{**OMNI, "base_radius": 1e308}), "base_radius", r"\[1e-06, 1000\]"),
    (lambda: omni(**{**OMNI, "base_radius": 1e-308}), "base_radius", r"\[1e-06, 1000\]"),
    (lambda: omni(**{**OMNI, "first_wheel_angle": 1e308}), "first_wheel_angle", r"\+-1e\+09"),
    (lambda: mecanum(**{**MECANUM, "wheelbase": 1e200}), "wheelbase", r"\[1e-06, 1000\]"),
    (lambda: mecanum(**{**MECANUM, "track": 1e308}), "track", r"\[1e-06, 1000\]"),
    (lambda: mecanum(**{**MECANUM, "wheel_radius": 1e-308}), "wheel_radius",
     r"\[1e-06, 1000\]"),
    (lambda: swerve(**{**SWERVE, "module_positions": [[1e308, 0], [-1e308, 0], [0, 1e308]]}),
     r"module_positions", r"\+-1000 \[m\]"),
    (lambda: from_dict({"type": "spherical", **BALLS, "positions": [[1e308, 0.0]] * 3}),
     "positions", r"\+-1000 \[m\]"),
    (lambda: from_dict({"type": "caster", **CASTERS, "offset": 1e-9}), r"offset\[0\]",
     r"\[1e-06, 1000\]"),
])
def test_geometry_that_would_overflow_is_refused_with_its_bound(build: Any, key: str,
                                                                 bound: str) -> None:
    """Sizes from 1e200 to 1e308 m (or 1e-308 m) used to come back as 'not holonomic' or a
    LinAlgError from the SVD; each is now refused by name with the bound it broke."""
    with pytest.raises(RobotError, match=rf"{key} must be .*{bound}.*bound"):
        build()


@pytest.mark.parametrize(("build", "key"), [
    (lambda: swerve(**{**SWERVE, "module_positions": [[True, False], [False, True],
                                                       [True, True]]}), "module_positions"),
    (lambda: swerve(**{**SWERVE, "module_positions": [["0.3", "0.3"], ["0.3", "-0.3"],
                                                       ["-0.3", "0"]]}), "module_positions"),
    (lambda: from_dict({"type": "spherical", **BALLS, "wheel_radius": "0.05"}), "wheel_radius"),
    (lambda: preset("mecanum").derated([[0.5]]), "derating"),
    (lambda: preset("mecanum").derated(["1", "1", "1", "0.5"]), "derating"),
])
def test_booleans_strings_and_nested_lists_are_not_numbers(build: Any, key: str) -> None:
    with pytest.raises(RobotError, match=rf"{key} must be"):
        build()


@pytest.mark.parametrize(("pose", "t", "steer", "key"), [
    (["0", "0", "0"], 0.0, None, "pose"),
    ([True, False, True], 0.0, None, "pose"),
    ([0.0, 0.0, 0.0], 0.0, [True] * 4, "steer_angles"),
    ([0.0, 0.0, 0.0], 0.0, [1e308] * 4, "steer_angles"),
])
def test_step_refuses_strings_booleans_and_huge_angles(pose: Any, t: float, steer: Any,
                                                       key: str) -> None:
    robot = preset("caster4" if steer is not None else "mecanum")
    controller = Controller(robot, Circle(0.5, 10.0))
    with pytest.raises(ControllerError, match=rf"^{key} must be"):
        controller.step(pose, t, steer_angles=steer)


def test_files_nested_too_deeply_or_with_huge_integers_name_the_file(tmp_path: Path) -> None:
    from mpc.model.weights import load_weights
    from trajectories import read_choreo

    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(RobotError, match=r"robot file .*deep\.toml': not usable TOML: nested"):
        load(deep)
    with pytest.raises(ControllerError, match=r"weights file .*deep\.toml': not usable TOML"):
        load_weights(deep)
    nested = tmp_path / "deep.traj"
    nested.write_text("[" * 100000 + "]" * 100000)
    with pytest.raises(TrajectoryError, match=r"choreo file .*deep\.traj': not usable JSON"):
        read_choreo(nested)
    good = (Path(__file__).parent / "data" / "minimal.traj").read_text()
    huge = tmp_path / "bigint.traj"
    huge.write_text(good.replace('"x": 0.25', '"x": 1' + "0" * 5000, 1))
    with pytest.raises(TrajectoryError, match=r"choreo file .*bigint\.traj': not valid JSON"):
        read_choreo(huge)
    far = tmp_path / "far.traj"
    far.write_text(good.replace('"x": 0.25', '"x": 1e308', 1))
    with pytest.raises(TrajectoryError, match=r"choreo file .*far\.traj': trajectory\.samples: "
                                              r"poses must be finite and within \+-1e\+09"):
        read_choreo(far)


def test_a_results_file_that_is_not_utf8_is_named(tmp_path: Path) -> None:
    from mpc.errors import ReportError
    from mpc.plot import report

    latin = tmp_path / "results.json"
    latin.write_bytes(b'{"a": "\xe9"}')
    with pytest.raises(ReportError, match=r"results file .*results\.json' is not UTF-8"):
        report(latin, tmp_path / "out")


@pytest.mark.parametrize(("body", "message"), [
    ("t,x,y,theta\n0," + "1" * 200000 + ",0,0\n1,1,1,1\n", r"line 2: unreadable CSV: field"),
    ("t,x,y,theta\n0,0,0,0\n1,1e308,0,0\n2,-1e308,0,0\n",
     r"waypoint poses must be finite and within \+-1e\+09"),
    ("t,x,y,theta\n0,0,0,0\n1e-300,1,0,0\n2e-300,2,0,0\n",
     r"waypoint times are too close together"),
])
def test_waypoint_files_that_overflow_are_refused_naming_the_file(tmp_path: Path, body: str,
                                                                  message: str) -> None:
    path = tmp_path / "path.csv"
    path.write_text(body)
    with pytest.raises(TrajectoryError, match=rf"^waypoint file .*path\.csv'.*{message}"):
        Waypoints.from_csv(path)


@pytest.mark.parametrize(("times", "poses", "message"), [
    ([0, 1, 2], [[0, 0, 0], [1e308, 0, 0], [-1e308, 0, 0]],
     r"waypoint poses must be finite and within \+-1e\+09 .*poses\[1, 0\]=1e\+308"),
    ([0, 1, 2], [[0, 0, 0], [1e300, 0, 0], [-1e300, 0, 0]], r"waypoint poses must be"),
    ([False, True], [[0, 0, 0], [1, 0, 0]], r"waypoint times must be"),
    ([0, 1e11], [[0, 0, 0], [1, 0, 0]], r"waypoint times must be finite and within \+-1e\+10"),
])
def test_waypoints_are_checked_at_construction(times: Any, poses: Any, message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        Waypoints(times, poses)


def test_a_heading_function_returning_nan_is_named() -> None:
    reference = Circle(1.0, 10.0, heading=lambda t: np.full_like(t, math.nan))
    with pytest.raises(TrajectoryError, match=r"heading function's angle\(t\) returned a "
                                              r"non-finite value at t = 0\.0 s"):
        reference.sample(0.0)


def test_retiming_and_feasibility_samples_are_bounded() -> None:
    from trajectories import feasibility, time_optimal
    from trajectories.retiming import MAX_SAMPLES

    with pytest.raises(TrajectoryError, match=rf"samples must be an integer from 16 to "
                                              rf"{MAX_SAMPLES}"):
        time_optimal(Circle(1.0, 10.0), preset("mecanum"), samples=10**9)
    with pytest.raises(TrajectoryError, match="samples must be an integer from 2 to 1000000"):
        feasibility(Circle(1.0, 10.0), preset("mecanum"), samples=10**9)
    with pytest.raises(TrajectoryError, match=r"^path cannot be retimed: Circle reference gives "
                                              r"a position too large"):
        time_optimal(Circle(1e12, 10.0), preset("mecanum"))


@pytest.mark.parametrize(("options", "message"), [
    ({"dt": 1e300}, r"dt must be at most 60 s"),
    ({"stage_dt": 1e300}, r"stage_dt must be at most 60 s"),
    ({"horizon": 1000}, r"horizon must be at most 300 with solver='daqp'"),
    ({"horizon": 250, "polygon_sides": 256, "robot": "swerve"},
     r"horizon 250 x 512 limit rows a stage \(polygon_sides 256\) makes a dense QP"),
    ({"horizon": 1000, "polygon_sides": 256, "robot": "swerve", "solver": "osqp"},
     r"horizon 1000 x 512 limit rows .* a QP plan has at most 262144"),
])
def test_tick_lengths_and_plan_sizes_are_bounded(options: dict[str, Any], message: str) -> None:
    """dt = 1e300 crashed daqp; horizon 1000 on daqp took 87 s for its first tick."""
    robot = preset(options.pop("robot", "mecanum"))
    with pytest.raises(ControllerError, match=message):
        Controller(robot, Circle(0.5, 10.0), **options)


def test_longer_horizons_run_on_the_sparse_paths() -> None:
    controller = Controller(preset("mecanum"), Circle(0.5, 10.0), horizon=400, solver="osqp")
    command = controller.step(controller.trajectory.sample(0.0).pose, 0.0)
    assert command.status is Status.SOLVED


@pytest.mark.parametrize(("controller", "options", "key"), [
    (None, {}, "controller"),
    ("mecanum", {}, "controller"),
    ("ok", {"robot": "mecanum"}, "robot"),
    ("ok", {"robot": preset("omni3")}, "robot"),
    ("ok", {"on_tick": 5}, "on_tick"),
])
def test_simulate_names_a_bad_argument(controller: Any, options: dict[str, Any],
                                       key: str) -> None:
    if controller == "ok":
        controller = Controller(preset("mecanum"), Circle(0.5, 10.0))
    with pytest.raises(SimulationError, match=rf"^{key} "):
        simulate(controller, 0.5, **options)


@pytest.mark.parametrize(("offset", "horizon", "solver", "bound"), [
    (1e-5, 20, "daqp", "at most 1000 "),  # a caster aligning in 8 us: 244,219 RK4 steps
    (0.045, 300, "osqp", "at most 1000 "),
    (0.045, 70, "ipopt", "at most 120 .*for solver=ipopt"),  # ipopt's build grows as N^2
])
def test_the_caster_steer_prediction_is_bounded(offset: float, horizon: int, solver: str,
                                                bound: str) -> None:
    """The steer-angle prediction is built once in RK4 steps of the casters' fastest time
    constant: a tiny offset or a long horizon used to build for minutes on the first tick."""
    from mpc.robots import caster

    robot = caster(**{**CASTERS, "offset": offset, "wheel_radius": 0.088,
                      "max_wheel_speed": 15.0, "max_steer_rate": 8.0})
    with pytest.raises(RobotError, match=rf"predicting its steer angles .* RK4 steps .*"
                                         rf"offset, wheel_radius.*{bound}"):
        Controller(robot, Circle(0.5, 10.0), horizon=horizon, solver=solver)


@pytest.mark.parametrize("reference", [Circle(1e300, 10.0), FigureEight(1e200, 10.0)])
def test_a_reference_beyond_the_coordinate_bound_falls_back_saying_why(
        reference: Trajectory) -> None:
    """Finite but far: 1e300 m used to reach daqp and raise its RuntimeError from step()."""
    with pytest.raises(TrajectoryError, match=rf"{type(reference).__name__} reference gives a "
                                              r"position too large \(beyond \+-1e\+09 m"):
        reference.sample(np.linspace(0.0, 10.0, 11))
    controller = Controller(preset("mecanum"), reference)
    command = controller.step([0.0, 0.0, 0.0], 0.0)
    assert command.status is not Status.SOLVED
    assert "reference failed" in command.solver_status and "too large" in command.solver_status
    assert np.all(np.isfinite(command.wheel_speeds))


# Arguments that do not fit a public callable's signature ----------------------------------


@pytest.mark.parametrize(("call", "error", "needle"), [
    (lambda: omni(bogus=1), RobotError, "unknown keyword argument(s) 'bogus'"),  # type: ignore[call-arg]
    (lambda: omni(), RobotError, "missing a required argument: 'n_wheels'"),  # type: ignore[call-arg]
    (lambda: mecanum(wheelbase=0.5, track=0.4, wheel_radius=0.05, max_wheel_speed=10.0,  # type: ignore[call-arg]
                     extra=1), RobotError, "'extra'"),
    (lambda: swerve(module_positions=[[0.3, 0.3]], wheel_radius=0.05, max_wheel_speed=10.0,  # type: ignore[call-arg]
                    max_steer_rate=5.0, steer=1), RobotError, "'steer'"),
    (lambda: Controller(preset("mecanum"), Circle(1.0, 10.0), horizn=20), ControllerError,  # type: ignore[call-arg]
     "unknown keyword argument(s) 'horizn'"),
    (lambda: Controller(), ControllerError, "missing a required argument: 'robot'"),  # type: ignore[call-arg]
    (lambda: simulate(Controller(preset("mecanum"), Circle(1.0, 10.0)), 1.0, plnt="ideal"),  # type: ignore[call-arg]
     SimulationError, "'plnt'"),
])
def test_arguments_that_do_not_fit_the_signature_are_the_projects_error(
        call: Callable[[], object], error: type[Exception], needle: str) -> None:
    with pytest.raises(error, match="its parameters are") as raised:
        call()
    assert needle in str(raised.value)


# Third adversarial pass (issue 17) ---------------------------------------------------------

HUGE_INT = 10**5000


def _frac() -> Any:
    from fractions import Fraction

    return Fraction(10**400, 3)


@pytest.mark.parametrize(("build", "error", "name"), [
    (lambda v: omni(n_wheels=3, base_radius=v, wheel_radius=0.05, max_wheel_speed=20.0,
                     max_wheel_accel=40.0), RobotError, "base_radius must"),
    (lambda v: omni(n_wheels=v, base_radius=0.2, wheel_radius=0.05, max_wheel_speed=20.0,
                     max_wheel_accel=40.0), RobotError, "n_wheels must"),
    (lambda v: mecanum(wheelbase=v, track=0.25, wheel_radius=0.05, max_wheel_speed=20.0,
                        max_wheel_accel=40.0), RobotError, "wheelbase must"),
    (lambda v: mecanum(wheelbase=0.3, track=0.25, wheel_radius=0.05, max_wheel_speed=v,
                        max_wheel_accel=40.0), RobotError, "max_wheel_speed must"),
    (lambda v: preset("mecanum").derated({v: 0.5}), RobotError, "wheel index"),
    (lambda v: preset("mecanum").derated({0: v}), RobotError, "derating of wheel 0"),
    (lambda v: Circle(v, 10.0), TrajectoryError, "radius"),
    (lambda v: Circle(1.0, 10.0, phase=v), TrajectoryError, "phase"),
    (lambda v: Circle(1.0, 10.0).sample(v), TrajectoryError, "t must"),
    (lambda v: Waypoints([0, v], [[0, 0, 0], [1, 0, 0]]), TrajectoryError, "waypoint times"),
    (lambda v: Controller(preset("mecanum"), Circle(0.5, 10.0), horizon=v), ControllerError,
     "horizon"),
    (lambda v: Controller(preset("mecanum"), Circle(0.5, 10.0), weights={"twist": v}),
     ControllerError, "twist"),
    (lambda v: Controller(preset("mecanum"), Circle(0.5, 10.0)).step([0.5, 0, 0], v),
     ControllerError, "t must"),
    (lambda v: simulate(Controller(preset("mecanum"), Circle(0.5, 10.0)), duration=v),
     SimulationError, "duration"),
])
@pytest.mark.parametrize("huge", ["int", "fraction"])
def test_huge_integers_and_fractions_are_refused_naming_the_input(
        build: Callable[[Any], Any], error: type[Exception], name: str, huge: str) -> None:
    value = HUGE_INT if huge == "int" else _frac()
    with pytest.raises(error, match=name) as raised:
        build(value)
    assert "\n" not in str(raised.value) and len(str(raised.value)) < 400


@pytest.mark.parametrize(("build", "error", "name"), [
    (lambda: swerve(module_positions=np.array([[.3, .3], [.3, -.3], [-.3, .3]], dtype=object),
                    wheel_radius=0.05, max_wheel_speed=90.0, max_steer_rate=12.0,
                    max_wheel_accel=200.0), RobotError, "module_positions must"),
    (lambda: Circle(1.0, 10.0, heading=lambda t: t > 0).sample(np.linspace(0, 5, 11)),
     TrajectoryError, "heading"),
    (lambda: __import__("trajectories").SampledTrajectory(
        [0, 1, 2], [[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[math.nan, 0, 0]] * 3),
     TrajectoryError, "velocities"),
])
def test_messages_showing_arrays_are_one_line(build: Callable[[], Any], error: type[Exception],
                                              name: str) -> None:
    with pytest.raises(error, match=name) as raised:
        build()
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(("build", "error", "name"), [
    (lambda: Circle(1.0, 10.0, center=(True, 0)), TrajectoryError, "center"),
    (lambda: Circle(1.0, 10.0).sample("1"), TrajectoryError, "t must"),
    (lambda: Circle(1.0, 10.0).sample(True), TrajectoryError, "t must"),
    (lambda: Circle.with_speed(1.0, 1.0, colour=1), TrajectoryError, "colour"),
    (lambda: FigureEight.with_speed(1.0, 1.0, colour=1), TrajectoryError, "colour"),
    (lambda: Waypoints.from_csv(None),  # type: ignore[arg-type]
     TrajectoryError, "waypoint file"),
    (lambda: __import__("trajectories").read_waypoint_csv(3), TrajectoryError, "waypoint file"),
    (lambda: __import__("trajectories").body_twist(None), TrajectoryError, "sample"),
    (lambda: __import__("trajectories").feasibility(Circle(1.0, 10.0), object()),
     TrajectoryError, "robot"),
    (lambda: __import__("mpc").Weights(colour=1), ControllerError, "colour"),
    (lambda: __import__("trajectories").time_optimal(Circle(1.0, 10.0), preset("mecanum"),
                                                     max_speed=1e-300),
     TrajectoryError, "max_speed"),
])
def test_bools_strings_and_foreign_arguments_get_our_error(build: Callable[[], Any],
                                                          error: type[Exception],
                                                          name: str) -> None:
    with pytest.raises(error, match=name):
        build()


@pytest.fixture(scope="module")
def short_run() -> Any:
    return simulate(Controller(preset("mecanum"), Circle(0.5, 10.0)), 0.3)


@pytest.mark.parametrize(("options", "name"), [
    ({"skip": math.nan}, "skip"), ({"skip": "1"}, "skip"), ({"labels": 5}, "labels"),
])
def test_report_options_are_checked(short_run: Any, tmp_path: Path, options: dict[str, Any],
                                    name: str) -> None:
    import mpc.plot
    from mpc.errors import ReportError

    with pytest.raises(ReportError, match=name):
        mpc.plot.report(short_run, tmp_path / "rep", **options)


def test_plot_run_label_and_report_folder_are_checked(short_run: Any, tmp_path: Path) -> None:
    import mpc.plot
    from mpc.errors import ReportError

    with pytest.raises(ReportError, match="controller"):
        mpc.plot.plot_run(short_run, controller=5)  # type: ignore[arg-type]
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    with pytest.raises(ReportError, match="out_dir"):
        mpc.plot.report(short_run, a_file)


@pytest.fixture(scope="module")
def short_run_results(short_run: Any, tmp_path_factory: pytest.TempPathFactory) -> str:
    """The results.json that mpc.plot.report writes for the short run (drawn once)."""
    import mpc.plot

    folder = tmp_path_factory.mktemp("rep")
    mpc.plot.report(short_run, folder)
    return (folder / "results.json").read_text()


@pytest.mark.parametrize(("field", "value", "name"), [
    ("pose", 1e308, "'pose'"), ("status", 5, "'status'"),
])
def test_damaged_results_files_are_refused_naming_the_field(short_run_results: str,
                                                            tmp_path: Path, field: str,
                                                            value: Any, name: str) -> None:
    import json

    import mpc.plot
    from mpc.errors import ReportError

    document = json.loads(short_run_results)
    series = document["runs"][0]["series"]
    if field == "pose":
        series["pose"][1][0] = value
    else:
        series["status"] = value
    path = tmp_path / "damaged.json"
    path.write_text(json.dumps(document))
    with pytest.raises(ReportError, match=name):
        mpc.plot.report(str(path), tmp_path / "again")


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="no named pipes")
@pytest.mark.parametrize("reader", ["robot", "waypoints", "results"])
def test_named_pipes_are_refused_not_opened(tmp_path: Path, reader: str) -> None:
    import os

    import mpc.plot

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    readers: dict[str, Callable[[Any], Any]] = {
        "robot": load, "waypoints": Waypoints.from_csv, "results": mpc.plot.load_results}
    read = readers[reader]
    with pytest.raises(MpcError, match="not a regular file") as raised:
        read(fifo)
    assert str(fifo) in str(raised.value)


def test_recorder_refuses_a_command_of_another_robot() -> None:
    from mpc.sim import Recorder

    controller = Controller(preset("mecanum"), Circle(0.5, 10.0))
    command = controller.step([0.5, 0, 0], 0.0)
    recorder = Recorder(preset("omni3"), controller.trajectory, 0.05)
    with pytest.raises(SimulationError, match="command"):
        recorder.record(0.0, [0, 0, 0], command)


@pytest.mark.parametrize(("argv", "flag"), [
    (["--dt", "1e-7", "--quick", "--no-report"], "--dt"),
    (["--dt", "60", "--horizon", "1000", "--controllers", "mpc-osqp", "--quick",
      "--no-report"], "--dt"),
    (["--skip", "5", "--duration", "4", "--quick", "--no-report"], "--skip"),
    (["--skip", "1e300", "--quick", "--no-report"], "--skip"),
    (["soak", "--ticks", str(10**12)], "--ticks"),
    (["fuzz", "--ticks", str(10**11)], "--ticks"),
    (["fuzz", "--ticks", "100", "--seed", "-1"], "--seed"),
    (["sweep", "--runs", str(10**10)], "--runs"),
    (["sweep", "--duration", "1e12"], "--duration"),
    (["motors", "--size", "1e300"], "--size"),
    (["motors", "--laps", str(10**9)], "--laps"),
])
def test_cli_bounds_exit_2_naming_the_flag(tmp_path: Path, capsys: Any, argv: list[str],
                                           flag: str) -> None:
    from benchmarks.cli import main

    out = [] if argv[0] == "soak" else ["--out", str(tmp_path / "out")]
    with pytest.raises(SystemExit) as exit_info:
        raise SystemExit(main([*argv, *out]))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert flag in err and "\n" not in err


def test_cli_refuses_a_robot_file_named_like_a_preset(tmp_path: Path, capsys: Any) -> None:
    from benchmarks.cli import main

    robot = tmp_path / "robot.toml"
    robot.write_text('type = "mecanum"\nwheelbase = 0.3\ntrack = 0.25\nwheel_radius = 0.05\n'
                     "max_wheel_speed = 20.0\nmax_wheel_accel = 40.0\n")
    with pytest.raises(SystemExit) as exit_info:
        raise SystemExit(main(["--robot", str(robot), "--quick", "--no-report",
                               "--out", str(tmp_path / "out")]))
    assert exit_info.value.code == 2
    assert "--robot" in capsys.readouterr().err


@pytest.mark.parametrize(("build", "name"), [
    (lambda v: mecanum(wheelbase=0.3, track=0.25, wheel_radius=0.05, max_wheel_speed=v),
     "max_wheel_speed"),
    (lambda v: omni(n_wheels=3, base_radius=0.2, wheel_radius=0.05, max_wheel_speed=20.0,
                    max_wheel_accel=v), "max_wheel_accel"),
    (lambda v: swerve(module_positions=[[0.25, 0.25], [0.25, -0.25], [-0.25, 0.25],
                                        [-0.25, -0.25]], wheel_radius=0.05,
                      max_wheel_speed=30.0, max_steer_rate=v), "max_steer_rate"),
])
@pytest.mark.parametrize("value", [1e-300, 1e-13, 0.9e-6])
def test_limits_below_the_smallest_rate_are_refused(build: Callable[[float], object],
                                                    name: str, value: float) -> None:
    """Limits far below any motor's (they would take the clamp's ratios and the QP rows
    towards underflow) are refused by name, with the bound; 1e-6 itself is taken."""
    with pytest.raises(RobotError, match=rf"^{name} must be at least 1e-06 \["):
        build(value)
    build(1e-6)


PUBLIC_PACKAGES = ("mpc.control", "mpc.robots", "mpc.sim", "mpc.model", "mpc.plot",
                   "trajectories", "mpc.adapters.ros", "mpc.adapters.wpilib")


def _public_callables() -> list[tuple[str, str, Any]]:
    """Every function, and every class users build (its own ``__init__``; not a protocol,
    abstract class, enum, exception or named tuple), in the packages' ``__all__``."""
    import enum
    import importlib
    import inspect

    found = []
    for package in PUBLIC_PACKAGES:
        try:
            module = importlib.import_module(package)
        except ModuleNotFoundError:  # an adapter whose optional extra is not installed
            continue
        for name in module.__all__:
            item = getattr(module, name)
            if inspect.isfunction(item) or (
                    inspect.isclass(item) and "__init__" in vars(item)
                    and not issubclass(item, (BaseException, enum.Enum))
                    and not getattr(item, "_is_protocol", False)
                    and not inspect.isabstract(item)):
                found.append((package, name, item))
    return found


@pytest.mark.parametrize(("package", "name", "item"), _public_callables(),
                         ids=lambda value: value if isinstance(value, str) else "")
def test_every_public_callable_names_an_unknown_keyword(package: str, name: str,
                                                        item: Any) -> None:
    """A misspelt keyword (``time_optimal(path, robot, sampels=400)``) raises the package's
    own error naming the callable and its parameters, for every public function and class,
    not Python's TypeError."""
    with pytest.raises(MpcError, match=rf"{name}\(\): unknown keyword argument\(s\) "
                                       r"'colour_xyz'; its parameters are "):
        item(colour_xyz=1)


def _choreo_with_a_huge_integer(tmp_path: Path) -> object:
    import json

    from trajectories import read_choreo

    document = json.loads((Path(__file__).parent / "data" / "minimal.traj").read_text())
    text = json.dumps(document).replace('"vx": 0.0', '"vx": ' + "1" * 401, 1)
    assert "1" * 401 in text
    path = tmp_path / "huge.traj"
    path.write_text(text)
    return read_choreo(path)


def _recorded_far_apart() -> object:
    from mpc.sim import Recorder

    robot, trajectory = preset("mecanum"), Circle(0.5, 10.0)
    controller, recorder = Controller(robot, trajectory), Recorder(robot, trajectory, 0.05)
    pose = trajectory.sample(0.0).pose
    recorder.record(0.0, pose, controller.step(pose, 0.0))
    recorder.record(1e300, pose, controller.step(pose, 0.05))
    return recorder


@pytest.mark.parametrize(("call", "error", "message"), [
    # a JSON integer of 401 digits: not an OverflowError from float()
    (_choreo_with_a_huge_integer, TrajectoryError, "vx: expected a finite number, got an "
                                                   "integer of 401 digits"),
    # math.sin takes one number; the reference samples arrays of times
    (lambda _: Circle(1.0, 10.0, heading=math.sin).sample([0.0, 1.0]), TrajectoryError,
     r"vectorised: np.sin, not math.sin"),
    # two modules in one place
    (lambda _: swerve(module_positions=[[0.3, 0.3], [0.3, 0.3], [-0.3, -0.3], [-0.3, 0.3]],
                      wheel_radius=0.05, max_wheel_speed=30.0, max_steer_rate=10.0),
     RobotError, r"modules 0 and 1 must stand apart"),
    # a plain number where a ROS stamp (sec, nanosec) belongs
    (lambda _: __import__("mpc.adapters.ros", fromlist=["ReferenceClock"]).ReferenceClock()(5),
     TrajectoryError, r"a stamp must be a builtin_interfaces/Time"),
    # a recording tick at 1e300 s: bounded like step()'s t, not a lap count that allocates
    (lambda _: _recorded_far_apart(), SimulationError, r"within \+-1e\+10"),
])
def test_more_bad_input_is_named(tmp_path: Path, call: Callable[[Path], object],
                                 error: type[Exception], message: str) -> None:
    if "stamp" in message:
        pytest.importorskip("rosbags")
    with pytest.raises(error, match=message):
        call(tmp_path)


@pytest.mark.parametrize(("pose", "twist", "dt", "message"), [
    ([0.0, 0.0], [1.0, 0.0, 0.0], 0.1, r"pose must have shape \(3,\)"),
    ([0.0, 0.0, 0.0], [math.nan, 0.0, 0.0], 0.1, "twist must be finite"),
    ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], -1.0, r"dt \[s\] must be a finite number >= 0"),
    ("abc", [1.0, 0.0, 0.0], 0.1, "pose must be 3 numbers"),
])
def test_integrate_checks_its_arguments(pose: Any, twist: Any, dt: float,
                                        message: str) -> None:
    """The README's loop integrates the commanded twist with mpc.model.integrate: a NaN
    twist or a negative dt is named, not a NaN pose or a backwards step."""
    from mpc.model import integrate

    with pytest.raises(ControllerError, match=message):
        integrate(pose, twist, dt)
    np.testing.assert_allclose(integrate([1.0, 2.0, 0.0], [1.0, 0.0, 0.0], 0.5),
                               [1.5, 2.0, 0.0])


def test_zero_dimensional_arrays_are_numbers() -> None:
    """``np.array(0.05)`` is a number wherever a number is asked (dt, t), as ``np.float64``
    is; a 0-d array of a bool is not."""
    dt, t, flag = np.array(0.05), np.array(0.5), np.array(True)
    controller = Controller(preset("mecanum"), Circle(0.5, 10.0), dt=dt)  # type: ignore[arg-type]
    assert controller.dt == 0.05 and isinstance(controller.dt, float)
    assert controller.step([0.5, 0.0, 0.0], t).status is Status.SOLVED  # type: ignore[arg-type]
    with pytest.raises(ControllerError, match="dt"):
        Controller(preset("mecanum"), Circle(0.5, 10.0), dt=flag)  # type: ignore[arg-type]


def test_long_ticks_keep_the_default_stages_within_the_bound() -> None:
    """The default stage is 2 dt in time mode, but never past MAX_STEP (60 s) unless dt
    itself is: dt = 40 s plans 60 s stages, not 80."""
    from mpc.validation import MAX_STEP

    controller = Controller(preset("mecanum"), Circle(0.5, 1000.0), horizon=3, dt=40.0)
    assert controller.stage_dt == MAX_STEP
    assert Controller(preset("mecanum"), Circle(0.5, 10.0), dt=0.05).stage_dt == 0.1


def test_nav2_controller_checks_its_options_when_built() -> None:
    """A nav2 controller is built once and planned in a subscription callback: its own
    options are checked when it is built, not at the first plan."""
    pytest.importorskip("rosbags")
    from mpc.adapters.ros import Nav2Controller

    robot = preset("mecanum")
    for options, message in (({"colour": 1}, "unknown option.*'colour'"),
                             ({"horizon": -5}, "horizon must be an integer >= 1"),
                             ({"dt": "x"}, r"dt \[s\] must be a finite number > 0")):
        with pytest.raises(ControllerError, match=message):
            Nav2Controller(robot, **options)
    Nav2Controller(robot, solver="osqp", horizon=10)


def test_laps_are_not_timed_between_ticks_far_apart() -> None:
    """Two recorded ticks 1e8 s apart span 10^7 laps of a 10 s circle: more laps than
    ticks cannot be timed, and ``lap_times`` says so (empty) instead of allocating them."""
    from mpc.sim import Recorder

    robot, trajectory = preset("mecanum"), Circle(0.5, 10.0)
    controller, recorder = Controller(robot, trajectory), Recorder(robot, trajectory, 0.05)
    pose = trajectory.sample(0.0).pose
    recorder.record(0.0, pose, controller.step(pose, 0.0))
    recorder.record(1e8, pose, controller.step(pose, 0.05))
    assert recorder.result().lap_times().size == 0
