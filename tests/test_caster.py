"""Powered offset casters: kinematics against hand values and finite differences, limits in
both solver paths and the clamp, closed loops in the plant (which integrates the steer
angles from the commanded rates and moves the robot by the least-squares joint map)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mpc import Controller
from mpc.control.clamp import clamp_command
from mpc.errors import ControllerError, RobotError
from mpc.robots import CasterRobot, caster, from_dict, load, preset, robot_mobility
from mpc.sim import FeedforwardPController, TrackingController, simulate
from trajectories import Circle, FigureEight, OutAndBack, Trajectory, feasibility

#: The worked example of the wheel notes: P = (0.24, 0.19), d = 0.045, r = 0.088, beta = 0.
WORKED = [((0.0, 0.3, 0.0), 0.0, 6.667), ((1.0, 0.0, 0.0), 11.364, 0.0),
          ((0.0, 0.0, 1.0), -2.159, 4.333)]


def worked_robot() -> CasterRobot:
    return caster(positions=[(0.24, 0.19), (-0.24, -0.19)], offset=0.045, wheel_radius=0.088,
                  max_wheel_speed=15.0, max_steer_rate=8.0)


@pytest.mark.parametrize(("twist", "drive", "steer"), WORKED)
def test_worked_table(twist: tuple[float, float, float], drive: float, steer: float) -> None:
    drive_rates, steer_rates = worked_robot().joint_rates(twist, [0.0, 0.0])
    assert drive_rates[0] == pytest.approx(drive, abs=5e-4)
    assert steer_rates[0] == pytest.approx(steer, abs=5e-4)


def test_contact_point_has_no_lateral_slip_by_finite_differences() -> None:
    """Integrate the pose and the steer angle over a small step; the contact point's motion
    over the ground is along the wheel (no sideways slip) and ``r phidot`` long."""
    robot = worked_robot()
    rng = np.random.default_rng(11)
    h = 1e-6
    for _ in range(20):
        twist, beta = rng.normal(size=3), rng.uniform(-math.pi, math.pi, size=2)
        drive, steer = robot.joint_rates(twist, beta)
        for i in range(2):
            p, d = robot.wheel_positions[i], robot.offsets[i]

            def contact(t: float, i: int = i, p: np.ndarray = p, d: float = d,
                        twist: np.ndarray = twist, beta: np.ndarray = beta,
                        steer: np.ndarray = steer) -> np.ndarray:
                theta = twist[2] * t  # the body's pose to first order is enough at h
                c, s = math.cos(theta), math.sin(theta)
                body = np.array([[c, -s], [s, c]])
                angle = beta[i] + steer[i] * t
                local = p - d * np.array([math.cos(angle), math.sin(angle)])
                return np.asarray(twist[:2] * t + body @ local)

            velocity = (contact(h) - contact(-h)) / (2 * h)
            e = np.array([math.cos(beta[i]), math.sin(beta[i])])
            n = np.array([-e[1], e[0]])
            assert velocity @ n == pytest.approx(0.0, abs=1e-6)
            assert velocity @ e == pytest.approx(robot.radii[i] * drive[i], abs=1e-6)


def test_round_trips_and_least_squares() -> None:
    robot = preset("caster4")
    assert isinstance(robot, CasterRobot)
    rng = np.random.default_rng(3)
    for _ in range(30):
        twist, beta = rng.normal(size=3), rng.uniform(-4, 4, size=4)
        drive, steer = robot.joint_rates(twist, beta)
        np.testing.assert_allclose(robot.twist(drive, steer, beta), twist, atol=1e-12)
    # inconsistent joint rates: the least-squares twist, i.e. the normal equations hold
    drive, steer, beta = rng.normal(size=4), rng.normal(size=4), rng.normal(size=4)
    twist = robot.twist(drive, steer, beta)
    d_rows, s_rows = robot.joint_rows(beta)
    e = np.stack([np.cos(beta), np.sin(beta)], 1)
    n = np.stack([-e[:, 1], e[:, 0]], 1)
    contact = robot.wheel_positions - robot.offsets[:, None] * e
    rows = np.concatenate([[[1, 0, -c[1]], [0, 1, c[0]]] for c in contact])
    wanted = (robot.radii * drive)[:, None] * e + (robot.offsets * steer)[:, None] * n
    residual = rows @ twist - wanted.ravel()
    np.testing.assert_allclose(rows.T @ residual, 0.0, atol=1e-12)
    assert d_rows.shape == s_rows.shape == (4, 3)


def test_predicted_angles_follow_the_rigid_motion() -> None:
    """The RK4 flow of betadot matches a fine Euler integration of the same ODE (measured up
    to 2.4e-3 rad after three stages: RK4 steps of up to 2.5 caster time constants, see
    ``caster_limits.substeps``, traded for the NLP's size)."""
    robot = preset("caster4")
    rng = np.random.default_rng(5)
    beta0, twists = rng.uniform(-3, 3, size=4), rng.normal(size=(3, 3)) * 0.5
    durations = np.array([0.05, 0.1, 0.1])
    predicted = robot.predict_steer_angles(beta0, twists, durations)
    beta = beta0.copy()
    for k, twist in enumerate(twists):
        for _ in range(20000):
            beta = beta + durations[k] / 20000 * (robot.joint_rows(beta)[1] @ twist)
        np.testing.assert_allclose(predicted[k + 1], beta, atol=5e-3)


def test_validation() -> None:
    with pytest.raises(RobotError, match="n >= 2 casters"):
        caster(positions=[(0, 0)], offset=0.05, wheel_radius=0.1, max_wheel_speed=1,
               max_steer_rate=1)
    with pytest.raises(RobotError, match="distinct contact points"):
        caster(positions=[(0, 0), (0.05, 0)], offset=0.03, wheel_radius=0.1,
               max_wheel_speed=1, max_steer_rate=1)
    with pytest.raises(RobotError, match="offset must be finite numbers > 0"):
        caster(positions=[(0, 0), (1, 0)], offset=[0.05, -1], wheel_radius=0.1,
               max_wheel_speed=1, max_steer_rate=1)
    with pytest.raises(RobotError, match="steer_angles must have shape"):
        worked_robot().joint_rates((0, 0, 0), [0.0])


def test_controller_needs_measured_angles() -> None:
    robot, reference = preset("caster4"), Circle(1.0, 12.0)
    controller = Controller(robot, reference)
    with pytest.raises(ControllerError, match="needs the measured steer angles"):
        controller.step(reference.sample(0.0).pose, 0.0)
    with pytest.raises(ControllerError, match="shape"):
        controller.step(reference.sample(0.0).pose, 0.0, steer_angles=[0.0, 0.0])
    with pytest.raises(ControllerError, match="finite"):
        controller.step(reference.sample(0.0).pose, 0.0, steer_angles=[0, 0, 0, math.nan])
    with pytest.raises(ControllerError, match="casters"):
        Controller(preset("swerve"), reference).step(reference.sample(0.0).pose, 0.0,
                                                   steer_angles=np.zeros(4))


def test_clamp_keeps_every_joint_within_its_limits_at_the_measured_angles() -> None:
    robot = preset("caster4")
    rng = np.random.default_rng(8)
    limit = robot.max_steer_rates
    assert limit is not None
    for _ in range(300):
        beta = rng.uniform(-math.pi, math.pi, size=4)
        last, target = rng.normal(size=3) * 0.3, rng.normal(size=3) * 2.0
        result, _ = clamp_command(robot, target, last, 0.05, beta)
        drive, steer = robot.joint_rates(result, beta)
        assert np.all(np.abs(drive) <= robot.max_wheel_speed * (1 + 1e-9))
        assert np.all(np.abs(steer) <= limit * (1 + 1e-9))


def test_qp_rows_at_the_measured_angles_are_exact_in_stage_zero() -> None:
    robot = preset("caster4")
    limits = robot.stage_limits(np.array([0.05, 0.05, 0.1]), 16)
    beta = np.array([0.3, -1.0, 2.0, 3.0])
    robot.update_stage_limits(limits, np.ones((3, 3)) * 0.2, np.zeros(3), beta)
    drive, steer = robot.joint_rows(beta)
    np.testing.assert_allclose(limits.now[0, :4], drive)
    np.testing.assert_allclose(limits.now[0, 4:8], steer)


def caster_reference(make: type[Circle] | type[FigureEight], heading: float | str,
                     ratio: float) -> Trajectory:
    robot = preset("caster4")

    def shape(period: float) -> Trajectory:
        return make(1.0, period, heading=heading)

    return shape(10.0 * feasibility(shape(10.0), robot).peak_ratio / ratio)


@pytest.mark.parametrize("heading", [0.0, "tangent"])
@pytest.mark.parametrize("shape", [Circle, FigureEight])
def test_tracks_inside_the_limits(shape: type[Circle] | type[FigureEight],
                                  heading: float | str) -> None:
    """Peak drive rate 0.8 x the limit, casters trailing the first direction of travel;
    measured 0.2-1.1 mm RMS after 2 s (the plant holds joint rates over a tick while the
    angles turn: a model mismatch the Swedish layouts do not have)."""
    robot = preset("caster4")
    reference = caster_reference(shape, heading, 0.8)
    result = simulate(Controller(robot, reference), 8.0)
    metrics = result.metrics(skip=2.0)
    assert metrics["rms_position_error"] < 2e-3
    assert metrics["limit_violations"] == 0 and metrics["steer_violations"] == 0
    assert metrics["max_steer_rate_ratio"] <= 1.0 + 1e-6


def test_exact_path_tracks_within_the_limits() -> None:
    robot = preset("caster4")
    reference = caster_reference(Circle, 0.0, 0.8)
    result = simulate(Controller(robot, reference, solver="ipopt"), 3.0)
    metrics = result.metrics(skip=2.0)
    assert metrics["rms_position_error"] < 2e-3
    assert metrics["limit_violations"] == 0 and metrics["steer_violations"] == 0
    assert metrics["failures"] == 0


@pytest.mark.parametrize("scenario", ["circle", "figure8", "out-and-back"])
def test_beyond_the_limits_mpc_beats_both_baselines(scenario: str) -> None:
    """At 1.3 x the drive limit (circle, figure-eight) and on a flat out-and-back where
    every caster swings round at each end (0.2 m between the ways out and back), the MPC
    has the lower RMS error, and never a drive or steer rate beyond its limit. Measured
    (mm, MPC / clip / scale): circle 238 / 414 / 398, figure-eight 51 / 84 / 84,
    out-and-back 78 / 124 / 132."""
    robot = preset("caster4")
    if scenario == "out-and-back":
        def shape(period: float) -> Trajectory:
            return OutAndBack(2.0, period, width=0.2)
        reference = shape(10.0 * feasibility(shape(10.0), robot).peak_ratio / 1.3)
    else:
        reference = caster_reference(Circle if scenario == "circle" else FigureEight, 0.0, 1.3)
    duration = reference.period + 2.0 if reference.period else 8.0
    errors = {}
    controllers: list[tuple[str, TrackingController]] = [
        ("mpc", Controller(robot, reference)),
        ("clip", FeedforwardPController(robot, reference, saturation="clip")),
        ("scale", FeedforwardPController(robot, reference))]
    for name, controller in controllers:
        result = simulate(controller, duration)
        metrics = result.metrics(skip=2.0)
        errors[name] = metrics["rms_position_error"]
        assert metrics["limit_violations"] == 0 and metrics["steer_violations"] == 0
        if name == "mpc" and scenario == "out-and-back":  # the swing is at the steer limit
            assert metrics["max_steer_rate_ratio"] == pytest.approx(1.0, abs=1e-6)
    assert errors["mpc"] < 0.8 * min(errors["clip"], errors["scale"])


def test_robot_files_and_mobility(tmp_path: Path) -> None:
    robot = preset("caster4")
    assert robot_mobility(robot) == (3, 0)
    assert robot_mobility(preset("mpo700")) == (1, 2)
    path = tmp_path / "car.toml"
    path.write_text('type = "wheels"\nwheel_radius = 0.1\nmax_wheel_speed = 10.0\n'
                    'max_steer_rate = 5.0\n'
                    'wheels = [{type = "fixed", x = -0.5, y = 0.3, heading = 0.0},\n'
                    '          {type = "fixed", x = -0.5, y = -0.3, heading = 0.0},\n'
                    '          {type = "steered", x = 0.5, y = 0.0}]\n')
    with pytest.raises(RobotError) as error:
        load(path)
    message = str(error.value)
    assert "\n" not in message and "(1, 1)" in message
    assert "degree of mobility" in message and "degree of steerability" in message
    built = from_dict({"type": "wheels", "wheel_radius": 0.088, "max_wheel_speed": 15.0,
                       "max_steer_rate": 8.0,
                       "wheels": [{"type": "caster", "x": x, "y": y, "offset": 0.045}
                                  for x, y in robot.wheel_positions]})
    assert isinstance(built, CasterRobot)
    np.testing.assert_allclose(built.wheel_blocks, robot.wheel_blocks)


def test_axle_offset_drive_correction_and_solvers_agree() -> None:
    """MPO-700 style: the wheel rolls ``L (omega + betadot) / r`` more than a centred one;
    forward kinematics while steering inverts it; daqp tracks like IPOPT."""
    robot = preset("mpo700")
    twist = np.array([0.3, 0.1, 0.5])
    speeds, commanded = robot.wheel_commands(twist, np.zeros(4))
    assert commanded is not None
    angles: np.ndarray = commanded
    velocity = robot.wheel_blocks @ twist
    lever = 0.045 * 0.5 / 0.09
    np.testing.assert_allclose(np.abs(speeds - lever), np.hypot(velocity[:, 0], velocity[:, 1]))
    np.testing.assert_allclose(robot.forward_kinematics(speeds, angles), twist, atol=1e-12)
    turning = np.array([1.0, -2.0, 0.5, 0.0])
    steered = speeds + 0.045 * turning / 0.09
    np.testing.assert_allclose(robot.steering_forward_kinematics(steered, angles, turning),
                               twist, atol=1e-12)
    reference = FigureEight(1.0, 16.0, heading="tangent")
    start = reference.sample(0.0).pose + np.array([0.2, 0.0, 0.3])
    results = {solver: simulate(Controller(robot, reference, solver=solver), 4.0,
                                initial_pose=start) for solver in ("daqp", "ipopt")}
    for result in results.values():
        metrics = result.metrics(skip=2.0)
        assert metrics["limit_violations"] == 0 and metrics["steer_violations"] == 0
        assert metrics["rms_position_error"] < 3e-4
    late = results["daqp"].time >= 2.0
    gap = np.abs(results["daqp"].pose[late] - results["ipopt"].pose[late]).max()
    assert gap < 1e-3


def test_the_angle_prediction_survives_copies_and_threads() -> None:
    """The prediction keeps CasADi buffers per thread: a robot that was used still pickles
    and copies, and threads predicting at once get each their own answer."""
    import copy
    import pickle
    import threading

    robot = preset("caster4")
    assert isinstance(robot, CasterRobot)
    durations = np.full(6, 0.05)
    rng = np.random.default_rng(5)
    cases = [(rng.uniform(-3.0, 3.0, robot.n_wheels), rng.normal(0.0, 0.5, (6, 3)))
             for _ in range(8)]
    expected = [robot.predict_steer_angles(a, u, durations) for a, u in cases]
    for twin in (pickle.loads(pickle.dumps(robot)), copy.deepcopy(robot)):
        for (angles, twists), want in zip(cases, expected, strict=True):
            np.testing.assert_array_equal(twin.predict_steer_angles(angles, twists, durations),
                                          want)
    mismatches: list[int] = []

    def work(offset: int) -> None:
        for round_ in range(50):
            k = (offset + round_) % len(cases)
            got = robot.predict_steer_angles(*cases[k], durations)
            if not np.array_equal(got, expected[k]):
                mismatches.append(k)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not mismatches


def test_the_angle_predictions_are_built_at_set_up_not_on_the_first_tick() -> None:
    """Building a prediction takes tens of milliseconds: the controller builds the three it
    uses (the limits' grid, one tick in two halves, the plan's stages) when it is made."""
    robot = preset("caster4")
    assert isinstance(robot, CasterRobot)
    control = Controller(robot, Circle(1.0, 20.0), horizon=6, dt=0.05)
    grids = {key[1] for key in robot._cache if isinstance(key, tuple) and key[0] == "predictor"}
    durations = tuple(float(h) for h in control.model.durations)
    limits = tuple(float(h) for h in control.model.change_times[1:])
    assert {(0.025, 0.025), durations, limits} <= grids


def test_command_predicts_the_steer_angles_along_its_plan() -> None:
    """A caster Command's predicted steer angles start at the measured ones and follow its
    own plan's twists over the model's stages (the prediction itself is checked against
    the rigid motion above); a solved tick's first stage is the twist it commands."""
    robot = preset("caster4")
    reference = Circle(1.0, 12.0)
    control = Controller(robot, reference, horizon=8, dt=0.05)
    measured = np.array([0.3, -0.2, 0.1, 0.4])
    given = measured.copy()
    command = control.step(reference.sample(0.0).pose, 0.0, steer_angles=given)
    plan = control._warm._plan
    assert plan is not None and command.status.value == "solved"
    expected = robot.predict_steer_angles(measured, plan[1].copy(), control.model.durations)
    # computed when read (not in the tick), from this tick's angles and plan: the ones the
    # controller holds move on with the next tick, and the caller's array may be reused
    given[:] = 0.0
    control.step(reference.sample(0.05).pose, 0.05, steer_angles=measured + 0.01)
    predicted = command.predicted_steer_angles
    assert predicted is not None and predicted.shape == (9, 4)
    np.testing.assert_array_equal(predicted[0], measured)
    assert command.predicted_steer_angles is predicted  # computed once
    np.testing.assert_allclose(predicted, expected, rtol=0, atol=1e-12)
    assert not np.allclose(predicted[-1], measured)  # the casters turn along the plan
