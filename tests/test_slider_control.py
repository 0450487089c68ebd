"""The slider robot driven: its type (preset, description, registry), its joint rows against
the kinematics, the plant against the kinematics, and both solvers in closed loop on the
independent plant against the reactive baseline (a figure-eight and a square with
reversals, each turning faster than the units can steer)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from benchmarks.slider import (
    SliderCase,
    figure_eight,
    peak_turn_rate,
    run_case,
    square_with_reversals,
)
from mpc.control.slider import SliderController
from mpc.errors import ControllerError, RobotError
from mpc.robots import SliderRobot, from_dict, preset, robot_mobility, robot_types, slider
from mpc.robots.wheels.slider.limits import nlp_stage_limits, stage_limits, update_stage_limits
from mpc.robots.wheels.slider.rows import joint_parameters, middle_angles, stage_durations
from mpc.sim.slider_plant import SliderPlant
from mpc.sim.slider_run import SliderRun, run_slider
from trajectories import Circle

SLACK = 1e-9  # relative: a commanded rate at its limit reads this far over it at most


def _swom() -> SliderRobot:
    robot = preset("swom")
    assert isinstance(robot, SliderRobot)
    return robot


def test_the_type_registers_and_describes_itself() -> None:
    robot = _swom()
    assert "slider" in robot_types()
    assert robot.kind == "slider" and robot.n_wheels == 4
    assert robot.wheel_names == ("FL", "FR", "RL", "RR")
    again = from_dict(robot.description())
    assert again.description() == robot.description()
    assert tuple(robot_mobility(robot)) == (3, 0)  # free sliders: no sliding constraint
    with pytest.raises(RobotError, match="stroke"):
        slider(rail_angles=[0.0, math.pi], stroke=[0.3, 0.2], wheel_radius=0.05,
               max_wheel_speed=20.0, max_steer_rate=3.0, max_slider_speed=0.4)
    with pytest.raises(RobotError, match="max_slider_speed"):
        slider(rail_angles=[0.0, math.pi], stroke=[0.1, 0.2], wheel_radius=0.05,
               max_wheel_speed=20.0, max_steer_rate=3.0, max_slider_speed=-1.0)


def test_joint_rows_match_the_units_kinematics() -> None:
    robot = _swom()
    rng = np.random.default_rng(7)
    for _ in range(50):
        angles = rng.uniform(-1.4, 1.4, size=4)
        positions = rng.uniform(0.15, 0.35, size=4)
        twist = rng.uniform(-0.5, 0.5, size=3)
        drive, slide = robot.slider_rows(angles, positions)
        for i, unit in enumerate(robot.units):
            phidot, ldot = unit.joint_rates(twist, float(angles[i]), float(positions[i]))
            assert drive[i] @ twist == pytest.approx(phidot, abs=1e-12)
            assert slide[i] @ twist == pytest.approx(ldot, abs=1e-12)


def test_plant_moves_the_body_by_consistent_joint_rates_without_slip() -> None:
    robot = _swom()
    angles = np.array([0.3, -0.2, 1.0, 0.1])
    twist = np.array([0.2, -0.1, 0.3])
    plant = SliderPlant(robot, steer_angles=angles, substeps=1)
    rates = [unit.joint_rates(twist, float(b), float(where)) for unit, b, where in
             zip(robot.units, angles, plant.slider_positions, strict=True)]
    drive = np.array([rate[0] for rate in rates])
    slide = np.array([rate[1] for rate in rates])
    assert plant.body_twist(drive, slide, angles, plant.slider_positions) == pytest.approx(
        twist, abs=1e-12)
    assert plant.peak_slip < 1e-12
    # a short step: the joints barely move, so the twist is about the one the rates made
    plant.step(drive, np.zeros(4), slide, 1e-5)
    assert plant.twist == pytest.approx(twist, abs=1e-5)
    assert plant.stroke_violations == 0


def test_plant_stops_a_slider_at_its_stroke_and_reports_it() -> None:
    robot = _swom()
    plant = SliderPlant(robot, slider_positions=[0.34, 0.25, 0.25, 0.25])
    plant.step(np.zeros(4), np.zeros(4), np.array([0.4, 0.0, 0.0, 0.0]), 0.1)
    assert plant.slider_positions[0] == pytest.approx(0.35)
    assert plant.stroke_violations == 1
    assert plant.overtravel == pytest.approx(0.03, abs=1e-3)
    plant.step(np.zeros(4), np.array([9.0, 0.0, 0.0, 0.0]), np.zeros(4), 0.1)
    assert plant.rate_violations == 1
    assert plant.steer_angles[0] == pytest.approx(0.3)  # run at its 3 rad/s limit


def test_fast_path_rows_equal_the_nlp_rows_along_the_same_plan() -> None:
    """The QP's rows at the positions predicted along a plan, against the NLP's symbolic
    positions integrated along the same plan (the plan keeps off the stroke's stops)."""
    robot = _swom()
    horizon = 6
    change_times = np.full(horizon, 0.05)
    rng = np.random.default_rng(3)
    twists = rng.uniform(-0.15, 0.15, size=(horizon, 3))
    angles = rng.uniform(-0.5, 0.5, size=4)
    positions = np.full(4, 0.25)
    ends, where = robot.steer_schedule(angles, positions, twists, stage_durations(change_times))
    joints = joint_parameters(angles, positions, ends)
    limits = stage_limits(robot, change_times)
    update_stage_limits(robot, limits, twists, joints)
    symbols = ca.SX.sym("u", 3, horizon)
    parameters = ca.SX.sym("p", joints.size)
    values, _, _ = nlp_stage_limits(robot, symbols, parameters, change_times)
    function = ca.Function("g", [symbols, parameters], [ca.vertcat(*values)])
    exact = np.asarray(function(twists.T, joints)).ravel().reshape(horizon, 3, 4)
    fast = np.einsum("kmj,kj->km", limits.now, twists)
    assert fast[:, :4] == pytest.approx(exact[:, 0], abs=1e-12)  # drive
    assert fast[:, 4:] == pytest.approx(exact[:, 1], abs=1e-12)  # slider rate
    assert where[1:] == pytest.approx(exact[:, 2], abs=1e-12)  # positions at stage ends
    assert bool((np.abs(np.diff(ends, axis=0)) <= 0.05 * robot.max_steer_rates + 1e-12).all())


def test_mid_angles_keep_off_the_rail_line() -> None:
    ends = np.array([[0.5 * math.pi - 0.001], [0.5 * math.pi + 0.001]])
    middle = middle_angles(ends)
    assert abs(math.cos(float(middle[0, 0]))) == pytest.approx(0.01)


def test_controller_needs_the_joint_states() -> None:
    robot = _swom()
    control = SliderController(robot, Circle(0.5, 8.0), 5, 0.05)
    with pytest.raises(ControllerError, match="joint states"):
        control.step([0.5, 0.0, 0.0], 0.0)
    with pytest.raises(ControllerError, match="stroke"):
        control.step([0.5, 0.0, 0.0], 0.0, steer_angles=np.zeros(4),
                     slider_positions=[0.5, 0.25, 0.25, 0.25])
    with pytest.raises(ControllerError, match="slider robots"):
        SliderController(preset("swerve"), Circle(0.5, 8.0))  # type: ignore[arg-type]


def _within_every_limit(run: SliderRun) -> None:
    assert run.rate_violations == 0
    assert run.stroke_violations == 0
    assert bool((run.peak_ratios <= 1.0 + SLACK).all())
    positions = run.slider_positions
    assert positions.min() >= 0.15 - 1e-12 and positions.max() <= 0.35 + 1e-12


@pytest.mark.parametrize(("case", "solver", "horizon"), [
    (figure_eight(1.0), "mpc-daqp", 20),
    (square_with_reversals(), "mpc-daqp", 20),
    (figure_eight(1.0), "mpc-ipopt", 10),
    (square_with_reversals(), "mpc-ipopt", 10),
])
def test_both_solvers_beat_the_reactive_baseline_within_every_limit(
        case: SliderCase, solver: str, horizon: int) -> None:
    robot = _swom()
    # each case asks for turns faster than the units steer
    assert peak_turn_rate(case.trajectory, case.duration) > robot.max_steer_rates.max()
    mpc = run_case(case, solver, robot, horizon)
    reactive = run_case(case, "reactive", robot)
    _within_every_limit(mpc)
    _within_every_limit(reactive)
    assert mpc.failures == 0
    assert mpc.rms_error < 0.5 * reactive.rms_error


def test_a_slider_started_at_its_end_is_steered_back_inside() -> None:
    """Every slider starts 2 mm from an end, on a circle that pushes each one outward in
    turn: the MPC keeps each inside (no stop met) and tracks."""
    robot = _swom()
    trajectory = Circle(0.4, 4.0)
    control = SliderController(robot, trajectory, 20, 0.05)
    start = trajectory.sample(0.0)
    plant = SliderPlant(robot, start.pose, slider_positions=[0.348, 0.152, 0.348, 0.152])
    run = run_slider(control, 4.0, plant)
    _within_every_limit(run)
    assert run.failures == 0
    assert run.rms_error < 0.02


def test_generic_entry_points_drive_the_slider_robot() -> None:
    """``Controller``, ``FeedforwardPController`` and ``simulate`` take a slider robot as any
    other (what ``mpc-bench --layouts swom`` runs): the slider's controller, baseline and
    plant, through the registries."""
    from mpc import Controller
    from mpc.sim import FeedforwardPController, simulate
    from mpc.sim.slider_baseline import ReactiveSliderController

    robot = _swom()
    case = square_with_reversals(edges=2)
    control = Controller(robot, case.trajectory, 10, 0.05)
    assert isinstance(control, SliderController)
    baseline = FeedforwardPController(robot, case.trajectory, 0.05, saturation="clip")
    assert isinstance(baseline, ReactiveSliderController)
    ours = simulate(control, case.duration).metrics()
    theirs = simulate(baseline, case.duration).metrics()
    assert ours["limit_violations"] == 0 and ours["steer_violations"] == 0
    assert ours["failures"] == 0
    assert ours["rms_position_error"] < theirs["rms_position_error"]


def test_desaturating_baseline_keeps_every_limit() -> None:
    from mpc.sim.slider_baseline import ReactiveSliderController

    robot = _swom()
    case = square_with_reversals(edges=4)
    run = run_slider(ReactiveSliderController(robot, case.trajectory, 0.05,
                                              saturation="desaturate"), case.duration)
    _within_every_limit(run)


def test_mpc_bench_slider_prints_its_table(capsys: pytest.CaptureFixture[str]) -> None:
    from benchmarks.cli import main

    assert main(["slider", "--cases", "square-reversals", "--controllers",
                 "mpc-daqp,reactive", "--horizon", "10"]) == 0
    out = capsys.readouterr().out
    assert "square-reversals mpc-daqp" in out and "square-reversals reactive" in out
    assert main(["slider", "--cases", "circle"]) == 2  # an unknown case: one line, exit 2
