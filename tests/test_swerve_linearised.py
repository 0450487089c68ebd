"""The swerve disks linearised around the plan the solver starts from (the QP paths'
default): the rows by hand, the faces turned to the guess, and a closed loop beyond the
limits that meets the exact NLP's tracking."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.perf import SPEEDS, reference
from mpc import Controller
from mpc.robots import SwerveRobot, preset
from mpc.robots.limits import SpeedRows, outermost
from mpc.robots.wheels.swerve.limits import (
    ACCEL_SIDES,
    FACE_ANGLES,
    FACES,
    GUARD_FACES,
    face_rows,
    linearised_stage_limits,
    qp_speed_rows,
)
from mpc.sim import simulate
from mpc.solvers.dense import DenseSolver

DT = 0.05


def test_the_middle_face_is_the_disk_tangent_at_the_guess_and_the_rows_are_two_sided() -> None:
    robot = preset("swerve")
    assert isinstance(robot, SwerveRobot) and robot.max_wheel_accel is not None
    n = robot.n_wheels
    change_times = np.full(3, DT)
    limits = linearised_stage_limits(robot, change_times)
    faces = face_rows(n, limits.rows)  # (n, FACES): each face's row
    # the 16-gon's rows a direction: the modules' two extreme moments (:func:`outermost`)
    assert limits.rows == FACES * n + ACCEL_SIDES and not limits.constant
    kept = limits.moving
    assert kept is not None
    assert sorted(faces.ravel()) == [*range(kept), *range(limits.rows - limits.guards,
                                                           limits.rows)]
    accel = slice(kept, limits.rows - limits.guards)  # the acceleration rows
    guess = np.array([[0.6, 0.2, 0.5], [0.5, -0.3, 0.0], [0.0, 0.0, 0.0]])
    last = np.array([0.4, 0.0, 0.1])
    robot.update_stage_limits(limits, guess, last, None)
    middle = FACE_ANGLES.index(0.0)
    for k in range(2):  # stages whose guess velocity gives a direction
        for i in range(n):
            v = robot.wheel_blocks[i] @ guess[k]
            for j in range(FACES):
                angle = math.atan2(v[1], v[0]) + FACE_ANGLES[j]
                normal = np.array([math.cos(angle), math.sin(angle)])
                np.testing.assert_allclose(limits.now[k, faces[i, j]],
                                           normal @ robot.wheel_blocks[i], atol=1e-12)
            # The middle face's value at the guess is the module's speed: the tangent.
            assert limits.now[k, faces[i, middle]] @ guess[k] == pytest.approx(
                np.linalg.norm(v), rel=1e-12)
    # Stage 2's guess is at rest: its speed faces keep the last direction (stage 2 started
    # along the body x axis).
    np.testing.assert_allclose(limits.now[2, faces[0, middle]], robot.wheel_blocks[0][0],
                               atol=1e-12)
    # The acceleration rows: the constant polygon on u_k - u_{k-1} (its outermost rows),
    # every stage, every tick.
    polygon = outermost(qp_speed_rows(robot, ACCEL_SIDES), robot.max_wheel_accel)
    np.testing.assert_allclose(limits.now[:, accel], np.tile(polygon.rows, (3, 1, 1)))
    np.testing.assert_allclose(limits.before[:, accel], -limits.now[:, accel])
    np.testing.assert_allclose(limits.before[:, faces.ravel()], 0.0)
    speed = np.repeat(robot.max_wheel_speed, FACES)
    np.testing.assert_allclose(limits.upper[:, faces.ravel()], np.tile(speed, (3, 1)))
    np.testing.assert_allclose(limits.lower, -limits.upper)
    accel_bound = polygon.scale * robot.max_wheel_accel[polygon.wheel] * DT
    np.testing.assert_allclose(limits.upper[:, accel], np.tile(accel_bound, (3, 1)))


def test_a_module_with_an_axle_offset_or_explicit_sides_keeps_the_constant_polygon() -> None:
    robot = preset("swerve")
    assert robot.stage_limits(np.full(4, DT), 16).constant
    assert not robot.stage_limits(np.full(4, DT), None).constant
    offset = preset("mpo700")
    if getattr(offset, "axle_offset", 0.0):
        assert offset.stage_limits(np.full(4, DT), None).constant


@pytest.mark.parametrize("shape", ["circle", "figure8"])
@pytest.mark.parametrize("heading", ["fixed", "tangent"])
def test_beyond_the_limits_the_linearised_disk_tracks_as_the_exact_nlp(shape: str,
                                                                       heading: str) -> None:
    """The benchmark's references 1.3x too fast for the modules: with the disks
    linearised the fast path's error is within 5 % of the exact NLP's (the 16-gon's is
    10 % above on the tangent figure-eight; a fan of three faces was 25 % above on the
    tangent circle), and no command leaves a module's limits."""
    robot = preset("swerve")
    trajectory = reference(shape, heading, robot, SPEEDS["beyond"])
    errors = {}
    for solver in ("daqp", "ipopt"):
        result = simulate(Controller(robot, trajectory, horizon=20, dt=DT, solver=solver),
                          6.0)
        metrics = result.metrics(skip=2.0)
        errors[solver] = metrics["rms_position_error"]
        assert metrics["limit_violations"] == metrics["accel_violations"] == 0
        assert metrics["max_wheel_speed_ratio"] <= 1.0 + 1e-9
    assert errors["daqp"] <= errors["ipopt"] * 1.05


def test_daqp_whitens_again_only_the_moving_faces_and_gets_the_whole_product() -> None:
    """The speed faces are the only rows a refill moves (``moving``, on ``u_k`` alone):
    after ticks of turning faces, the rows daqp holds equal the whole ``A L^{-T}`` of the
    rows as they are now."""
    robot = preset("swerve")
    controller = Controller(robot, reference("figure8", "fixed", robot, SPEEDS["beyond"]),
                            horizon=8, dt=DT, solver="daqp")
    solver = controller.solver
    assert isinstance(solver, DenseSolver)
    limits = solver.limits  # the rows daqp solves with: the guard faces left out
    assert limits.moving == (FACES - len(GUARD_FACES)) * robot.n_wheels
    assert not limits.before[:, :limits.moving].any()
    simulate(controller, 1.5)
    assert solver.factorisations >= 1
    before = limits.now[:, :limits.moving].copy()
    controller.step(np.array([0.01, 0.0, 0.02]), 1.55)
    assert not np.array_equal(limits.now[:, :limits.moving], before)  # the faces turned
    assert not solver._rows_stale
    whole = solver._whitened(solver._unwhiten)
    np.testing.assert_allclose(solver._whitened_rows, whole, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("mode", ["time", "path"])
def test_the_guard_faces_stay_out_of_daqp_and_the_plans_are_those_of_every_face(
        mode: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """daqp solves without the faces at +-45 and 90 deg, checks the plan against them and
    solves again with them when one breaks (the circle's first tick beyond the limits):
    the commands are those of daqp given every face, to its tolerance (after the second
    solve the kept model starts from another active set, so the closed loops part at
    that level: below 1e-9 here, against 0.04 m/s with the check left out). Inside the limits
    no plan reaches a guard face: no second solve."""
    robot = preset("swerve")
    trajectory = reference("circle", "fixed", robot, SPEEDS["beyond"])
    guarded = Controller(robot, trajectory, horizon=20, dt=DT, solver="daqp", mode=mode)
    inside = Controller(robot, reference("figure8", "fixed", robot, SPEEDS["inside"]),
                        horizon=20, dt=DT, solver="daqp", mode=mode)
    monkeypatch.setattr("mpc.robots.wheels.swerve.limits.GUARD_FACES", ())
    every = Controller(robot, trajectory, horizon=20, dt=DT, solver="daqp", mode=mode)
    solver, every_face, solver_inside = guarded.solver, every.solver, inside.solver
    assert isinstance(solver, DenseSolver) and isinstance(every_face, DenseSolver)
    assert isinstance(solver_inside, DenseSolver)
    assert solver.limits.rows == every_face.limits.rows - len(GUARD_FACES) * robot.n_wheels
    first, second = simulate(guarded, 3.0), simulate(every, 3.0)
    simulate(inside, 3.0)
    assert solver.guarded_solves >= 1 and every_face.guarded_solves == 0
    assert solver_inside.guarded_solves == 0
    np.testing.assert_allclose(first.twist_command, second.twist_command, rtol=0.0, atol=1e-7)


@pytest.mark.parametrize(("ratio", "late"), [(0.8, False), (1.3, True)])
def test_rows_kept_while_the_plan_keeps_inside_the_disks_give_the_same_commands(
        ratio: float, late: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """A tick after a plan well inside every speed disk, with no speed face active, keeps
    the faces of the last refill (no new rows for daqp); its plan is checked, and turns the
    faces after all and solves again when it reaches a disk's edge (the figure-eight 1.3x
    beyond the limits). Commands equal those of refilling every tick, to daqp's tolerance
    (the closed loops part at 2e-7 m/s after a second solve)."""
    robot = preset("swerve")
    trajectory = reference("figure8", "fixed", robot, ratio)
    keeping = Controller(robot, trajectory, horizon=20, dt=DT, solver="daqp")
    first = simulate(keeping, 6.0)
    monkeypatch.setattr("mpc.solvers.dense.KEEP_ROWS_BELOW", 0.0)  # never keep
    refilling = Controller(robot, trajectory, horizon=20, dt=DT, solver="daqp")
    second = simulate(refilling, 6.0)
    solver, other = keeping.solver, refilling.solver
    assert isinstance(solver, DenseSolver) and isinstance(other, DenseSolver)
    assert solver.kept_rows >= 3 and other.kept_rows == 0
    assert (solver.late_refills >= 1) == late
    np.testing.assert_allclose(first.twist_command, second.twist_command, rtol=0.0,
                               atol=1e-6 if late else 1e-12)


def test_a_guarded_solve_daqp_cannot_set_up_is_a_failed_tick_with_a_safe_command(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The second solve's own model refused (its set-up failing): the tick fails with its
    own status, and the controller's fallback sends a command within the limits."""
    robot = preset("swerve")
    # (a time budget: no second solve of the failed first tick from the held command)
    controller = Controller(robot, reference("circle", "fixed", robot, SPEEDS["beyond"]),
                            horizon=20, dt=DT, solver="daqp", time_limit=10.0)
    solver = controller.solver
    assert isinstance(solver, DenseSolver)
    set_up = DenseSolver._set_up

    def refuse_guarded(self: DenseSolver, gradient: np.ndarray, rows: np.ndarray,
                       lower: np.ndarray, upper: np.ndarray,
                       multipliers: np.ndarray | None = None) -> object:
        if rows.shape[0] > self._whitened_rows.shape[0]:  # the rows with the guards
            return None  # warm and cold alike
        return set_up(self, gradient, rows, lower, upper, multipliers)

    monkeypatch.setattr(DenseSolver, "_set_up", refuse_guarded)
    pose = np.array(controller.trajectory.sample(0.0).pose)
    command = controller.step(pose, 0.0)  # the first tick breaks a guard (see above)
    assert solver.guarded_solves == 1
    assert command.solver_status == "daqp set-up failed (with the guard rows)"
    assert command.status.value != "solved"
    assert np.all(np.isfinite(command.wheel_speeds))
    assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))


def test_the_second_solve_starts_from_the_first_ones_active_rows_or_cold(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The guarded solve marks the first solve's active rows active (a warm start: 70
    iterations against 205 on the circle's first tick at N = 20); when daqp refuses that
    start it solves cold, to the same command."""
    robot = preset("swerve")
    trajectory = reference("circle", "fixed", robot, SPEEDS["beyond"])
    pose = np.array(trajectory.sample(0.0).pose)
    warm = Controller(robot, trajectory, horizon=20, dt=DT, solver="daqp")
    warm_command = warm.step(pose, 0.0)
    set_up = DenseSolver._set_up
    starts: list[bool] = []

    def refuse_warm(self: DenseSolver, gradient: np.ndarray, rows: np.ndarray,
                    lower: np.ndarray, upper: np.ndarray,
                    multipliers: np.ndarray | None = None) -> object:
        if rows.shape[0] > self._whitened_rows.shape[0]:  # the guarded solve's set-ups
            starts.append(multipliers is not None)
            if multipliers is not None:
                return None
        return set_up(self, gradient, rows, lower, upper, multipliers)

    monkeypatch.setattr(DenseSolver, "_set_up", refuse_warm)
    cold = Controller(robot, trajectory, horizon=20, dt=DT, solver="daqp")
    cold_command = cold.step(pose, 0.0)
    assert starts == [True, False]  # warm refused, then cold
    assert warm.solver.guarded_solves == cold.solver.guarded_solves == 1  # type: ignore[attr-defined]
    assert warm_command.status.value == cold_command.status.value == "solved"
    assert warm_command.iterations < cold_command.iterations
    np.testing.assert_allclose(warm_command.twist, cold_command.twist, rtol=0.0, atol=1e-9)


def test_outermost_keeps_each_directions_extreme_moments_by_hand() -> None:
    """Rows alike but for the omega coefficient, with the same bound: the least and the
    greatest hold the rest (a duplicate and a middle one go); other directions, and a
    row with another bound (a derated wheel), stay; the order is kept."""
    rows = np.array([[1.0, 0.0, 0.5], [1.0, 0.0, -2.0], [0.0, 1.0, 1.0], [1.0, 0.0, 2.0],
                     [1.0, 0.0, 2.0], [1.0, 0.0, 3.0]])
    wheel = np.array([0, 1, 0, 2, 3, 4])
    limit = np.array([1.0, 1.0, 1.0, 1.0, 0.5])  # wheel 4 derated
    kept = outermost(SpeedRows(rows, wheel, 0.9), limit)
    np.testing.assert_array_equal(kept.rows, rows[[1, 2, 3, 5]])
    np.testing.assert_array_equal(kept.wheel, [1, 0, 2, 4])
    assert kept.scale == 0.9


@pytest.mark.parametrize("name", ["swerve", "mpo700"])
def test_outermost_rows_bound_every_twist_as_all_the_rows_do(name: str) -> None:
    """On a swerve's 16-gon (the MPO-700's with its axle offset: rows +- L omega), derated
    or not, for its speed and acceleration limits: for 2000 random changes of twist the
    largest row value over its bound is the same with the rows kept as with all of them,
    to rounding."""
    rng = np.random.default_rng(11)

    def worst(rows: SpeedRows, limit: np.ndarray, twists: np.ndarray) -> np.ndarray:
        bounds = rows.scale * limit[rows.wheel]
        return np.max(np.abs(twists @ rows.rows.T) / bounds, axis=1)

    for robot in (preset(name), preset(name).derated({1: 0.6})):
        polygon = robot.qp_speed_rows(16)
        accel = () if robot.max_wheel_accel is None else (robot.max_wheel_accel,)
        for limit in (robot.max_wheel_speed, *accel):
            kept = outermost(polygon, limit)
            assert len(kept.rows) < len(polygon.rows)
            twists = rng.normal(size=(2000, 3))
            np.testing.assert_allclose(worst(kept, limit, twists),
                                       worst(polygon, limit, twists), rtol=1e-12)
