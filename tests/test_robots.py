"""Robot kinematics against hand-derived check values (README, "Conventions"), round trips,
invariants and validation."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpc.errors import MpcError, RobotError
from mpc.robots import (
    PRESETS,
    SwedishRobot,
    SwedishWheel,
    SwerveRobot,
    load,
    mecanum,
    omni,
    preset,
    swerve,
)

MECANUM = mecanum(wheelbase=0.30, track=0.25, wheel_radius=0.05, max_wheel_speed=20.0)
SWERVE = swerve(
    module_positions=[[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3], [-0.3, -0.3]],
    wheel_radius=0.05,
    max_wheel_speed=30.0,
    max_steer_rate=10.0,
)

twists = st.tuples(*(st.floats(-3, 3, allow_nan=False) for _ in range(3))).map(np.array)


@pytest.mark.parametrize(
    ("twist", "surface_speed"),
    [
        ((1, 0, 0), (1, 1, 1, 1)),
        ((0, 1, 0), (-1, 1, 1, -1)),
        ((0, 0, 1), (-0.275, 0.275, -0.275, 0.275)),
    ],
)
def test_mecanum_check_values(twist: np.ndarray, surface_speed: tuple[float, ...]) -> None:
    np.testing.assert_allclose(MECANUM.wheel_speeds(twist) * 0.05, surface_speed, atol=1e-12)


def test_mecanum_batched_matches_single() -> None:
    batch = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, -0.2, 0.7]])
    single = np.array([MECANUM.wheel_speeds(t) for t in batch])
    np.testing.assert_allclose(MECANUM.wheel_speeds(batch), single)


def test_omni_formula_and_ccw_spin() -> None:
    robot = omni(n_wheels=3, base_radius=0.15, wheel_radius=0.03, max_wheel_speed=30.0,
                 first_wheel_angle=math.radians(60))
    alphas = np.radians([60, 180, 300])
    vx, vy, w = 0.4, -0.3, 1.2
    expected = (-np.sin(alphas) * vx + np.cos(alphas) * vy + 0.15 * w) / 0.03
    np.testing.assert_allclose(robot.wheel_speeds([vx, vy, w]), expected, atol=1e-12)
    # A positive speed on every wheel spins the robot counter-clockwise.
    twist = robot.twist(np.ones(3))
    np.testing.assert_allclose(twist[:2], 0.0, atol=1e-12)
    assert twist[2] > 0


def test_omni4_x_layout_forward() -> None:
    robot = preset("omni4")  # wheels at 45, 135, 225, 315 degrees, radius 0.05
    s = math.sqrt(0.5)
    np.testing.assert_allclose(robot.wheel_speeds([1, 0, 0]) * 0.05, [-s, -s, s, s], atol=1e-12)


def test_swerve_check_values_spin() -> None:
    speeds, angles = SWERVE.module_states([0, 0, 1])
    np.testing.assert_allclose(speeds * 0.05, 0.4243, atol=1e-4)
    assert math.degrees(angles[0]) == pytest.approx(135)
    assert math.degrees(angles[1]) == pytest.approx(45)
    np.testing.assert_allclose(SWERVE.wheel_speeds([0, 0, 1]) * 0.05, 0.4243, atol=1e-4)


def test_swerve_flip_beyond_90_degrees() -> None:
    # Ask every module for 170 degrees (pure translation) while at 0: flip to -10, drive back.
    direction = math.radians(170)
    twist = [math.cos(direction), math.sin(direction), 0.0]
    speeds, angles = SWERVE.module_states(twist, current_angles=np.zeros(4))
    np.testing.assert_allclose(np.degrees(angles), -10.0, atol=1e-9)
    np.testing.assert_allclose(speeds, -1.0 / 0.05)


def test_swerve_exactly_90_degrees_does_not_flip() -> None:
    speeds, angles = SWERVE.module_states([0, 1, 0], current_angles=np.zeros(4))
    np.testing.assert_allclose(angles, math.pi / 2)
    np.testing.assert_allclose(speeds, 1.0 / 0.05)


def test_swerve_stopped_module_keeps_angle() -> None:
    current = np.array([0.1, -0.2, 0.3, 2.0])
    speeds, angles = SWERVE.module_states([0, 0, 0], current_angles=current)
    np.testing.assert_allclose(speeds, 0.0)
    np.testing.assert_allclose(angles, current)


def test_states_from_module_velocities_are_those_of_the_twist_and_check_their_shapes() -> None:
    """``states_from_velocities`` takes ground velocities [m/s] (n, 2): those of a twist
    give that twist's module states; a wrong shape or angle count is a RobotError."""
    twist = np.array([0.4, -0.2, 0.7])
    current = np.array([0.1, 2.5, -1.0, 0.3])
    velocities = SWERVE.module_velocities(twist)
    for states, expected in ((SWERVE.states_from_velocities(velocities, current),
                             SWERVE.module_states(twist, current)),
                            (SWERVE.states_from_velocities(velocities),
                             SWERVE.module_states(twist))):
        np.testing.assert_allclose(states[0], expected[0], rtol=1e-12)
        np.testing.assert_allclose(states[1], expected[1], rtol=1e-12)
    with pytest.raises(RobotError, match="velocities must have shape"):
        SWERVE.states_from_velocities(velocities[:3])
    with pytest.raises(RobotError, match="current_angles must be 4 finite angles"):
        SWERVE.states_from_velocities(velocities, 0.3)
    with pytest.raises(RobotError, match="current_angles must be 4 finite angles"):
        SWERVE.states_from_velocities(velocities, [0.0, math.nan, 0.0, 0.0])


@settings(max_examples=60, deadline=None)
@given(twists)
def test_round_trips(twist: np.ndarray) -> None:
    for robot in (MECANUM, preset("omni3"), preset("omni4")):
        np.testing.assert_allclose(robot.twist(robot.wheel_speeds(twist)), twist,  # type: ignore[attr-defined]
                                   atol=1e-9)
    speeds, angles = SWERVE.module_states(twist, current_angles=np.full(4, 0.5))
    # Modules slower than STOPPED_MODULE_SPEED (1e-6 m/s) are commanded to rest.
    np.testing.assert_allclose(SWERVE.twist(speeds, angles), twist, atol=1e-5)


@settings(max_examples=60, deadline=None)
@given(twists, st.floats(0.01, 10))
def test_desaturate_keeps_direction_and_limits(twist: np.ndarray, scale: float) -> None:
    for robot in (MECANUM, SWERVE):
        out = robot.desaturate(twist * scale)
        assert robot.is_feasible(out)
        # Parallel to the input, never longer.
        assert np.linalg.norm(out) <= np.linalg.norm(twist * scale) + 1e-12
        np.testing.assert_allclose(np.cross(out, twist * scale), 0.0, atol=1e-9)
        if robot.is_feasible(twist * scale):
            np.testing.assert_allclose(out, twist * scale)
        else:
            assert robot.speed_ratio(out) == pytest.approx(1.0)


def test_feasible_set_is_not_a_box() -> None:
    # Full forward speed leaves no room to strafe on a Mecanum chassis.
    assert MECANUM.is_feasible([1.0, 0.0, 0.0])
    assert MECANUM.is_feasible([0.0, 1.0, 0.0])
    assert not MECANUM.is_feasible([1.0, 0.1, 0.0])


def test_derated_wheel() -> None:
    weak = MECANUM.derated({1: 0.5})
    np.testing.assert_allclose(weak.max_wheel_speed, [20, 10, 20, 20])
    assert not weak.is_feasible([1.0, 0, 0])
    dead = preset("omni4").derated({0: 0.0})
    assert dead.speed_ratio([0.0, 0.0, 0.0]) == 0.0
    assert dead.speed_ratio([0.1, 0.0, 0.0]) == math.inf
    np.testing.assert_allclose(dead.desaturate([0.1, 0.0, 0.0]), 0.0)
    with pytest.raises(RobotError, match="derating factors"):
        MECANUM.derated({0: 1.5})
    with pytest.raises(RobotError, match=r"derating factors must be 0 .* or at least 1e-06"):
        MECANUM.derated({0: 1e-14})  # lost in the other wheels' rounding
    assert MECANUM.derated({0: 1e-6}).max_wheel_speed[0] > 0.0
    with pytest.raises(RobotError, match="wheel index"):
        MECANUM.derated({7: 0.5})


@pytest.mark.parametrize("name", PRESETS)
def test_presets_load(name: str) -> None:
    robot = preset(name)
    assert robot.n_wheels >= 3 or name == "swerve"
    assert np.all(robot.max_wheel_speed > 0)


def test_load_toml_matches_factory(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(
        'type = "mecanum"\nname = "mine"\nwheelbase = 0.30\ntrack = 0.25\n'
        "wheel_radius = 0.05\nmax_wheel_speed = 20.0\n"
    )
    robot = load(path)
    assert robot.name == "mine"
    np.testing.assert_allclose(robot.wheel_speeds([0.2, 0.1, 0.5]),
                               MECANUM.wheel_speeds([0.2, 0.1, 0.5]))


def test_load_swedish_wheels_table(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    rows = "".join(
        f"[[wheels]]\nalpha = {a}\nbeta = 3.141592653589793\ngamma = 0.0\nl = 0.2\n"
        "radius = 0.05\nmax_speed = 10.0\n"
        for a in (0.0, 2.0, 4.0)
    )
    path.write_text('type = "swedish"\n' + rows)
    robot = load(path)
    assert isinstance(robot, SwedishRobot) and robot.n_wheels == 3


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('type = "tank"\n', "type must be one of"),
        ('type = "mecanum"\nwheelbase = 0.3\ntrack = 0.2\nwheel_radius = 0.05\n'
         "max_wheel_speed = 20.0\ncolour = 1\n", r"unknown key\(s\) \['colour'\]"),
        ('type = "mecanum"\nwheelbase = 0.3\n', "missing"),
        ("type = [", "not valid TOML"),
    ],
)
def test_load_errors(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(text)
    with pytest.raises(RobotError, match=match):
        load(path)


def test_load_missing_file(tmp_path: Path) -> None:
    with pytest.raises(RobotError, match="robot file .* does not exist"):
        load(tmp_path / "nope.toml")


def test_unknown_preset_lists_names() -> None:
    with pytest.raises(RobotError, match="omni3"):
        preset("hexapod")


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: mecanum(wheelbase=0.3, track=0.2, wheel_radius=0.0, max_wheel_speed=1.0),
         r"wheel_radius must be a number of metres in \[1e-06, 1000\]"),
        (lambda: mecanum(wheelbase=0.3, track=0.2, wheel_radius=0.05, max_wheel_speed=-1.0),
         "max_wheel_speed must be a finite number > 0"),
        (lambda: mecanum(wheelbase=float("nan"), track=0.2, wheel_radius=0.05,
                         max_wheel_speed=1.0), "wheelbase"),
        (lambda: omni(n_wheels=2, base_radius=0.2, wheel_radius=0.05, max_wheel_speed=1.0),
         "n_wheels must be an integer >= 3"),
        (lambda: omni(n_wheels=3, base_radius=0.2, wheel_radius=0.05, max_wheel_speed=1.0,
                      max_wheel_accel=float("inf")), "max_wheel_accel must be"),
        (lambda: swerve(module_positions=[[0.3, 0.3]], wheel_radius=0.05, max_wheel_speed=1.0,
                        max_steer_rate=5.0), r"shape \(n, 2\)"),
        (lambda: swerve(module_positions=[[0.0, 0.0], [0.0, 0.0]], wheel_radius=0.05,
                        max_wheel_speed=1.0, max_steer_rate=5.0), "must stand apart"),
        (lambda: swerve(module_positions=[[0.3, 0.3], [0.3, -0.3]], wheel_radius=0.05,
                        max_wheel_speed=1.0, max_steer_rate=0.0), "max_steer_rate"),
    ],
)
def test_bad_descriptions(build: Callable[[], object], match: str) -> None:
    with pytest.raises(RobotError, match=match):
        build()


def test_parallel_wheels_are_not_holonomic() -> None:
    wheel = dict(beta=0.0, gamma=0.0, l=0.2, radius=0.05, max_speed=10.0)
    # All three wheel planes parallel: alpha + beta equal, so no sideways drive.
    wheels = tuple(SwedishWheel(alpha=0.0, **wheel) for _ in range(3))
    with pytest.raises(RobotError, match="not holonomic"):
        SwedishRobot(name="parallel", wheels=wheels)


@pytest.mark.parametrize(
    ("twist", "match"),
    [([1.0, 0.0], r"shape \(3,\) or \(k, 3\)"), ([np.nan, 0.0, 0.0], "finite")],
)
def test_bad_twists(twist: np.ndarray, match: str) -> None:
    with pytest.raises(MpcError, match=match):
        MECANUM.wheel_speeds(twist)


def test_errors_are_value_errors() -> None:
    assert issubclass(RobotError, ValueError)
    assert issubclass(RobotError, MpcError)
    with pytest.raises(ValueError):
        MECANUM.twist([1.0, 2.0])


def test_swedish_robot_takes_its_wheels_positionally() -> None:
    wheels = preset("omni3").wheels  # type: ignore[attr-defined]
    robot = SwedishRobot(wheels, name="three")
    assert robot.name == "three" and robot.n_wheels == 3
    with pytest.raises(RobotError, match="at least 3 SwedishWheel"):
        SwedishRobot(wheels[:2])


@pytest.mark.parametrize("index", [1.9, True, "1", -1, 4])
def test_derating_index_must_be_a_wheel_number(index: object) -> None:
    with pytest.raises(RobotError, match="wheel index must be an integer in 0..3"):
        MECANUM.derated({index: 0.5})  # type: ignore[dict-item]


@pytest.mark.parametrize("name", PRESETS)
def test_forward_kinematics_inverts_the_commands(name: str) -> None:
    """The plant's forward map recovers the twist from what wheel_commands sends."""
    robot = preset(name)
    rng = np.random.default_rng(3)
    steer = robot.initial_steer_angles()
    for twist in rng.normal(size=(20, 3)):
        speeds, steer = robot.wheel_commands(twist, steer)
        np.testing.assert_allclose(robot.forward_kinematics(speeds, steer), twist, atol=1e-12)
        if isinstance(robot, SwerveRobot) and robot.axle_offset:  # a bound: |v| + L |omega|
            assert np.all(robot.wheel_magnitudes(twist) >= np.abs(speeds) * (1 - 1e-12))
        else:
            np.testing.assert_allclose(robot.wheel_magnitudes(twist), np.abs(speeds),
                                       rtol=1e-12)


@pytest.mark.parametrize("name", PRESETS)
def test_casadi_limits_agree_with_wheel_magnitudes(name: str) -> None:
    """The NLP's limit expression holds exactly when every wheel is within its bound."""
    import casadi as ca

    robot = preset(name)
    symbol = ca.SX.sym("u", 3)
    bounds = robot.max_wheel_speed
    g, low, high = robot.casadi_limits(symbol, bounds)
    values = ca.Function("g", [symbol], [g])
    rng = np.random.default_rng(4)
    for twist in rng.normal(size=(50, 3)) * 0.8:
        inside = bool(np.all(robot.wheel_magnitudes(twist) <= bounds))
        value = np.asarray(values(twist)).ravel()
        assert inside == bool(np.all((low <= value) & (value <= high)))
# QP speed rows (the swerve polygon) ----------------------------------------


@pytest.mark.parametrize("robot_name", ["omni3", "omni4", "mecanum"])
def test_polygon_rows_for_swedish_wheels_are_the_jacobian(robot_name: str) -> None:
    robot = preset(robot_name)
    assert isinstance(robot, SwedishRobot)
    rows, wheel, scale = robot.qp_speed_rows(polygon_sides=16)
    np.testing.assert_array_equal(rows, robot.jacobian)
    np.testing.assert_array_equal(wheel, np.arange(robot.n_wheels))
    assert scale == 1.0


@pytest.mark.parametrize("sides", [4, 8, 16, 64])
def test_swerve_polygon_lies_midway_between_inscribed_and_circumscribed(sides: int) -> None:
    """For each module, twists mapping to the polygon's vertices and edge points satisfy
    every row bound (the adjacent rows tightly), lie between R (1 + c) / 2 (the edges'
    middles) and R (1 + c) / (2 c) (the vertices), c = cos(pi / sides), and points just
    outside the polygon violate a row."""
    robot = preset("swerve")
    rows, wheel, factor = robot.qp_speed_rows(sides)
    c = math.cos(math.pi / sides)
    assert factor == pytest.approx((1.0 + c) / 2.0)  # the apothem, as a fraction of R
    assert rows.shape == (robot.n_wheels * sides // 2, 3)
    bound = robot.max_wheel_speed[wheel] * factor
    limit = robot.max_wheel_speed[0]
    corner = limit * factor / c  # the vertices' distance
    vertex_angles = 2 * math.pi * (np.arange(sides) + 0.5) / sides
    vertices = corner * np.stack([np.cos(vertex_angles), np.sin(vertex_angles)], axis=1)
    for module in range(robot.n_wheels):
        inverse = np.linalg.pinv(robot.wheel_blocks[module])  # (3, 2): W_i @ inverse = I
        mine = wheel == module
        for m in range(sides):
            for s in (0.0, 0.3, 0.5):  # a vertex and points along the edge to the next one
                point = (1 - s) * vertices[m] + s * vertices[(m + 1) % sides]
                twist = inverse @ point
                np.testing.assert_allclose(robot.wheel_velocities(twist)[module], point,
                                           atol=1e-12)
                values = np.abs(rows[mine] @ twist)
                assert np.all(values <= bound[mine] * (1 + 1e-12))
                assert values.max() == pytest.approx(bound[mine][0], rel=1e-12)  # on an edge
                radius = np.linalg.norm(point) / limit
                assert (1.0 + c) / 2.0 * (1 - 1e-12) <= radius <= (1.0 + c) / (2.0 * c) + 1e-12
                outside = inverse @ (point * (1 + 1e-6))
                assert np.any(np.abs(rows[mine] @ outside) > bound[mine])


@pytest.mark.parametrize("sides", [2, 3, 5, 15])
def test_polygon_sides_must_be_even_and_at_least_4(sides: int) -> None:
    with pytest.raises(RobotError, match="polygon_sides"):
        preset("swerve").qp_speed_rows(sides)
