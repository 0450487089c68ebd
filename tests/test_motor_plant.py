"""The motor plant: settings, steady motion, battery sag by hand, slip, and closed loops."""

from __future__ import annotations

import numpy as np
import pytest

from mpc import Command, Controller, Status
from mpc.errors import SimulationError
from mpc.robots import motor_preset, preset
from mpc.robots.drive.force_map import force_map
from mpc.sim import MotorPlant, MotorPlantConfig, simulate
from mpc.sim.motor_plant import EVENT_KEYS
from trajectories import Circle, FigureEight

DT = 0.05


def command(twist: np.ndarray, speeds: np.ndarray, angles: np.ndarray | None = None,
            torques: np.ndarray | None = None) -> Command:
    return Command(wheel_speeds=speeds, twist=twist, steer_angles=angles,
                   predicted_poses=np.zeros((1, 3)), status=Status.SOLVED, solver_status="",
                   solve_time=0.0, tick_time=0.0, iterations=0, consecutive_failures=0,
                   clamped=False, reference_time=0.0, motor_torques=torques)


@pytest.mark.parametrize(("options", "message"), [
    ({"motor_lag": 0.02}, "motor_lag and slip must be 0"),
    ({"slip_speed": 0.0}, "slip_speed [m/s] must be a finite number > 0"),
    ({"slip_ratio": -1.0}, "slip_ratio must be a finite number >= 0"),
    ({"velocity_gain": float("inf")}, "velocity_gain must be a finite number >= 0"),
    ({"substeps": 0}, "substeps must be an integer >= 1"),
])
def test_bad_settings_are_one_line_errors(options: dict[str, object], message: str) -> None:
    with pytest.raises(SimulationError) as error:
        MotorPlantConfig(**options)  # type: ignore[arg-type]
    assert message in str(error.value) and "\n" not in str(error.value)


def test_the_motor_plant_needs_dynamics() -> None:
    with pytest.raises(SimulationError, match="needs a robot with dynamics"):
        MotorPlant(preset("mecanum"), DT, np.zeros(3), MotorPlantConfig(),
                   np.random.default_rng(0))
    controller = Controller(preset("mecanum"), Circle(1.0, 10.0))
    with pytest.raises(SimulationError, match="needs a robot with dynamics"):
        simulate(controller, 0.1, plant="motor")
    # the kinematic controller on the true robot with motors is fine
    result = simulate(controller, 0.2, plant="motor", robot=motor_preset("mecanum"))
    assert result.plant_events is not None and set(result.plant_events) == set(EVENT_KEYS)


def test_cruising_draws_the_free_current_and_sags_by_hand() -> None:
    """Driving straight at a steady speed the wheels need no torque (the model has no
    friction torque): zero current, no sag. Accelerating, the bus sags by R I_battery with
    I_battery = sum(V I) / V_bus."""
    robot = motor_preset("swerve")
    dyn = robot.dynamics
    assert dyn is not None
    forces = force_map(robot)
    plant = MotorPlant(robot, DT, np.zeros(3), MotorPlantConfig(slip_ratio=0.0),
                       np.random.default_rng(0))  # a rigid tread: no creep
    twist = np.array([2.0, 0.0, 0.0])
    plant.set_motion(twist)
    speeds, angles = robot.wheel_commands(twist, plant.steer_angles)
    for _ in range(5):
        plant.apply(command(twist, speeds, angles))
    events = plant.events()
    np.testing.assert_allclose(plant.twist, twist, atol=1e-6)
    assert events["bus_voltage"][-1] == pytest.approx(dyn.battery_voltage, abs=1e-6)
    assert not (events["voltage_violation"].any() or events["slip"].any())
    # accelerate at 3 m/s^2 with the force map's torques: each motor ~ m a r / 4 / gearing
    faster = twist + np.array([3.0 * DT, 0.0, 0.0])
    speeds, angles = robot.wheel_commands(faster, angles)
    torque = (dyn.mass * 3.0 * 0.05 / 4 + dyn.wheel_inertia * 3.0 / 0.05) / dyn.gearing
    plant.apply(command(faster, speeds, angles, np.full(4, torque)))
    current = torque * dyn.gearing / forces.kt  # per module, at the wheel's torque
    volts = (faster[0] / 0.05) / forces.kv + forces.resistance * current
    bus = plant.events()["bus_voltage"][-1]  # the lowest, at the tick's end (fastest)
    battery = 4 * volts * current / bus  # [A] the power the modules draw, through the bus
    assert dyn.battery_voltage - bus == pytest.approx(dyn.battery_resistance * battery,
                                                      rel=0.02)
    np.testing.assert_allclose(plant.twist, faster, atol=0.01)


def test_flooring_it_slips_and_breaks_the_limits() -> None:
    """A kinematic command far beyond traction: the wheels spin (slip events), the loops ask
    for more current than the limit; the same step through the clamp does neither."""
    robot = motor_preset("mecanum")
    plant = MotorPlant(robot, DT, np.zeros(3), MotorPlantConfig(), np.random.default_rng(0))
    target = np.array([1.5, 0.0, 0.0])  # 30 m/s^2 asked
    plant.apply(command(target, robot.wheel_speeds(target)))
    events = plant.events()
    assert events["slip"][0] == 1.0 and events["current_violation"][0] == 1.0
    assert events["peak_traction_ratio"][0] > 1.0 and events["peak_current_ratio"][0] > 1.0
    controller = Controller(robot, Circle(1.0, 10.0))
    from mpc.control.clamp import clamp_command

    safe, clamped = clamp_command(robot, target, np.zeros(3), DT)
    assert clamped and 0.0 < safe[0] < target[0]
    calm = MotorPlant(robot, DT, np.zeros(3), MotorPlantConfig(), np.random.default_rng(0))
    from mpc.robots.drive.motor_step import first_step_feedforward

    feed = first_step_feedforward(robot, np.zeros(3), safe, DT, None)
    assert feed is not None
    calm.apply(command(safe, robot.wheel_speeds(safe), torques=feed[1]))
    events = calm.events()
    assert events["slip"][0] == 0.0 and events["current_violation"][0] == 0.0
    del controller


def test_a_held_current_never_needs_more_than_the_bus() -> None:
    """A wheel loop asking for far more than a sagged bus while its wheel already spins
    near the bus's free speed: the voltage applied stays within the bus (a held current's
    voltage, back-EMF plus the limit's drop, would pass it), so the current is what the
    bus gives by hand, ``(V_bus - w / kv) / R``, below the limit."""
    robot = motor_preset("swerve")
    forces = force_map(robot)
    plant = MotorPlant(robot, DT, np.zeros(3), MotorPlantConfig(), np.random.default_rng(0))
    bus = 6.0
    spin = np.full(4, 0.9 * bus * forces.kv)  # [rad/s] wheels at 90 % of the bus's speed
    angles = np.zeros(4)
    twist, speeds, sub = plant._physics.step((np.zeros(3), spin), angles, np.full(4, 40.0),
                                              bus)
    assert np.all(np.abs(sub.voltage) <= bus * (1 + 1e-9))
    by_hand = (bus - speeds / forces.kv) / forces.resistance
    np.testing.assert_allclose(sub.current, by_hand, rtol=1e-6)
    assert sub.voltage_violation and np.all(np.isfinite(twist))


def test_the_bus_stays_up_under_commands_beyond_it() -> None:
    """The kinematic MPC on a figure-eight beyond the free speed asks for more than the bus
    on many ticks; the bus sags but never below what the current limits allow
    (``E - R n I_max``), and braking lifts it no further than that above the battery
    (before: it went negative and diverged)."""
    from benchmarks.motors import controller, free_speed_reference

    robot = motor_preset("swerve")
    dyn = robot.dynamics
    assert dyn is not None
    reference = free_speed_reference("figure8", robot, 1.2, 2.0)
    result = simulate(controller("mpc-kinematic", robot, reference, DT, 10), 1.6,
                      plant="motor", robot=robot)
    assert result.plant_events is not None
    bus = result.plant_events["bus_voltage"]
    drop = dyn.battery_resistance * 4 * dyn.current_limit  # [V]
    assert result.metrics()["voltage_violations"] > 0
    assert np.all(bus >= dyn.battery_voltage - drop - 1e-6)
    assert np.all(bus <= dyn.battery_voltage + drop + 1e-6)


@pytest.mark.parametrize("name", ["omni4", "swerve"])
def test_motor_aware_mpc_beats_kinematic_mpc_on_the_motor_plant(name: str) -> None:
    """A short closed loop at the traction limit: the motor-aware MPC has no voltage or
    current violation and tracks closer than the same MPC with kinematic limits."""
    from benchmarks.motors import controller, motor_reference

    robot = motor_preset(name)
    reference = motor_reference("figure8", robot)
    errors = {}
    for name_ in ("mpc-motors", "mpc-kinematic"):
        result = simulate(controller(name_, robot, reference, DT, 10), 4.0, plant="motor",
                          robot=robot)
        metrics = result.metrics(skip=1.0)
        errors[name_] = metrics["rms_position_error"]
        if name_ == "mpc-motors":
            assert metrics["voltage_violations"] == metrics["current_violations"] == 0
    assert errors["mpc-motors"] <= errors["mpc-kinematic"] * 1.05


def test_delay_holds_the_robot_at_rest_first() -> None:
    robot = motor_preset("omni3")
    config = MotorPlantConfig(delay_ticks=2)
    plant = MotorPlant(robot, DT, np.zeros(3), config, np.random.default_rng(0))
    twist = np.array([0.2, 0.0, 0.0])
    for _ in range(2):
        plant.apply(command(twist, robot.wheel_speeds(twist)))
    np.testing.assert_allclose(plant.twist, 0.0, atol=1e-12)
    plant.apply(command(twist, robot.wheel_speeds(twist)))
    assert plant.twist[0] > 0.0


def test_simulate_reports_the_plant_metrics() -> None:
    robot = motor_preset("ball3")
    result = simulate(Controller(robot, FigureEight(1.0, 8.0)), 1.0, plant="motor")
    metrics = result.metrics()
    for key in ("voltage_violations", "current_violations", "slip_events",
                "peak_voltage_ratio", "peak_current_ratio", "min_bus_voltage"):
        assert key in metrics
    assert metrics["voltage_violations"] == metrics["current_violations"] == 0
    assert 0.0 < metrics["min_bus_voltage"] <= 12.0
    assert "voltage_violations" not in simulate(Controller(preset("ball3"), FigureEight(
        1.0, 8.0)), 0.2).metrics()
