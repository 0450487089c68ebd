"""Choreo .traj files: exact interpolation, the planned robot, every bad file, a closed loop."""

from __future__ import annotations

import copy
import json
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.polynomial import Polynomial

from mpc import Controller
from mpc.robots import SwerveRobot
from mpc.sim import simulate
from trajectories import (
    CHOREO_TO_OURS,
    ChoreoConfig,
    ChoreoEvent,
    SampledTrajectory,
    TrajectoryError,
    choreo_robot,
    feasibility,
    read_choreo,
)

DATA = Path(__file__).parent / "data"
CONFIG: dict[str, Any] = {
    "frontLeft": {"x": 0.3, "y": 0.25}, "backLeft": {"x": -0.28, "y": 0.27},
    "mass": 60.0, "inertia": 6.0, "gearing": 6.5, "radius": 0.05, "vmax": 600.0,
    "tmax": 1.2, "cof": 1.5, "bumper": {"front": 0.4, "side": 0.4, "back": 0.4},
}
DURATION = 3.0  # [s] of the polynomial path
# Each axis: (value, first, second derivative) at times t.
Axis = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def in_time(coefficients: list[float]) -> Polynomial:
    """The polynomial sum c_k u^k, u = t / DURATION, as a polynomial in t."""
    return Polynomial([c / DURATION**k for k, c in enumerate(coefficients)])


SMOOTH = [0.0, 0.0, 0.0, 10.0, -15.0, 6.0]  # rest-to-rest 0 -> 1 (quintic smoothstep)
# Rest to rest, degree <= 5 in t: quintic Hermite interpolation reproduces it exactly;
# the heading runs from 2.8 to 3.8 rad, so the file's wrapped heading crosses +-pi.
POLYNOMIALS = (in_time([2.0 * c for c in SMOOTH]), in_time([0.0, 0.0, 8.0, -16.0, 8.0]),
               in_time([2.8] + [1.0 * c for c in SMOOTH[1:]]))


def polynomial_axis(p: Polynomial) -> Axis:
    return lambda t: (p(t), p.deriv(1)(t), p.deriv(2)(t))


def circle_axes() -> tuple[Axis, Axis, Axis]:
    """x = cos t, y = sin t, heading 0.7 t (spinning through +-pi)."""
    return ((lambda t: (np.cos(t), -np.sin(t), -np.cos(t))),
            (lambda t: (np.sin(t), np.cos(t), -np.sin(t))),
            (lambda t: (0.7 * t, np.full_like(t, 0.7), np.zeros_like(t))))


def samples(axes: tuple[Axis, Axis, Axis], times: np.ndarray) -> list[dict[str, Any]]:
    """Choreo swerve samples of analytic axes, heading wrapped into (-pi, pi] as Choreo has it."""
    (x, vx, ax), (y, vy, ay), (h, w, al) = (axis(times) for axis in axes)
    wrapped = np.arctan2(np.sin(h), np.cos(h))
    rows = []
    for k, t in enumerate(times):
        rows.append({"t": float(t), "x": float(x[k]), "y": float(y[k]),
                     "heading": float(wrapped[k]), "vx": float(vx[k]), "vy": float(vy[k]),
                     "omega": float(w[k]), "ax": float(ax[k]), "ay": float(ay[k]),
                     "alpha": float(al[k]), "fx": [1.0 + k, 2.0, 3.0, 4.0],
                     "fy": [5.0, 6.0, 7.0, 8.0 + k]})
    return rows


def document(rows: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "name": "generated", "version": 3, "snapshot": None, "params": {},
        "trajectory": {"config": copy.deepcopy(CONFIG), "sampleType": "Swerve",
                       "waypoints": [0.0], "samples": rows, "splits": [0],
                       "forcesAvailable": True},
        "events": [{"name": "intake", "from": {"target": 1, "targetTimestamp": 1.25,
                                               "offset": {"exp": "0.1 s", "val": 0.1}},
                    "event": None},
                   {"name": "untimed", "from": {"target": None, "targetTimestamp": None,
                                                "offset": {"exp": "0 s", "val": 0.0}}}],
    }


def write(directory: Path, content: Any, name: str = "path.traj") -> Path:
    path = directory / name
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    return path


def polynomial_file(directory: Path) -> Path:
    times = np.linspace(0.0, DURATION, 61)
    x, y, heading = (polynomial_axis(p) for p in POLYNOMIALS)
    return write(directory, document(samples((x, y, heading), times)))


def test_polynomial_path_is_reproduced_exactly_between_samples(tmp_path: Path) -> None:
    trajectory = read_choreo(polynomial_file(tmp_path))
    t = np.random.default_rng(3).uniform(0.0, DURATION, 200)
    sample, path = trajectory.sample(t), trajectory.path(t)
    for axis, p in enumerate(POLYNOMIALS):
        np.testing.assert_allclose(sample.pose[:, axis], p(t), atol=1e-12)
        np.testing.assert_allclose(sample.velocity[:, axis], p.deriv(1)(t), atol=1e-11)
        np.testing.assert_allclose(sample.acceleration[:, axis], p.deriv(2)(t), atol=1e-9)
        if axis < 2:
            np.testing.assert_allclose(path.jerk[:, axis], p.deriv(3)(t), atol=1e-6)


def test_samples_round_trip_and_file_extras(tmp_path: Path) -> None:
    times = np.linspace(0.0, 6.0, 121)
    rows = samples(circle_axes(), times)
    trajectory = read_choreo(write(tmp_path, document(rows)))
    at = trajectory.sample(times)
    table = np.array([[r[k] for k in ("x", "y", "heading", "vx", "vy", "omega", "ax", "ay",
                                       "alpha")] for r in rows])
    np.testing.assert_array_equal(trajectory.times, times)
    np.testing.assert_allclose(at.pose[:, :2], table[:, :2], atol=1e-15)
    np.testing.assert_allclose(np.angle(np.exp(1j * (at.pose[:, 2] - table[:, 2]))), 0.0,
                               atol=1e-12)
    np.testing.assert_allclose(at.pose[:, 2], 0.7 * times, atol=1e-12)  # unwrapped
    np.testing.assert_allclose(at.velocity, table[:, 3:6], atol=1e-13)
    np.testing.assert_allclose(at.acceleration, table[:, 6:9], atol=1e-9)
    choreo_forces = np.stack([[r["fx"] for r in rows], [r["fy"] for r in rows]], axis=-1)
    assert trajectory.module_forces is not None
    np.testing.assert_array_equal(trajectory.module_forces,
                                  choreo_forces[:, [0, 3, 1, 2]])  # FL, FR(4th), RL(2nd), RR
    assert trajectory.name == "generated" and trajectory.start_time == 0.0
    assert trajectory.end_time == 6.0 and trajectory.period is None
    assert trajectory.events == (ChoreoEvent("intake", 1.35), ChoreoEvent("untimed", None))
    assert trajectory.config == ChoreoConfig((0.3, 0.25), (-0.28, 0.27), 60.0, 6.0, 6.5, 0.05,
                                             600.0, 1.2, 1.5)


def test_interpolation_is_close_to_a_smooth_path_and_continuous(tmp_path: Path) -> None:
    times = np.linspace(0.0, 6.0, 121)  # h = 0.05 s
    trajectory = read_choreo(write(tmp_path, document(samples(circle_axes(), times))))
    t = np.random.default_rng(5).uniform(0.0, 6.0, 300)
    exact = np.stack([np.cos(t), np.sin(t), 0.7 * t], axis=1)
    # quintic Hermite error <= max|f^(6)| h^6 / (720 * 64) = 3.4e-13 for this circle
    np.testing.assert_allclose(trajectory.sample(t).pose, exact, atol=1e-11)
    for knot in times[1:-1]:
        left, right = trajectory.sample(knot - 1e-9), trajectory.sample(knot + 1e-9)
        for a, b in ((left.pose, right.pose), (left.velocity, right.velocity),
                     (left.acceleration, right.acceleration)):
            np.testing.assert_allclose(a, b, atol=1e-7)


def test_constant_acceleration_samples_differ_from_their_quadratics_as_documented(
        tmp_path: Path) -> None:
    rng = np.random.default_rng(11)
    h, count = 0.05, 30
    accel = rng.uniform(-3.0, 3.0, (count, 3))
    position, velocity = np.zeros((count, 3)), np.zeros((count, 3))
    for k in range(count - 1):  # Choreo's optimiser: a_k held over interval k
        position[k + 1] = position[k] + velocity[k] * h + 0.5 * accel[k] * h * h
        velocity[k + 1] = velocity[k] + accel[k] * h
    times = h * np.arange(count)
    rows = [{"t": float(times[k]), "x": position[k, 0], "y": position[k, 1],
             "heading": position[k, 2], "vx": velocity[k, 0], "vy": velocity[k, 1],
             "omega": velocity[k, 2], "ax": accel[k, 0], "ay": accel[k, 1],
             "alpha": accel[k, 2]} for k in range(count)]
    trajectory = read_choreo(write(tmp_path, document(rows)))
    assert trajectory.module_forces is None
    tau = 0.6 * h  # the largest gap, at s = 3/5
    middle = times[:-1] + tau
    quadratic = position[:-1] + velocity[:-1] * tau + 0.5 * accel[:-1] * tau**2
    gap = trajectory.sample(middle).pose - quadratic
    np.testing.assert_allclose(gap, 0.6**3 * 0.4**2 / 2 * np.diff(accel, axis=0) * h * h,
                               atol=1e-13)


def test_robot_from_config_maps_module_order_and_limits(tmp_path: Path) -> None:
    trajectory = read_choreo(polynomial_file(tmp_path), max_steer_rate=20.0)
    robot = trajectory.robot
    assert isinstance(robot, SwerveRobot)
    choreo_order = [(0.3, 0.25), (-0.28, 0.27), (-0.28, -0.27), (0.3, -0.25)]  # FL BL BR FR
    expected = np.array(choreo_order)[list(CHOREO_TO_OURS)]
    np.testing.assert_array_equal(robot.module_positions, expected)
    np.testing.assert_array_equal(expected, [(0.3, 0.25), (0.3, -0.25), (-0.28, 0.27),
                                             (-0.28, -0.27)])  # FL, FR, RL, RR
    np.testing.assert_allclose(robot.max_wheel_speed, 600.0 / 6.5)
    assert robot.wheel_radius == 0.05 and robot.max_steer_rate == 20.0
    assert robot.max_wheel_accel is None
    config = trajectory.config
    force = min(1.2 * 6.5 / 0.05, 1.5 * 60.0 * 9.8 / 4)  # torque-limited here: 156 N
    assert config.max_module_force == pytest.approx(156.0)
    assert config.max_wheel_accel == pytest.approx(4 * force / (60.0 * 0.05))
    limited = choreo_robot(config, max_wheel_accel=config.max_wheel_accel)
    assert limited.max_wheel_accel is not None
    np.testing.assert_allclose(limited.max_wheel_accel, 208.0)
    assert choreo_robot(config).max_steer_rate == 12.0


def test_hand_written_minimal_file() -> None:
    trajectory = read_choreo(DATA / "minimal.traj")
    sample = trajectory.sample(np.array([0.25, 0.75]))  # x = t^2, heading = t / 2
    np.testing.assert_allclose(sample.pose, [[0.0625, 0.0, 0.125], [0.5625, 0.0, 0.375]],
                               atol=1e-14)
    np.testing.assert_allclose(sample.velocity, [[0.5, 0.0, 0.5], [1.5, 0.0, 0.5]], atol=1e-14)
    assert trajectory.name == "minimal" and trajectory.events == ()
    assert trajectory.module_forces is None and trajectory.robot.n_wheels == 4


def test_closed_loop_on_the_planned_robot_stays_within_limits(tmp_path: Path) -> None:
    path = polynomial_file(tmp_path)
    config = read_choreo(path).config
    trajectory = read_choreo(path, max_wheel_accel=config.max_wheel_accel)
    robot = trajectory.robot
    assert feasibility(trajectory, robot).peak_ratio < 0.5
    controller = Controller(robot, trajectory, horizon=20, dt=0.05)
    result = simulate(controller, duration=trajectory.end_time + 1.0)
    metrics = result.metrics(skip=0.5)  # the modules start at 0 deg and steer at 12 rad/s
    assert metrics["limit_violations"] == 0 and metrics["accel_violations"] == 0
    assert metrics["max_wheel_speed_ratio"] <= 1.0 + 1e-6
    # measured 1.3 mm RMS (a time-optimal plan, at the limits; 0.1 s stages)
    assert metrics["rms_position_error"] < 2e-3 and metrics["max_position_error"] < 4e-3
    np.testing.assert_allclose(result.pose[-1], trajectory.sample(DURATION).pose, atol=2e-3)


def _set(document: dict[str, Any], dotted: str, value: Any) -> None:
    """Set (or delete, for value ``...``) the field at a dotted path with [i] indices."""
    keys: list[Any] = []
    for part in dotted.split("."):
        name, *indices = part.replace("]", "").split("[")
        keys += [name] + [int(i) for i in indices]
    parent: Any = document
    for key in keys[:-1]:
        parent = parent[key]
    if value is ...:
        del parent[keys[-1]]
    else:
        parent[keys[-1]] = value


BAD_FIELDS = [
    ("version", 2, "version: expected 3"),
    ("version", "3", "version: expected 3"),
    ("version", ..., "version: missing"),
    ("trajectory.sampleType", "Differential", 'trajectory.sampleType: expected "Swerve", got '
                                              '"Differential"'),
    ("trajectory.sampleType", ..., "trajectory.sampleType: missing"),
    ("trajectory", ..., "trajectory: missing"),
    ("trajectory.samples", ..., "trajectory.samples: missing"),
    ("trajectory.samples", [], "trajectory.samples: expected a list of at least 2 samples"),
    ("trajectory.samples[3].vx", "fast", 'trajectory.samples[3].vx: expected a number, got '
                                         '"fast"'),
    ("trajectory.samples[2].alpha", ..., "trajectory.samples[2].alpha: missing"),
    ("trajectory.samples[4].x", True, "trajectory.samples[4].x: expected a number, got true"),
    ("trajectory.samples[5].t", 0.1, "trajectory.samples[5].t: expected a time after 0.2"),
    ("trajectory.samples[1]", [1, 2], "trajectory.samples[1]: expected an object"),
    ("trajectory.samples[0].fx", [1.0, 2.0], "trajectory.samples[0].fx: expected 4 numbers"),
    ("trajectory.samples[0].fy[2]", "x", "trajectory.samples[0].fy[2]: expected a number"),
    ("trajectory.config", ..., "trajectory.config: missing"),
    ("trajectory.config.radius", -0.05, "trajectory.config.radius: expected a finite number "
                                        "> 0, got -0.05"),
    ("trajectory.config.frontLeft.y", ..., "trajectory.config.frontLeft.y: missing"),
    ("trajectory.config.vmax", None, "trajectory.config.vmax: missing"),
    ("name", 7, "name: expected a string, got 7"),
    ("events", {}, "events: expected a list"),
    ("events[0].name", 3, "events[0].name: expected a string"),
    ("events[0].from.targetTimestamp", "soon", "events[0].from.targetTimestamp: expected a "
                                               "number"),
]


@pytest.mark.parametrize(("field", "value", "expected"), BAD_FIELDS)
def test_bad_fields_give_one_line_errors_naming_file_and_field(
        tmp_path: Path, field: str, value: Any, expected: str) -> None:
    content = document(samples(circle_axes(), np.linspace(0.0, 0.5, 11)))
    _set(content, field, value)
    path = write(tmp_path, content)
    with pytest.raises(TrajectoryError) as error:
        read_choreo(path)
    message = str(error.value)
    assert message.startswith(f"choreo file {str(path)!r}: {expected}"), message
    assert "\n" not in message


def test_the_documented_example_message(tmp_path: Path) -> None:
    content = document(samples(circle_axes(), np.linspace(0.0, 0.5, 11)))
    content["trajectory"]["samples"][3]["vx"] = "fast"
    path = write(tmp_path, content, "x.traj")
    with pytest.raises(TrajectoryError, match=r"^choreo file '.*x\.traj': trajectory\.samples"
                                              r'\[3\]\.vx: expected a number, got "fast"$'):
        read_choreo(path)


@pytest.mark.parametrize(("content", "expected"), [
    ("{ not json", "not valid JSON"),
    ("[1, 2]", "(top level): expected an object"),
    ('{"version": 3, "trajectory": {"sampleType": "Swerve", "samples": [], "config": {}}}',
     "trajectory.config.frontLeft: missing"),
])
def test_unusable_files(tmp_path: Path, content: str, expected: str) -> None:
    path = write(tmp_path, content)
    with pytest.raises(TrajectoryError) as error:
        read_choreo(path)
    assert str(error.value).startswith(f"choreo file {str(path)!r}: {expected}")
    with pytest.raises(TrajectoryError, match="does not exist"):
        read_choreo(tmp_path / "missing.traj")


def test_nan_in_a_sample_is_refused(tmp_path: Path) -> None:
    content = json.dumps(document(samples(circle_axes(), np.linspace(0.0, 0.5, 11))))
    path = write(tmp_path, re.sub(r'"ay": [-0-9.e]+', '"ay": NaN', content, count=1))
    with pytest.raises(TrajectoryError, match=r"samples\[\d+\]\.ay: expected a finite number, "
                                              "got NaN"):
        read_choreo(path)


def test_heading_override_and_repr(tmp_path: Path) -> None:
    trajectory = read_choreo(polynomial_file(tmp_path), heading=0.0)
    assert np.all(trajectory.sample(np.linspace(0, DURATION, 7)).pose[:, 2] == 0.0)
    assert "61 samples" in repr(trajectory) and math.isclose(trajectory.duration or 0, 3.0)


def test_modules_at_one_point_are_refused_naming_the_config(tmp_path: Path) -> None:
    content = document(samples(circle_axes(), np.linspace(0.0, 0.5, 11)))
    for side in ("frontLeft", "backLeft"):
        content["trajectory"]["config"][side] = {"x": 0.0, "y": 0.0}
    path = write(tmp_path, content)
    with pytest.raises(TrajectoryError, match=r"^choreo file '.*': trajectory\.config: "
                                              "module_positions: modules 0 and 1 must stand "
                                              "apart"):
        read_choreo(path)


def test_sampled_trajectory_without_accelerations_is_cubic_hermite() -> None:
    cubic = Polynomial([0.5, -1.0, 2.0, -0.7])  # reproduced exactly from values and slopes
    times = np.array([0.0, 0.4, 1.1, 2.0])
    values = np.stack([cubic(times), 2 * cubic(times), 0.1 * cubic(times)], axis=1)
    slopes = np.stack([cubic.deriv()(times), 2 * cubic.deriv()(times),
                       0.1 * cubic.deriv()(times)], axis=1)
    trajectory = SampledTrajectory(times, values, slopes)
    t = np.random.default_rng(8).uniform(0.0, 2.0, 50)
    np.testing.assert_allclose(trajectory.sample(t).pose[:, 1], 2 * cubic(t), atol=1e-12)
    np.testing.assert_allclose(trajectory.sample(t).acceleration[:, 0], cubic.deriv(2)(t),
                               atol=1e-10)
    assert trajectory.accelerations is None
    with pytest.raises(TrajectoryError, match="strictly increasing"):
        SampledTrajectory([0.0, 0.0], values[:2], slopes[:2])
    with pytest.raises(TrajectoryError, match=r"velocities must have shape \(4, 3\)"):
        SampledTrajectory(times, values, slopes[:3])
    with pytest.raises(TrajectoryError, match="poses must be finite"):
        SampledTrajectory(times, np.full((4, 3), np.nan), slopes)
