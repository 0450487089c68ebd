"""The simulated robot: hand answers for ideal kinematics, and each fault's effect."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpc import Command, Controller, Status
from mpc.errors import MpcError
from mpc.robots import PRESETS, Robot, SwerveRobot, preset
from mpc.sim import PLANT_PRESETS, Plant, PlantConfig, simulate
from trajectories import Circle

DT = 0.05


def command(robot: Robot, twist: np.ndarray | list[float],
            steer_from: np.ndarray | None = None) -> Command:
    """An open-loop command for ``twist`` (what a controller would send)."""
    twist = np.asarray(twist, dtype=float)
    speeds, steer = robot.wheel_commands(
        twist, robot.initial_steer_angles() if steer_from is None else steer_from)
    return Command(wheel_speeds=speeds, twist=twist, steer_angles=steer,
                   predicted_poses=np.zeros((1, 3)), status=Status.SOLVED, solver_status="",
                   solve_time=0.0, tick_time=0.0, iterations=0, consecutive_failures=0,
                   clamped=False, reference_time=0.0)


def drive(robot: Robot, twist: list[float], seconds: float, start: np.ndarray | None = None,
          config: PlantConfig | None = None, seed: int = 0) -> Plant:
    """Apply one constant command for ``seconds``; return the plant."""
    plant = Plant(robot, DT, np.zeros(3) if start is None else start,
                  config or PlantConfig(), np.random.default_rng(seed))
    for _ in range(round(seconds / DT)):
        plant.apply(command(robot, twist))
    return plant


# Ideal kinematics: hand answers -------------------------------------------------------


@pytest.mark.parametrize("robot_name", PRESETS)
@pytest.mark.parametrize("heading", [0.0, 0.7, -2.5])
def test_constant_forward_twist_moves_speed_times_time_along_the_heading(
    robot_name: str, heading: float
) -> None:
    plant = drive(preset(robot_name), [0.4, 0.0, 0.0], 1.0, start=np.array([1.0, -2.0, heading]),
                  config=PlantConfig(steer_rate_limited=False))
    expected = [1.0 + 0.4 * math.cos(heading), -2.0 + 0.4 * math.sin(heading), heading]
    np.testing.assert_allclose(plant.pose, expected, atol=1e-12)


@pytest.mark.parametrize("robot_name", PRESETS)
def test_pure_rotation_turns_in_place(robot_name: str) -> None:
    plant = drive(preset(robot_name), [0.0, 0.0, -1.2], 1.0, start=np.array([0.5, 0.5, 0.3]),
                  config=PlantConfig(steer_rate_limited=False))
    np.testing.assert_allclose(plant.pose, [0.5, 0.5, 0.3 - 1.2], atol=1e-12)


@pytest.mark.parametrize("robot_name", ["omni3", "mecanum"])
def test_forward_and_turning_follows_the_circular_arc(robot_name: str) -> None:
    """(v, 0, w) from heading h traces p(t) = p0 + (v/w)(sin(h + w t) - sin h,
    cos h - cos(h + w t)); RK4 at 10 substeps is exact to ~1e-10 here."""
    v, w, h = 0.5, 0.8, 0.3
    plant = drive(preset(robot_name), [v, 0.0, w], 2.0, start=np.array([0.0, 0.0, h]))
    end = h + 2.0 * w
    expected = [v / w * (math.sin(end) - math.sin(h)), v / w * (math.cos(h) - math.cos(end)), end]
    np.testing.assert_allclose(plant.pose, expected, atol=1e-9)


def test_ideal_plant_reaches_the_commanded_wheel_speeds_and_measures_the_true_pose() -> None:
    robot = preset("mecanum")
    plant = Plant(robot, DT, np.array([1.0, 2.0, 3.0]), PlantConfig(), np.random.default_rng(0))
    sent = command(robot, [0.3, -0.2, 0.5])
    np.testing.assert_allclose(plant.apply(sent), sent.wheel_speeds, atol=1e-12)
    np.testing.assert_array_equal(plant.measure(), plant.pose)


# Each fault, open loop with a hand answer -----------------------------------------------


def test_motor_lag_reaches_the_first_order_step_response() -> None:
    """After one tick of a step command the wheels are at (1 - exp(-dt / lag)) of it."""
    robot, lag = preset("omni4"), 0.08
    plant = Plant(robot, DT, np.zeros(3), PlantConfig(motor_lag=lag), np.random.default_rng(0))
    sent = command(robot, [0.5, 0.2, 0.0])
    reached = [plant.apply(sent) for _ in range(3)]
    for ticks, speeds in enumerate(reached, start=1):
        np.testing.assert_allclose(
            speeds, (1.0 - math.exp(-ticks * DT / lag)) * sent.wheel_speeds, rtol=1e-12)
    ideal = drive(robot, [0.5, 0.2, 0.0], 3 * DT)
    assert np.linalg.norm(plant.pose[:2]) < 0.6 * np.linalg.norm(ideal.pose[:2])


def test_delay_holds_the_robot_for_the_delayed_ticks() -> None:
    robot = preset("omni3")
    plant = Plant(robot, DT, np.zeros(3), PlantConfig(delay_ticks=2), np.random.default_rng(0))
    sent = command(robot, [0.5, 0.0, 0.0])
    for _ in range(2):
        np.testing.assert_array_equal(plant.apply(sent), np.zeros(robot.n_wheels))
        np.testing.assert_array_equal(plant.pose, np.zeros(3))
    plant.apply(sent)
    np.testing.assert_allclose(plant.pose, [0.5 * DT, 0.0, 0.0], atol=1e-14)


def test_measurement_noise_has_the_configured_spread() -> None:
    config = PlantConfig(position_noise=0.01, heading_noise=0.03)
    plant = Plant(preset("mecanum"), DT, np.array([1.0, -1.0, 0.5]), config,
                  np.random.default_rng(123))
    errors = np.array([plant.measure() - plant.pose for _ in range(4000)])
    # 4000 samples: the sample std is within ~2.2% (1 sigma) of the true one.
    np.testing.assert_allclose(errors.std(axis=0), [0.01, 0.01, 0.03], rtol=0.08)
    assert np.all(np.abs(errors.mean(axis=0)) < [0.001, 0.001, 0.003])  # ~6 sigma
    np.testing.assert_array_equal(plant.pose, [1.0, -1.0, 0.5])  # the truth is untouched


@pytest.mark.parametrize("robot_name", PRESETS)
def test_slip_makes_an_open_loop_robot_fall_short(robot_name: str) -> None:
    """Each wheel loses a uniform [0, 0.4] fraction (mean 0.2) of its speed: 2 s at
    0.5 m/s cover about 0.8 m instead of 1 m (measured 0.788-0.811 over seeds)."""
    robot = preset(robot_name)
    ideal = drive(robot, [0.5, 0.0, 0.0], 2.0)
    slipping = drive(robot, [0.5, 0.0, 0.0], 2.0, config=PlantConfig(slip=0.2), seed=4)
    assert ideal.pose[0] == pytest.approx(1.0, abs=1e-12)
    assert 0.75 < slipping.pose[0] < 0.85


def test_rate_limited_steering_turns_modules_at_the_steer_rate() -> None:
    """A swerve robot at rest (modules at 0 rad) asked to strafe left (modules to +90 deg):
    a snapping plant strafes at once, a rate-limited one turns 12 rad/s * 0.05 s = 0.6 rad
    in the first tick and so makes less leftward progress."""
    robot = preset("swerve")
    assert isinstance(robot, SwerveRobot)
    strafe = [0.0, 0.5, 0.0]
    snap = drive(robot, strafe, DT, config=PlantConfig(steer_rate_limited=False))
    slow = drive(robot, strafe, DT, config=PlantConfig(steer_rate_limited=True))
    assert snap.steer_angles is not None and slow.steer_angles is not None
    np.testing.assert_allclose(snap.steer_angles, math.pi / 2, atol=1e-12)
    np.testing.assert_allclose(slow.steer_angles, robot.max_steer_rate * DT, atol=1e-12)
    np.testing.assert_allclose(snap.pose, [0.0, 0.5 * DT, 0.0], atol=1e-14)
    assert slow.pose[1] < 0.5 * snap.pose[1]
    # Once turned (after pi/2 / 12 rad/s = 0.13 s), both strafe at the same speed.
    late_snap = drive(robot, strafe, 0.5, config=PlantConfig(steer_rate_limited=False))
    late_slow = drive(robot, strafe, 0.5, config=PlantConfig(steer_rate_limited=True))
    assert late_slow.steer_angles is not None
    np.testing.assert_allclose(late_slow.steer_angles, math.pi / 2, atol=1e-12)
    assert late_slow.pose[1] < late_snap.pose[1]
    assert late_snap.pose[1] - late_slow.pose[1] < 0.5 * 0.15


# Each fault, closed loop: worse tracking than the ideal plant -----------------------------


@pytest.fixture(scope="module")
def closed_loop_rms() -> dict[str, float]:
    """RMS position error after 2 s of the OSQP controller on a mecanum circle, per plant.
    Measured: ideal ~5e-6 m, motor lag 0.05 s ~1.9e-3 m, 1 tick delay ~1.9e-3 m."""
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    start = trajectory.sample(0.0).pose + np.array([0.2, 0.0, 0.3])
    plants = {"ideal": PlantConfig(), "lag": PlantConfig(motor_lag=0.05),
              "delay": PlantConfig(delay_ticks=1), "realistic": PLANT_PRESETS["realistic"]}
    out = {}
    for name, config in plants.items():
        result = simulate(Controller(robot, trajectory), 6.0, initial_pose=start, plant=config,
                          seed=1)
        out[name] = result.metrics(skip=2.0)["rms_position_error"]
        if name == "realistic":
            noise = (result.measured - result.pose)[:, :2]
            assert noise.std() == pytest.approx(0.002, rel=0.15)
    return out


@pytest.mark.parametrize("fault", ["lag", "delay", "realistic"])
def test_each_fault_makes_tracking_worse_than_the_ideal_plant(
    closed_loop_rms: dict[str, float], fault: str
) -> None:
    assert closed_loop_rms["ideal"] < 1e-4
    assert closed_loop_rms[fault] > 10 * closed_loop_rms["ideal"]
    assert closed_loop_rms[fault] < 2e-2  # still tracking


# Validation --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"substeps": 0}, "substeps must be an integer >= 1"),
        ({"substeps": 2.5}, "substeps must be an integer >= 1"),
        ({"delay_ticks": -1}, "delay_ticks must be an integer >= 0"),
        ({"delay_ticks": 1.0}, "delay_ticks must be an integer >= 0"),
        ({"motor_lag": -0.01}, "motor_lag must be a finite number >= 0"),
        ({"motor_lag": math.inf}, "motor_lag must be a finite number >= 0"),
        ({"position_noise": math.nan}, "position_noise must be a finite number >= 0"),
        ({"heading_noise": -1.0}, "heading_noise must be a finite number >= 0"),
        ({"heading_noise": "0.1"}, "heading_noise must be a finite number >= 0"),
        ({"slip": -0.1}, "slip must be a finite number >= 0"),
        ({"slip": 0.5}, "slip must be < 0.5"),
    ],
)
def test_invalid_plant_config_raises(options: dict[str, object], message: str) -> None:
    with pytest.raises(MpcError, match=message):
        PlantConfig(**options)  # type: ignore[arg-type]
