"""Robot dynamics descriptions: Python and TOML, hand-derived motor values, presets, Choreo."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mpc.errors import RobotError
from mpc.robots import (
    MOTOR_ROBOT_PRESETS,
    DCMotor,
    RobotDynamics,
    SwedishRobot,
    SwedishWheel,
    choreo_dynamics,
    dynamics,
    from_dict,
    load,
    motor_preset,
    preset,
)
from mpc.robots.drive.dynamics import HEADROOM, bus_voltage
from mpc.robots.drive.force_map import force_map

RPM = math.pi / 30.0


def kraken(**overrides: object) -> RobotDynamics:
    settings: dict[str, object] = {"mass": 50.0, "yaw_inertia": 4.0, "motor": "kraken_x60",
                                   "gearing": 6.75, "current_limit": 60.0, "friction": 1.1}
    settings.update(overrides)
    return dynamics(**settings)  # type: ignore[arg-type]


def test_wheel_side_values_by_hand() -> None:
    dyn = kraken()
    # WPILib's Kraken X60: 6000 rpm free, 7.09 N m and 366 A stall, 2 A free, at 12 V
    assert dyn.motor == DCMotor.preset("kraken_x60")
    assert dyn.free_speed == pytest.approx(6000 * RPM / 6.75, rel=1e-12)
    kt = 7.09 / 366.0  # [N m/A]
    assert dyn.max_wheel_torque == pytest.approx(kt * 60.0 * 6.75, rel=1e-12)
    # without a current limit: stall torque at the battery voltage
    assert kraken(current_limit=None).max_wheel_torque == pytest.approx(7.09 * 6.75, rel=1e-12)
    # two motors per wheel double the torque at the same current limit per motor
    assert kraken(motor_count=2).max_wheel_torque == pytest.approx(2 * kt * 60 * 6.75)


def test_motor_as_a_table_and_steering() -> None:
    table = {"nominal_voltage": 12.0, "stall_torque": 0.9, "stall_current": 5.5,
             "free_current": 0.25, "free_speed": 50.0}
    dyn = kraken(motor=table, gearing=1.0, steer_motor="neo_550", steer_gearing=20.0)
    assert dyn.motor == DCMotor(12.0, 0.9, 5.5, 0.25, 50.0)
    assert dyn.free_speed == pytest.approx(50.0)
    assert dyn.max_steer_rate == pytest.approx(11000 * RPM / 20.0)
    assert kraken().max_steer_rate is None


@pytest.mark.parametrize(("overrides", "message"), [
    ({"mass": -1.0}, "mass [kg] must be a finite number > 0"),
    ({"gearing": 0.0}, "gearing"),
    ({"motor": "kraken"}, "motor must be one of"),
    ({"motor": {"stall_torque": 1.0}}, "missing key(s)"),
    ({"motor": 3}, "motor must be a DCMotor"),
    ({"headroom": 0.5}, "headroom must be a fraction in [0, 0.5)"),
    ({"voltage_headroom": -0.1}, "voltage_headroom must be a finite number >= 0"),
    ({"voltage_headroom": 0.6}, "voltage_headroom must be a fraction in [0, 0.5)"),
    ({"current_limit": 0.0}, "current_limit [A] must be a finite number > 0"),
    ({"friction": float("nan")}, "friction must be a finite number > 0"),
    ({"battery_resistance": -0.1}, "battery_resistance [ohm]"),
    ({"steer_motor": "neo"}, "steer_motor and steer_gearing go together"),
    ({"motor_count": 0}, "motor_count must be an integer >= 1"),
])
def test_bad_descriptions_name_the_input(overrides: dict[str, object], message: str) -> None:
    with pytest.raises(RobotError) as error:
        kraken(**overrides)
    assert message in str(error.value)
    assert "\n" not in str(error.value)


def test_toml_dynamics_table(tmp_path: Path) -> None:
    file = tmp_path / "robot.toml"
    file.write_text("""
type = "mecanum"
wheelbase = 0.3
track = 0.25
wheel_radius = 0.05
max_wheel_speed = 70.0

[dynamics]
mass = 15.0
yaw_inertia = 0.25
motor = "neo_550"
gearing = 16.0
current_limit = 8.0
friction = 0.7
battery_resistance = 0.02
voltage_headroom = 0.1
""")
    robot = load(file)
    assert robot.dynamics == dynamics(mass=15.0, yaw_inertia=0.25, motor="neo_550",
                                      gearing=16.0, current_limit=8.0, friction=0.7,
                                      battery_resistance=0.02, voltage_headroom=0.1)
    assert robot.dynamics is not None and robot.dynamics.headroom == HEADROOM
    assert robot.with_dynamics(None).dynamics is None
    described = {"type": "omni", "n_wheels": 3, "base_radius": 0.2, "wheel_radius": 0.05,
                 "max_wheel_speed": 10.0, "dynamics": {"mass": 5.0, "yaw_inertia": 0.1,
                                                       "motor": "neo", "gear": 10.0}}
    with pytest.raises(RobotError, match=r"robot description: dynamics: unknown key\(s\) "
                                         r"\['gear'\], missing key\(s\) \['gearing'\]"):
        from_dict(described)


def test_motor_presets_share_the_layouts_and_run_at_free_speed() -> None:
    for name in MOTOR_ROBOT_PRESETS:
        robot, kinematic = motor_preset(name), preset(name)
        assert robot.dynamics is not None and robot.kind == kinematic.kind
        np.testing.assert_allclose(robot.wheel_positions, kinematic.wheel_positions)
        np.testing.assert_allclose(robot.max_wheel_speed, robot.dynamics.free_speed,
                                   rtol=1e-12)
        assert robot.max_wheel_accel is None  # the motor rows bound acceleration
    with pytest.raises(RobotError, match="no motor preset 'caster4'"):
        motor_preset("caster4")


def test_with_dynamics_checks_its_argument_and_the_loads() -> None:
    robot = preset("omni3")
    with pytest.raises(RobotError, match="dynamics must be a RobotDynamics or None"):
        robot.with_dynamics("heavy")  # type: ignore[arg-type]
    # three wheels all in front of the body origin cannot carry a centre of mass there
    lopsided = SwedishRobot(tuple(SwedishWheel(alpha=a, beta=math.pi, gamma=0.0, l=0.2,
                                               radius=0.05, max_speed=10.0)
                                  for a in (-0.6, 0.0, 0.6)))
    with pytest.raises(RobotError, match="cannot carry the weight"):
        lopsided.with_dynamics(kraken())
    # a derated copy keeps the dynamics; the failed wheel takes no share of the effort
    derated = robot.with_dynamics(kraken(mass=5.0, yaw_inertia=0.1)).derated({0: 0.0})
    assert derated.dynamics is not None
    np.testing.assert_allclose(force_map(derated).effort_map[0], 0.0, atol=1e-12)


def test_choreo_config_becomes_the_motor_model() -> None:
    config = SimpleNamespace(mass=60.0, inertia=6.0, gearing=6.5, radius=0.048, vmax=600.0,
                             tmax=1.2, cof=1.5)
    dyn = choreo_dynamics(config)  # type: ignore[arg-type]
    # Choreo's box: free speed vmax / gearing at the wheel, torque limit tmax * gearing
    assert dyn.free_speed == pytest.approx(600.0 / 6.5, rel=1e-12)
    assert dyn.max_wheel_torque == pytest.approx(1.2 * 6.5, rel=1e-12)
    assert (dyn.mass, dyn.yaw_inertia, dyn.friction, dyn.gearing) == (60.0, 6.0, 1.5, 6.5)
    with pytest.raises(RobotError, match="beyond"):
        choreo_dynamics(SimpleNamespace(**{**vars(config), "tmax": 100.0}))  # type: ignore[arg-type]


def test_bus_voltage_solves_the_battery_by_hand() -> None:
    # V^2 - E V + R P = 0: E = 12 V, R = 0.02 ohm, P = 1000 W -> V = (12 + sqrt(64)) / 2 = 10
    assert bus_voltage(12.0, 0.02, 1000.0) == pytest.approx(10.0, rel=1e-12)
    assert bus_voltage(12.0, 0.02, -50.0) == 12.0  # regeneration is not planned on
    assert bus_voltage(12.0, 0.02, 5000.0) == 6.0  # beyond the battery's most power
    assert bus_voltage(12.0, 0.0, 1000.0) == 12.0


def test_a_choreo_file_gives_a_robot_with_motors() -> None:
    """The shipped minimal Choreo file: its robot with the motor model of its config drives
    its own trajectory on the motor plant within the motor limits."""
    from mpc import Controller
    from mpc.sim import simulate
    from trajectories import read_choreo

    reference = read_choreo(Path(__file__).parent / "data" / "minimal.traj")
    robot = reference.robot.with_dynamics(choreo_dynamics(reference.config))
    assert robot.dynamics is not None
    np.testing.assert_allclose(robot.max_wheel_speed, robot.dynamics.free_speed, rtol=1e-12)
    result = simulate(Controller(robot, reference, dt=0.02),
                      float(reference.end_time or 1.0) + 0.2, plant="motor")
    metrics = result.metrics()
    assert metrics["voltage_violations"] == metrics["current_violations"] == 0
