"""Numbers in the wrong unit fail loudly (mpc.plausibility): each plausible range's bound,
the allow_unusual override (factory keyword, robot-file key, Controller), the issue's two
mistakes (millimetre geometry, a heading in degrees), and real robots passing untouched."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mpc.plausibility as plausibility
from mpc import Controller, ControllerError, Status
from mpc.errors import RobotError, SimulationError
from mpc.plausibility import HEADING, LIMITS
from mpc.robots import (
    MOTOR_ROBOT_PRESETS,
    PRESETS,
    Robot,
    caster,
    dynamics,
    from_dict,
    load,
    mecanum,
    motor_preset,
    omni,
    preset,
    spherical,
    swerve,
    wheel_set,
)
from mpc.sim import simulate
from trajectories import Circle, SpinHeading

SQUARE = [[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3], [-0.3, -0.3]]  # [m]
FAR = [[1.2, 1.2], [1.2, -1.2], [-1.2, 1.2], [-1.2, -1.2]]  # [m] room for 0.5 m offsets
MECANUM: dict[str, Any] = {"wheelbase": 0.3, "track": 0.25, "wheel_radius": 0.05,
                           "max_wheel_speed": 20.0}
SWERVE: dict[str, Any] = {"module_positions": SQUARE, "wheel_radius": 0.05,
                          "max_wheel_speed": 20.0, "max_steer_rate": 10.0}
CASTER: dict[str, Any] = {"positions": FAR, "offset": 0.045, "wheel_radius": 0.05,
                          "max_wheel_speed": 20.0, "max_steer_rate": 10.0}
BALLS: dict[str, Any] = {"positions": [[0.0, 0.2], [-0.17, -0.1], [0.17, -0.1]],
                         "wheel_radius": 0.05, "max_wheel_speed": 20.0}
OMNI: dict[str, Any] = {"n_wheels": 3, "base_radius": 0.15, "wheel_radius": 0.03,
                        "max_wheel_speed": 30.0}
MOTORS: dict[str, Any] = {"mass": 50.0, "yaw_inertia": 4.0, "motor": "kraken_x60",
                          "gearing": 6.75}


def ring(radius: float) -> list[list[float]]:
    """Four points at ``radius`` [m] from the origin."""
    return [[radius, 0.0], [0.0, radius], [-radius, 0.0], [0.0, -radius]]


def wheels_at(radius: float) -> list[dict[str, Any]]:
    """A wheel set of four steered modules at ``radius`` [m] from the origin."""
    return [{"type": "steered", "x": x, "y": y} for x, y in ring(radius)]


# (factory, keyword arguments, the argument, a value just within its bound, one just
# beyond, the name the message gives): every bound, on every factory that takes it.
BOUNDS: list[tuple[Callable[..., Any], dict[str, Any], str, Any, Any, str]] = [
    (mecanum, MECANUM, "wheelbase", 5.0, 5.01, "wheelbase"),
    (mecanum, MECANUM, "track", 5.0, 5.01, "track"),
    (omni, OMNI, "base_radius", 5.0, 5.01, "base_radius"),
    (swerve, SWERVE, "module_positions", ring(5.0), ring(5.01), r"module_positions\[0\]"),
    (caster, CASTER, "positions", ring(5.0), ring(5.01), r"positions\[0\]"),
    (spherical, BALLS, "positions", ring(5.0)[:3], ring(5.01)[:3], r"positions\[0\]"),
    (wheel_set, {**SWERVE, "module_positions": None}, "wheels", wheels_at(5.0),
     wheels_at(5.01), r"wheels\[0\]"),
    (mecanum, MECANUM, "wheel_radius", 0.5, 0.51, "wheel_radius"),
    (swerve, SWERVE, "wheel_radius", 0.5, 0.51, "wheel_radius"),
    (caster, CASTER, "wheel_radius", 0.5, 0.51, "wheel_radius"),
    (spherical, BALLS, "wheel_radius", 0.5, 0.51, "wheel_radius"),
    (caster, CASTER, "offset", 0.5, 0.51, "offset"),
    (swerve, SWERVE, "axle_offset", 0.5, 0.51, "axle_offset"),
    (mecanum, {**MECANUM, "wheel_radius": 0.01}, "max_wheel_speed", 1000.0, 1001.0,
     "max_wheel_speed"),
    (spherical, {**BALLS, "wheel_radius": 0.01}, "max_wheel_speed", [[10.0, 1000.0]] * 3,
     [[10.0, 1001.0]] * 3, r"max_wheel_speed\[1\]"),
    # the rim: radius x limit
    (mecanum, {**MECANUM, "wheel_radius": 0.1}, "max_wheel_speed", 200.0, 201.0,
     "rim speed"),
    (caster, {**CASTER, "wheel_radius": 0.1}, "max_wheel_speed", 200.0, 201.0, "rim speed"),
    (omni, {**OMNI, "wheel_radius": 0.1}, "max_wheel_accel", 1000.0, 1001.0,
     "rim acceleration"),
    (swerve, {**SWERVE, "wheel_radius": 0.1}, "max_wheel_accel", 1000.0, 1001.0,
     "rim acceleration"),
    (swerve, SWERVE, "max_steer_rate", 200.0, 201.0, "max_steer_rate"),
    (caster, CASTER, "max_steer_rate", 200.0, 201.0, "max_steer_rate"),
    (dynamics, MOTORS, "mass", 1e5, 1.01e5, "mass"),
]


def call(factory: Callable[..., Any], arguments: dict[str, Any], name: str, value: Any,
         **extra: Any) -> Any:
    """``factory`` with ``name`` set to ``value`` (a wheel set's modules: ``wheels``)."""
    options = {k: v for k, v in arguments.items() if v is not None}
    return factory(**{**options, name: value, **extra})


@pytest.mark.parametrize(("factory", "arguments", "name", "within", "beyond", "shown"),
                         BOUNDS, ids=[f"{f.__name__}-{n}" for f, _, n, *_ in BOUNDS])
def test_each_bound_refuses_just_beyond_it_and_accepts_it(
        factory: Callable[..., Any], arguments: dict[str, Any], name: str, within: Any,
        beyond: Any, shown: str) -> None:
    call(factory, arguments, name, within)
    with pytest.raises(RobotError, match=rf"{shown}.* is over .*Pass allow_unusual=True"):
        call(factory, arguments, name, beyond)
    call(factory, arguments, name, beyond, allow_unusual=True)


def test_the_issue_s_millimetre_mecanum_is_refused_naming_millimetres() -> None:
    with pytest.raises(RobotError, match=r"wheelbase 300 m is over 5 m.*millimetres \(0\.3 m\)"):
        mecanum(wheelbase=300, track=250, wheel_radius=50, max_wheel_speed=20)
    with pytest.raises(RobotError, match=r"wheel_radius 50 m .*millimetres \(0\.05 m\)"):
        mecanum(wheelbase=0.3, track=0.25, wheel_radius=50, max_wheel_speed=20)
    real = mecanum(wheelbase=300, track=250, wheel_radius=50, max_wheel_speed=20,
                   allow_unusual=True)
    assert real.wheels[0].radius == 50.0  # taken as given once allowed


@pytest.mark.parametrize(("arguments", "hint"), [
    ({"max_wheel_speed": 5676.0}, r"rpm \(594 rad/s\)"),  # a NEO's free speed in rpm
    ({"max_wheel_speed": 889.0, "wheel_radius": 0.0508},  # 889 rpm at an FRC wheel
     r"rim speed of 45.16 m/s.*rpm \(93.1 rad/s\)"),
    ({"max_wheel_accel": 2292.0}, r"degrees/s\^2 \(40 rad/s\^2\)"),  # 40 rad/s^2 in degrees
    ({"wheel_radius": 2.0}, r"inches \(0.0508 m\)"),  # a 4 in wheel's radius in inches
])
def test_messages_name_the_unit_mistake_that_explains_the_value(arguments: dict[str, Any],
                                                                 hint: str) -> None:
    with pytest.raises(RobotError, match=hint):
        mecanum(**{**MECANUM, **arguments})


def test_robot_files_take_allow_unusual_as_a_key_covering_their_dynamics(
        tmp_path: Path) -> None:
    body = ('type = "mecanum"\nwheelbase = 300\ntrack = 250\nwheel_radius = 50\n'
            'max_wheel_speed = 20\n')
    file = tmp_path / "robot.toml"
    file.write_text(body)
    with pytest.raises(RobotError, match=r"robot\.toml.*wheelbase 300 m.*millimetres"):
        load(file)
    file.write_text(body + "allow_unusual = true\n")
    assert float(load(file).wheel_positions[0, 0]) == 150.0
    metres = body.replace("300", "0.3").replace("250", "0.25").replace("50\n", "0.05\n")
    motors = "[dynamics]\nyaw_inertia = 4.0\nmotor = \"neo\"\ngearing = 8.0\nmass = "
    file.write_text(metres + motors + "50000.0\n")  # 50 t: a heavy-load platform, real
    assert load(file).dynamics is not None
    file.write_text(metres + motors + "500000.0\n")  # 500 kg in grams
    with pytest.raises(RobotError, match=r"dynamics: mass 500000 kg .*grams \(500 kg\)"):
        load(file)
    file.write_text(metres + "allow_unusual = true\n" + motors + "500000.0\n")
    robot = load(file)
    assert robot.dynamics is not None and robot.dynamics.mass == 500000.0


@pytest.mark.parametrize("value", ["yes", 1, None])
def test_allow_unusual_must_be_a_bool(value: object) -> None:
    with pytest.raises(RobotError, match="allow_unusual must be True or False"):
        mecanum(**MECANUM, allow_unusual=value)  # type: ignore[arg-type]
    with pytest.raises(RobotError, match="allow_unusual must be True or False"):
        from_dict({"type": "mecanum", **MECANUM, "allow_unusual": value})
    with pytest.raises(ControllerError, match="allow_unusual must be True or False"):
        Controller(preset("mecanum"), Circle(1.0, 12.0),
                   allow_unusual=value)  # type: ignore[arg-type]


def test_swedish_wheel_tables_are_checked_by_their_keys() -> None:
    wheel = {"alpha": 0.0, "beta": 0.0, "gamma": 0.0, "l": 0.2, "radius": 0.05,
             "max_speed": 20.0}
    wheels = [{**wheel, "alpha": a} for a in (0.0, 2.1, 4.2)]
    from_dict({"type": "swedish", "wheels": wheels})
    wheels[1] = {**wheels[1], "l": 200.0}
    with pytest.raises(RobotError, match=r"wheels\[1\]\.l 200 m is over 5 m.*millimetres"):
        from_dict({"type": "swedish", "wheels": wheels})
    from_dict({"type": "swedish", "wheels": wheels, "allow_unusual": True})


def test_a_copy_of_an_allowed_robot_is_not_checked_again() -> None:
    """derated() and with_dynamics() copy the robot: the override holds for the copy."""
    big = mecanum(**{**MECANUM, "wheelbase": 30.0}, allow_unusual=True)
    assert big.derated({0: 0.5}).max_wheel_speed[0] == 10.0
    heavy = dynamics(**{**MOTORS, "mass": 2e5}, allow_unusual=True)
    assert big.with_dynamics(heavy).dynamics is heavy


def test_wpilib_adapters_check_and_take_the_override() -> None:
    pytest.importorskip("wpimath")
    from mpc.adapters.wpilib import (
        robot_from_mecanum_kinematics,
        robot_from_swerve_kinematics,
    )

    millimetres = [(300.0, 250.0), (300.0, -250.0), (-300.0, 250.0), (-300.0, -250.0)]
    message = r"\[0\] 390.5\d* m from the body origin.*millimetres"
    with pytest.raises(RobotError, match=message):
        robot_from_mecanum_kinematics(millimetres, wheel_radius=0.05, max_wheel_speed=20.0)
    with pytest.raises(RobotError, match=message):
        robot_from_swerve_kinematics(millimetres, wheel_radius=0.05, max_wheel_speed=20.0,
                                     max_steer_rate=10.0)
    robot_from_mecanum_kinematics(millimetres, wheel_radius=0.05, max_wheel_speed=20.0,
                                  allow_unusual=True)
    robot_from_swerve_kinematics(millimetres, wheel_radius=0.05, max_wheel_speed=20.0,
                                 max_steer_rate=10.0, allow_unusual=True)


# Real robots pass ----------------------------------------------------------------------


@pytest.mark.parametrize("name", PRESETS)
def test_every_shipped_preset_is_within_every_range(name: str) -> None:
    assert isinstance(preset(name), Robot)


@pytest.mark.parametrize("name", MOTOR_ROBOT_PRESETS)
def test_every_shipped_motor_preset_is_within_every_range(name: str) -> None:
    assert motor_preset(name).dynamics is not None


def test_robots_at_the_edge_of_real_practice_pass() -> None:
    """A large AGV (4 m x 2.5 m, 0.25 m wheels at 1.5 m/s, 3 t), an FRC swerve (Kraken X60
    at 6.75:1, 4 in wheels, steering at 90 rad/s) and a TurtleBot-sized omni base."""
    agv = mecanum(wheelbase=4.0, track=2.5, wheel_radius=0.25, max_wheel_speed=6.0,
                  max_wheel_accel=8.0)
    agv.with_dynamics(dynamics(mass=3000.0, yaw_inertia=5000.0, motor="cim", motor_count=2,
                               gearing=40.0))
    swerve(module_positions=[[0.29, 0.29], [0.29, -0.29], [-0.29, 0.29], [-0.29, -0.29]],
           wheel_radius=0.0508, max_wheel_speed=628.3 / 6.75, max_steer_rate=90.0,
           max_wheel_accel=250.0)
    omni(n_wheels=3, base_radius=0.08, wheel_radius=0.02, max_wheel_speed=13.0)


def test_the_docstring_table_states_every_bound() -> None:
    table = plausibility.__doc__ or ""
    for limit in LIMITS:
        shown = ("2 pi 1e4" if limit is HEADING else
                 f"{limit.bound:,.0f}" if limit.bound >= 1e4 else f"{limit.bound:g}")
        assert re.search(rf"\s{re.escape(shown)} ", table), (limit.quantity, shown)


# Headings --------------------------------------------------------------------------------


def test_the_issue_s_heading_in_degrees_is_refused_at_the_first_tick() -> None:
    """step([x, y, 90], t): the issue's 90 degrees, which used to return SOLVED."""
    trajectory = Circle(1.0, 12.0, heading=math.pi / 2)
    controller = Controller(preset("mecanum"), trajectory)
    with pytest.raises(ControllerError, match=r"pose heading 90 rad .*degrees \(1\.571 rad\)"):
        controller.step([1.0, 0.0, 90.0], 0.0)
    allowed = Controller(preset("mecanum"), trajectory, allow_unusual=True)
    assert allowed.step([1.0, 0.0, 90.0], 0.0).status is Status.SOLVED


@pytest.mark.parametrize("degrees", [-90.0, 45.0, 180.0, 270.0, 359.0])
def test_headings_in_degrees_beyond_a_turn_are_refused_whatever_the_reference(
        degrees: float) -> None:
    for heading in (0.0, math.pi, -math.pi, 2 * math.pi):
        controller = Controller(preset("swerve"), Circle(1.0, 12.0, heading=heading))
        with pytest.raises(ControllerError, match="degrees"):
            controller.step([1.0, 0.0, degrees], 0.0)


def test_a_start_from_rest_is_checked_again_a_robot_in_motion_never() -> None:
    """reset() (at rest) and a new trajectory at rest check the next tick; a reset with a
    moving last_twist and a new trajectory while moving do not: never stop a moving
    robot."""
    controller = Controller(preset("mecanum"), Circle(1.0, 12.0))
    moving = controller.step([1.0, 0.0, 0.0], 0.0).twist
    assert np.any(moving)
    controller.reset()
    with pytest.raises(ControllerError, match="degrees"):
        controller.step([1.0, 0.0, 90.0], 0.0)
    controller.reset(moving)
    assert controller.step([1.0, 0.0, 90.0], 0.0).status is Status.SOLVED
    controller.trajectory = Circle(1.0, 12.0, heading=1.0)  # while moving
    assert controller.step([1.0, 0.0, 57.0], 0.05).status is Status.SOLVED
    controller.reset()
    controller.trajectory = Circle(1.0, 12.0, heading=1.0)  # at rest
    with pytest.raises(ControllerError, match="degrees"):
        controller.step([1.0, 0.0, 57.0], 0.0)


def test_multi_turn_headings_that_follow_the_reference_pass() -> None:
    """Spinning at 1 rad/s: at t = 30 s the reference's heading is 30 rad. A heading
    unwrapped alongside it (30.2 rad), or wrapped into (-pi, pi], is a radian heading."""
    trajectory = Circle(1.0, 12.0, heading=SpinHeading(1.0))
    pose = trajectory.sample(30.0).pose
    for heading in (pose[2] + 0.2, math.remainder(pose[2] + 0.2, 2 * math.pi)):
        controller = Controller(preset("swerve"), trajectory)
        command = controller.step([pose[0], pose[1], heading], 30.0)
        assert command.status is Status.SOLVED


def test_later_ticks_are_not_checked_against_the_reference() -> None:
    """Mid-run a wrapped odometry heading drifts whole turns from a spinning reference:
    the robot must not be stopped for it."""
    trajectory = Circle(1.0, 12.0, heading=SpinHeading(1.0))
    controller = Controller(preset("mecanum"), trajectory)
    controller.step(trajectory.sample(0.0).pose, 0.0)
    for k, t in enumerate(np.arange(1, 40) * 0.05):
        pose = trajectory.sample(t).pose + [0.0, 0.0, 2 * math.pi * (k % 5 - 2)]
        assert controller.step(pose, float(t)).status is Status.SOLVED


def test_wrapping_a_heading_changes_no_command() -> None:
    """Why the rule may ask for a wrapped heading: whole turns change nothing."""
    trajectory = Circle(1.0, 12.0, heading="tangent")
    pose = trajectory.sample(2.0).pose + [0.05, -0.03, 0.1]
    commands = []
    for turns in (0, 3, -7):
        controller = Controller(preset("mecanum"), trajectory, allow_unusual=True)
        commands.append(controller.step(pose + [0.0, 0.0, 2 * math.pi * turns], 2.0))
    for command in commands[1:]:
        np.testing.assert_allclose(command.wheel_speeds, commands[0].wheel_speeds,
                                   atol=1e-9)


def test_a_heading_beyond_ten_thousand_turns_is_refused_at_any_tick() -> None:
    trajectory = Circle(1.0, 12.0)
    controller = Controller(preset("mecanum"), trajectory)
    controller.step([1.0, 0.0, 0.0], 0.0)
    beyond = HEADING.bound * 1.001
    with pytest.raises(ControllerError, match=r"over 62831.9 rad \(10,000 turns\)"):
        controller.step([1.0, 0.0, beyond], 0.05)
    allowed = Controller(preset("mecanum"), trajectory, allow_unusual=True)
    assert allowed.step([1.0, 0.0, beyond], 0.0).status is Status.SOLVED


def test_simulate_refuses_an_initial_heading_in_degrees() -> None:
    trajectory = Circle(1.0, 12.0)
    with pytest.raises(SimulationError, match=r"initial_pose heading 90 rad.*degrees"):
        simulate(Controller(preset("omni3"), trajectory), 0.2, initial_pose=[1.0, 0.0, 90.0])
    result = simulate(Controller(preset("omni3"), trajectory, allow_unusual=True), 0.2,
                      initial_pose=[1.0, 0.0, 90.0])
    assert np.isfinite(result.pose).all()
