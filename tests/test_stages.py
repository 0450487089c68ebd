"""The plan's time grid: stage 0 is one control tick, the others ``stage_dt``.

Independent answers: the stage starts written out by hand, the twist integral
(checked against RK4 in test_model.py) stepped stage by stage, limits counted
by hand, and a plan moved on by one tick worked out on paper.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from closed_loop import DT, Loop, too_fast_circle

from mpc import Controller, ControllerError
from mpc.model import TickInput, TrackingModel, Weights
from mpc.model.grid import shift_maps
from mpc.model.se2 import integrate
from mpc.robots import preset
from mpc.robots.limits import outermost
from mpc.solvers import SolveResult
from trajectories import Circle, FigureEight

HORIZON = 6
STAGE = 0.1


def make_model(robot_name: str = "mecanum", path: bool = False) -> TrackingModel:
    return TrackingModel(preset(robot_name), HORIZON, STAGE, Weights(), path=path, tick=DT)


def test_grid_by_hand() -> None:
    model = make_model()
    np.testing.assert_allclose(model.durations, [0.05, 0.1, 0.1, 0.1, 0.1, 0.1])
    np.testing.assert_allclose(model.offsets, [0.0, 0.05, 0.15, 0.25, 0.35, 0.45, 0.55])
    # u_0 follows the last command by one tick, u_1 follows u_0 by stage 0 (one tick too).
    np.testing.assert_allclose(model.change_times, [0.05, 0.05, 0.1, 0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="tick"):
        TrackingModel(preset("mecanum"), HORIZON, STAGE, Weights(), tick=0.2)


def test_rollout_steps_each_stage_for_its_own_duration() -> None:
    model = make_model()
    rng = np.random.default_rng(3)
    start = np.array([0.3, -0.2, 0.4])
    twists = rng.uniform(-1.0, 1.0, size=(HORIZON, 3))
    poses, _ = model.rollout(start, twists.T)
    expected = [start]
    for twist, duration in zip(twists, model.durations, strict=True):
        expected.append(integrate(expected[-1], twist, float(duration)))
    np.testing.assert_allclose(np.asarray(poses).T, expected, rtol=0, atol=1e-12)


def test_feedforward_drives_each_stage_exactly_over_its_duration() -> None:
    model = make_model()
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    sample = trajectory.sample(1.3 + model.offsets)
    feedforward, _ = model.reference_terms(sample.pose.T, sample.velocity.T)
    for k in range(HORIZON):
        reached = integrate(sample.pose[k], np.asarray(feedforward)[:, k],
                            float(model.durations[k]))
        np.testing.assert_allclose(reached, sample.pose[k + 1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("robot_name", ["mecanum", "swerve"])
def test_acceleration_limits_allow_each_change_its_own_time(robot_name: str) -> None:
    """The QP rows: a change of twist into stage k may move a wheel by max_wheel_accel
    times change_times[k] (scaled like the speed rows); the NLP: the same, exactly."""
    model = make_model(robot_name)
    robot = model.robot
    assert robot.max_wheel_accel is not None
    limits = robot.stage_limits(model.change_times, 16)
    speed_rows = outermost(robot.qp_speed_rows(16), robot.max_wheel_speed)
    accel_rows = outermost(robot.qp_speed_rows(16), robot.max_wheel_accel)
    accel = limits.upper[:, speed_rows.rows.shape[0]:]
    expected = (accel_rows.scale * robot.max_wheel_accel[accel_rows.wheel])[None, :] \
        * model.change_times[:, None]
    np.testing.assert_allclose(accel, expected, rtol=1e-12)
    twists, last = ca.SX.sym("u", 3, HORIZON), ca.SX.sym("last", 3)
    steer = ca.SX.sym("steer", robot.n_wheels) if robot.steered else None
    values, _, upper = robot.nlp_stage_limits(twists, last, steer, model.change_times)
    # A change of the first stage by exactly the tick's allowance along one wheel's row is
    # on the bound, twice that is over it.
    function = ca.Function("g", [twists, last], [ca.vertcat(*values)]) if steer is None \
        else ca.Function("g", [twists, last, steer], [ca.vertcat(*values)])
    bound = np.concatenate(upper)
    u = np.zeros((3, HORIZON))
    u[0, 0] = 1e-3
    arguments = [u, np.zeros(3)] + ([np.zeros(robot.n_wheels)] if steer is not None else [])
    assert np.all(np.asarray(function(*arguments)).ravel() <= bound + 1e-12)


def test_a_plan_moved_on_one_tick_by_hand() -> None:
    """Stages (0.05, 0.1, 0.1): one tick later, new stage 0 is old stage 1's first half,
    new stage 1 spans old stages 1 and 2 half each, new stage 2 is old stage 2's second
    half and then the last twist held; poses at 0.05, 0.10, 0.20, 0.30 s interpolated,
    held past the end."""
    offsets = np.array([0.0, 0.05, 0.15, 0.25])
    poses_map, twists_map = shift_maps(offsets, DT)
    np.testing.assert_allclose(twists_map, np.array([[0, 1, 0], [0, 0.5, 0.5], [0, 0, 1.0]]),
                               atol=1e-12)
    np.testing.assert_allclose(poses_map, np.array([[0, 1, 0, 0], [0, 0.5, 0.5, 0],
                                                    [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]]),
                               atol=1e-12)
    uniform_poses, uniform_twists = shift_maps(DT * np.arange(4.0), DT)
    np.testing.assert_array_equal(uniform_twists, [[0, 1, 0], [0, 0, 1], [0, 0, 1]])
    np.testing.assert_array_equal(uniform_poses, [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1],
                                                  [0, 0, 0, 1]])


def test_stage_dt_defaults_and_errors() -> None:
    robot, trajectory = preset("omni4"), Circle(1.0, 12.0, heading=0.0)
    assert Controller(robot, trajectory, dt=0.02).stage_dt == pytest.approx(0.04)
    assert Controller(robot, trajectory, dt=0.02, mode="path").stage_dt == pytest.approx(0.02)
    controller = Controller(robot, trajectory, horizon=5, dt=0.02, stage_dt=0.07)
    np.testing.assert_allclose(controller.model.offsets, [0, 0.02, 0.09, 0.16, 0.23, 0.30])
    for bad in (0.01, 0.0, -1.0, float("nan"), "0.1"):
        with pytest.raises(ControllerError, match="stage_dt"):
            Controller(robot, trajectory, dt=0.02, stage_dt=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("solver", ["daqp", "osqp", "ipopt"])
def test_the_plans_first_twist_keeps_the_tick_acceleration_limit(
        solver: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """From rest onto a circle beyond the limits with 0.15 s stages, the plan's first twist
    (what is sent) already keeps every wheel's acceleration over one tick: the clamp
    changes it by solver tolerance only (were the first change allowed a whole stage, it
    would cut it to a third). Loop checks every command against the limits, too."""
    robot = preset("mecanum")
    trajectory = too_fast_circle(robot)
    controller = Controller(robot, trajectory, stage_dt=3 * DT, solver=solver)
    solve = controller.solver.solve
    firsts: list[np.ndarray] = []

    def recording(*args: object) -> SolveResult:
        result = solve(*args)  # type: ignore[arg-type]
        firsts.append(result.twists[0].copy())
        return result

    monkeypatch.setattr(controller.solver, "solve", recording)
    loop = Loop(controller, trajectory.sample(0.0).pose)
    assert robot.max_wheel_accel is not None
    accelerating = 0
    for _ in range(40):
        last = loop.last.copy()
        command = loop.step()
        np.testing.assert_allclose(command.twist, firsts[-1], rtol=0, atol=1e-4)
        change = robot.wheel_speeds(command.twist - last)
        accelerating += bool(np.any(np.abs(change) > 0.99 * robot.max_wheel_accel * DT))
    assert accelerating >= 3  # it did accelerate at the limit for a while


def test_tick_input_is_the_same_layout_whatever_the_stages() -> None:
    assert TickInput(make_model().layouts).parameters.size == TickInput(
        TrackingModel(preset("mecanum"), HORIZON, DT, Weights()).layouts).parameters.size
