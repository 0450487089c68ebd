"""Closed-loop simulation and its metrics, on synthetic logs with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import ArrayLike

from mpc import Command, Controller, Status
from mpc.errors import MpcError
from mpc.robots import Robot, preset
from mpc.sim import Plant, PlantConfig, Recorder, SimResult, simulate
from trajectories import Circle, Trajectory

DT = 0.05
TICKS = 120  # 6 s
ROBOT = preset("mecanum")  # 4 wheels, 20 rad/s, 40 rad/s^2
CIRCLE = Circle(1.0, 12.0, heading=0.0)


def synthetic(trajectory: Trajectory = CIRCLE, pose: np.ndarray | None = None,
              **fields: object) -> SimResult:
    """A log of TICKS ticks on ``trajectory``: by default on the reference, at rest,
    every tick solved in 1 ms."""
    time = DT * np.arange(TICKS)
    reference = trajectory.sample(time).pose
    pose = reference.copy() if pose is None else pose
    n = ROBOT.n_wheels
    values: dict[str, object] = {
        "time": time, "pose": pose, "measured": pose.copy(), "reference": reference,
        "wheel_command": np.zeros((TICKS, n)), "wheel_actual": np.zeros((TICKS, n)),
        "wheel_limit": ROBOT.max_wheel_speed.copy(), "wheel_accel_limit": ROBOT.max_wheel_accel,
        "twist_command": np.zeros((TICKS, 3)), "status": ("solved",) * TICKS,
        "tick_time": np.full(TICKS, 1e-3), "solve_time": np.full(TICKS, 5e-4),
        "iterations": np.full(TICKS, 10.0), "dt": DT, "trajectory": trajectory,
        "wheel_blocks": ROBOT.wheel_blocks,
    }
    values.update(fields)
    return SimResult(**values)  # type: ignore[arg-type]


def radial_offset(trajectory: Circle, distance: float) -> np.ndarray:
    """Poses ``distance`` outside the circle, radially, at the reference's times."""
    reference = trajectory.sample(DT * np.arange(TICKS)).pose
    pose = reference.copy()
    pose[:, :2] *= (trajectory.radius + distance) / trajectory.radius
    return pose


# Tracking errors --------------------------------------------------------------------------


def test_constant_offset_gives_equal_rms_and_max() -> None:
    result = synthetic(pose=radial_offset(CIRCLE, 0.003))
    metrics = result.metrics()
    assert metrics["rms_position_error"] == pytest.approx(0.003, abs=1e-12)
    assert metrics["max_position_error"] == pytest.approx(0.003, abs=1e-12)
    # Radially outward is also the distance to the path (polyline chord error ~1e-6 m).
    assert metrics["rms_cross_track_error"] == pytest.approx(0.003, abs=1e-5)
    assert metrics["max_cross_track_error"] == pytest.approx(0.003, abs=1e-5)
    assert metrics["rms_heading_error"] == 0.0


def test_on_the_path_but_late_has_no_cross_track_error() -> None:
    """Half a second late on a 12 s circle: 0.26 m behind (the chord), 0 m off the path."""
    late = CIRCLE.sample(DT * np.arange(TICKS) - 0.5).pose
    metrics = synthetic(pose=late).metrics()
    chord = 2.0 * math.sin(0.5 * (2 * math.pi / 12.0) / 2)
    assert metrics["rms_position_error"] == pytest.approx(chord, rel=1e-9)
    assert metrics["max_cross_track_error"] < 2e-6


@pytest.mark.parametrize(
    ("reference_heading", "robot_heading", "error"),
    [
        (math.pi - 0.01, -math.pi + 0.01, 0.02),  # across +-pi
        (0.3, 0.35 + 6 * math.pi, 0.05),  # three turns apart
        (-0.2, -0.2 - 4 * math.pi - 0.03, 0.03),
    ],
)
def test_heading_error_is_wrapped(reference_heading: float, robot_heading: float,
                                  error: float) -> None:
    trajectory = Circle(1.0, 12.0, heading=reference_heading)
    pose = trajectory.sample(DT * np.arange(TICKS)).pose
    pose[:, 2] = robot_heading
    metrics = synthetic(trajectory, pose=pose).metrics()
    assert metrics["rms_heading_error"] == pytest.approx(error, abs=1e-9)
    assert metrics["max_heading_error"] == pytest.approx(error, abs=1e-9)
    assert metrics["rms_position_error"] == 0.0


def test_skip_excludes_the_first_seconds_from_tracking_errors() -> None:
    pose = radial_offset(CIRCLE, 0.003)
    pose[:20, :2] = radial_offset(CIRCLE, 0.1)[:20, :2]  # first second 0.1 m off
    result = synthetic(pose=pose)
    assert result.metrics()["max_position_error"] == pytest.approx(0.1, abs=1e-12)
    skipped = result.metrics(skip=1.0)
    assert skipped["rms_position_error"] == pytest.approx(0.003, abs=1e-12)
    assert skipped["max_position_error"] == pytest.approx(0.003, abs=1e-12)
    assert skipped["max_cross_track_error"] == pytest.approx(0.003, abs=1e-5)
    assert result.metrics(skip=0.95)["max_position_error"] == pytest.approx(0.1, abs=1e-12)


@pytest.mark.parametrize("skip", [TICKS * DT, 100.0])
def test_skip_leaving_no_ticks_raises(skip: float) -> None:
    with pytest.raises(MpcError, match="leaves no ticks"):
        synthetic().metrics(skip=skip)


# Wheel limits -------------------------------------------------------------------------------


def test_one_command_over_the_limit_is_one_violation() -> None:
    command = np.full((TICKS, ROBOT.n_wheels), 0.5 * 20.0)
    command[37, 2] = -1.1 * 20.0  # the magnitude counts
    result = synthetic(wheel_command=command)
    assert result.metrics()["limit_violations"] == 1
    assert result.metrics()["max_wheel_speed_ratio"] == pytest.approx(1.1, rel=1e-12)
    # Violations count every tick; the peak ratio, like the errors, only those after skip.
    windowed = result.metrics(skip=3.0)
    assert windowed["limit_violations"] == 1
    assert windowed["max_wheel_speed_ratio"] == pytest.approx(0.5, rel=1e-12)


def test_commands_at_the_limit_within_its_tolerance_are_not_violations() -> None:
    command = np.full((TICKS, ROBOT.n_wheels), 20.0 * (1 + 1e-7))  # LIMIT_RTOL is 1e-6
    metrics = synthetic(wheel_command=command).metrics()
    assert metrics["limit_violations"] == 0
    assert metrics["max_wheel_speed_ratio"] == pytest.approx(1.0, abs=1e-6)
    assert metrics["control_effort"] == pytest.approx(1.0, abs=1e-6)


def test_control_effort_is_the_rms_of_command_over_limit() -> None:
    command = np.zeros((TICKS, ROBOT.n_wheels))
    command[:, 0] = 10.0  # half the limit on one wheel of four
    metrics = synthetic(wheel_command=command).metrics()
    assert metrics["control_effort"] == pytest.approx(math.sqrt(0.25 / 4), rel=1e-12)


def test_acceleration_violations_count_ticks_with_too_big_a_change() -> None:
    """Mecanum: 40 rad/s^2 * 0.05 s = 2 rad/s per tick = 0.1 m/s forward. A 0.2 m/s spike
    on one tick breaks the limit going up and coming down: 2 violations."""
    twists = np.tile([0.05, 0.0, 0.0], (TICKS, 1))  # 1 rad/s up from rest on tick 0: fine
    twists[20, 0] = 0.25
    assert synthetic(twist_command=twists).metrics()["accel_violations"] == 2
    assert synthetic(twist_command=twists, wheel_accel_limit=None).metrics()[
        "accel_violations"] == 0
    twists[20, 0] = 0.149  # 1.98 rad/s: within the limit
    assert synthetic(twist_command=twists).metrics()["accel_violations"] == 0


# Timing and statuses ---------------------------------------------------------------------------


def test_deadline_misses_and_tick_time_percentiles() -> None:
    ticks = np.full(TICKS, 1e-3)
    ticks[[10, 50]] = [0.06, 0.2]  # two ticks longer than dt = 0.05
    ticks[60] = 0.05  # exactly dt is not a miss
    metrics = synthetic(tick_time=ticks).metrics()
    assert metrics["deadline_misses"] == 2
    assert metrics["tick_time_p50"] == pytest.approx(1e-3)
    assert metrics["tick_time_max"] == pytest.approx(0.2)
    assert metrics["solve_time_p50"] == pytest.approx(5e-4)


def test_failures_are_counted_by_status() -> None:
    status = ["solved"] * TICKS
    status[5:7] = ["previous_plan", "previous_plan"]
    status[40] = "feedforward"
    metrics = synthetic(status=tuple(status)).metrics()
    assert metrics["failures"] == 3
    assert metrics["failures_by_status"] == {"previous_plan": 2, "feedforward": 1}
    assert synthetic().metrics()["failures_by_status"] == {}


def test_duration_is_ticks_times_dt() -> None:
    assert synthetic().duration == pytest.approx(TICKS * DT)


# simulate() ----------------------------------------------------------------------------------


class ConstantTwist:
    """A stand-in controller (the TrackingController protocol) that always sends one twist."""

    def __init__(self, robot: Robot, trajectory: Trajectory, twist: list[float]) -> None:
        self.robot, self.dt, self._trajectory = robot, DT, trajectory
        self.twist = np.asarray(twist, dtype=float)
        self.resets = 0
        self.seen: list[tuple[np.ndarray, float]] = []

    @property
    def trajectory(self) -> Trajectory:
        return self._trajectory

    def reset(self) -> None:
        self.resets += 1

    def step(self, pose: ArrayLike, t: float) -> Command:
        self.seen.append((np.array(pose, dtype=float), t))
        return Command(wheel_speeds=self.robot.wheel_speeds(self.twist), twist=self.twist,
                       steer_angles=None, predicted_poses=np.zeros((1, 3)),
                       status=Status.FEEDFORWARD, solver_status="stub", solve_time=1e-4,
                       tick_time=2e-4, iterations=3, consecutive_failures=1, clamped=False,
                       reference_time=t)


def test_simulate_records_the_loop() -> None:
    """A constant forward twist from the given start: the log holds the hand answer."""
    stub = ConstantTwist(ROBOT, CIRCLE, [0.4, 0.0, 0.0])
    start = np.array([1.0, 0.5, math.pi / 2])
    result = simulate(stub, 1.0, initial_pose=start)
    assert stub.resets == 1
    np.testing.assert_allclose(result.time, DT * np.arange(20), atol=1e-15)
    expected = start + np.outer(0.4 * result.time, [0.0, 1.0, 0.0])
    np.testing.assert_allclose(result.pose, expected, atol=1e-12)
    np.testing.assert_array_equal(result.measured, result.pose)
    np.testing.assert_allclose(result.reference, CIRCLE.sample(result.time).pose)
    np.testing.assert_allclose(result.wheel_command, np.tile(ROBOT.wheel_speeds(stub.twist),
                                                             (20, 1)))
    np.testing.assert_allclose(result.wheel_actual, result.wheel_command, atol=1e-12)
    assert result.status == ("feedforward",) * 20
    assert [t for _, t in stub.seen] == pytest.approx(list(result.time))
    metrics = result.metrics()
    assert metrics["failures_by_status"] == {"feedforward": 20}


def test_simulate_defaults_to_the_reference_start_and_noise_is_seeded() -> None:
    stub = ConstantTwist(ROBOT, CIRCLE, [0.0, 0.0, 0.0])
    result = simulate(stub, 0.5)
    np.testing.assert_allclose(result.pose, np.tile(CIRCLE.sample(0.0).pose, (10, 1)))
    noisy = [simulate(stub, 0.5, plant="realistic", seed=s).measured for s in (3, 3, 4)]
    np.testing.assert_array_equal(noisy[0], noisy[1])
    assert not np.array_equal(noisy[0], noisy[2])


@pytest.mark.parametrize("duration", [0.0, -1.0, math.nan, math.inf, "5"])
def test_simulate_rejects_bad_durations(duration: object) -> None:
    stub = ConstantTwist(ROBOT, CIRCLE, [0.0, 0.0, 0.0])
    with pytest.raises(MpcError, match="duration must be a finite number of seconds > 0"):
        simulate(stub, duration)  # type: ignore[arg-type]
    assert stub.resets == 0


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"initial_pose": [0.0, 0.0]}, r"initial_pose must have shape \(3,\)"),
        ({"initial_pose": [0.0, math.nan, 0.0]}, "initial_pose must be finite"),
        ({"plant": "bumpy"}, "plant must be a PlantConfig or one of"),
    ],
)
def test_simulate_rejects_bad_options(options: dict[str, object], message: str) -> None:
    stub = ConstantTwist(ROBOT, CIRCLE, [0.0, 0.0, 0.0])
    with pytest.raises(MpcError, match=message):
        simulate(stub, 1.0, **options)  # type: ignore[arg-type]


def test_simulate_with_a_real_controller_matches_its_metrics() -> None:
    """The real loop: a short OSQP run, metrics consistent with the logged arrays."""
    controller = Controller(ROBOT, CIRCLE, horizon=10)
    result = simulate(controller, 2.0)
    metrics = result.metrics()
    errors = np.linalg.norm(result.pose[:, :2] - result.reference[:, :2], axis=1)
    assert metrics["max_position_error"] == pytest.approx(errors.max(), rel=1e-12)
    assert metrics["max_wheel_speed_ratio"] == pytest.approx(
        float((np.abs(result.wheel_command) / ROBOT.max_wheel_speed).max()), rel=1e-12)
    assert metrics["failures"] == sum(status != "solved" for status in result.status)


def test_a_loop_of_your_own_records_the_same_result_as_simulate() -> None:
    """The Recorder in a hand-written loop (what a user with a real robot writes) gives the
    SimResult that simulate() gives for the same controller and plant."""
    controller = Controller(ROBOT, CIRCLE, horizon=10)
    expected = simulate(controller, 1.5, plant="realistic", seed=4)
    controller.reset()
    plant = Plant(ROBOT, DT, CIRCLE.sample(0.0).pose, PlantConfig(
        motor_lag=0.03, delay_ticks=1, position_noise=0.002, heading_noise=0.005, slip=0.03),
        np.random.default_rng(4))
    recorder = Recorder(ROBOT, CIRCLE, DT)
    for k in range(30):
        pose, measured = plant.pose, plant.measure()
        command = controller.step(measured, k * DT)
        recorder.record(k * DT, pose, command, measured, plant.apply(command))
    mine = recorder.result()
    assert len(recorder) == 30
    for name in ("time", "pose", "measured", "reference", "wheel_command", "wheel_actual",
                 "twist_command"):
        np.testing.assert_allclose(getattr(mine, name), getattr(expected, name), atol=1e-12)
    assert mine.status == expected.status
    assert mine.metrics()["rms_position_error"] == pytest.approx(
        expected.metrics()["rms_position_error"], rel=1e-9)


def test_recorder_rejects_bad_ticks_and_empty_results() -> None:
    recorder = Recorder(ROBOT, CIRCLE, DT)
    with pytest.raises(MpcError, match="nothing recorded"):
        recorder.result()
    stub = ConstantTwist(ROBOT, CIRCLE, [0.0, 0.0, 0.0])
    command = stub.step(np.zeros(3), 0.0)
    with pytest.raises(MpcError, match="pose must be finite"):
        recorder.record(0.0, [0.0, math.nan, 0.0], command)
    with pytest.raises(MpcError, match="t must be a finite time"):
        recorder.record(math.inf, np.zeros(3), command)
    with pytest.raises(MpcError, match=r"wheel_actual must have shape \(4,\)"):
        recorder.record(0.0, np.zeros(3), command, wheel_actual=[1.0])


def test_lap_times_from_the_tracked_reference_time() -> None:
    """A robot that lags the clock more and more (tracking 0.8x the reference's pace)
    completes a 12 s lap every 15 s; lag and the tracked reference follow."""
    time = DT * np.arange(TICKS * 6)  # 36 s
    lag = 0.2 * time
    tracked = CIRCLE.sample(time - lag).pose
    result = synthetic(time=time, pose=tracked, measured=tracked, reference=tracked,
                       wheel_command=np.zeros((time.size, ROBOT.n_wheels)),
                       wheel_actual=np.zeros((time.size, ROBOT.n_wheels)),
                       twist_command=np.zeros((time.size, 3)), status=("solved",) * time.size,
                       tick_time=np.full(time.size, 1e-3), solve_time=np.full(time.size, 5e-4),
                       iterations=np.full(time.size, 1.0), lag=lag)
    np.testing.assert_allclose(result.reference_time, 0.8 * time)
    np.testing.assert_allclose(result.lap_times(), [15.0], atol=1e-9)  # passes at 15 and 30 s
    metrics = result.metrics(skip=1.0)
    assert metrics["lap_time"] == pytest.approx(15.0, abs=1e-9)
    assert metrics["max_lag"] == pytest.approx(0.2 * time[-1])
    assert metrics["rms_position_error"] == 0.0
    assert synthetic().metrics()["lap_time"] is None  # 6 s of a 12 s circle: no whole lap
