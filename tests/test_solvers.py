"""The fast path (OSQP, real-time iteration) against the exact path (IPOPT).

Both solve the same tracking problem built from one CasADi model. One QP tick
is a single linearisation (RTI) around the guess, so its first twist is not
the NLP's optimum when the guess is far from it. Solving the QP again and
again around its own solution (a full-step SQP with the cost's exact,
constant Hessian) converges to a point where the linearisation is exact; its
KKT conditions are then the NLP's, so the two must agree up to the solvers'
tolerances:

- OSQP at its default tolerance (eps_abs = eps_rel = 1e-4 on residuals scaled
  by the problem's norms, ~1e2 here) leaves twist errors of ~1e-4..3e-3:
  we allow 2e-3 on the first twist, against corrections of 0.1-0.5 m/s.
- OSQP at tolerance 1e-9 agrees with IPOPT (tol 1e-8) to 1e-6.

Swerve modules are disks in the NLP and inscribed 16-gons in the QP, so the
two problems differ where a module limit is active; swerve is compared on a
problem where every limit is inactive.
"""

from __future__ import annotations

import numpy as np
import pytest
from closed_loop import ACCEL_PRESETS

from mpc.control.timing import ReferenceWindow
from mpc.model import TickInput, TrackingModel, Weights
from mpc.robots import PRESETS, Robot, preset
from mpc.solvers import USABLE_PRIMAL_RESIDUAL, NlpSolver, QpSolver, SolveResult
from mpc.solvers.dense import DenseSolver
from mpc.solvers.qp import _DirectOsqp
from trajectories import FigureEight

DT = 0.05
HORIZON = 20
TRAJECTORY = FigureEight(1.0, 16.0, heading="tangent")


class Problem:
    """One tick's inputs: start pose, reference window and last command."""

    def __init__(self, robot_name: str, offset: tuple[float, float, float],
                 last: str = "rest") -> None:
        self.robot: Robot = preset(robot_name)
        self.model = TrackingModel(self.robot, HORIZON, DT, Weights())
        self.pose = TRAJECTORY.sample(0.0).pose + np.array(offset)
        self.tick = TickInput(self.model.layouts)
        ReferenceWindow(TRAJECTORY, self.model, self.tick).fill(0.0, float(self.pose[2]))
        self.poses_ref = self.tick.poses_ref.copy()
        self.feedforward = self.tick.twists_ref.copy()
        self.last = np.zeros(3) if last == "rest" else self.feedforward[0].copy()
        self.tick.pose[:] = self.pose
        self.tick.last_twist[:] = self.last

    def guess(self) -> tuple[np.ndarray, np.ndarray]:
        poses = self.poses_ref.copy()
        poses[0] = self.pose
        return poses, self.feedforward.copy()

    def solve(self, solver: QpSolver | NlpSolver, guess: tuple[np.ndarray, np.ndarray]
              ) -> SolveResult:
        self.tick.guess_poses[:], self.tick.guess_twists[:] = guess
        return solver.solve(self.tick)

    def iterate_qp(self, solver: QpSolver, rounds: int) -> SolveResult:
        """Re-linearise around the QP's own solution ``rounds`` times (full-step SQP)."""
        guess = self.guess()
        for _ in range(rounds):
            solver.reset()  # the dual shift is for receding horizons, not for re-solving
            result = self.solve(solver, guess)
            assert result.success, result.status
            guess = (result.poses.copy(), result.twists.copy())
        return result

    def speed_ratio(self, twists: np.ndarray) -> float:
        return float(np.max(self.robot.speed_ratio(twists)))

    def accel_ratio(self, twists: np.ndarray) -> float:
        changes = np.diff(np.vstack([self.last, twists]), axis=0)
        size = np.linalg.norm(self.robot.wheel_velocities(changes), axis=-1)
        accel = self.robot.max_wheel_accel
        if accel is None:
            raise AssertionError("the preset has acceleration limits")
        return float((size / (accel * DT)).max())


FAR_OFF = (0.2, -0.1, 0.3)  # [m, m, rad]; from rest: the acceleration limits bind
NEAR = (0.003, -0.0015, 0.003)  # continuing at the feedforward: no limit binds


@pytest.mark.parametrize("robot_name", ["omni3", "omni4", "mecanum"])
def test_converged_rti_matches_nlp_with_active_limits(robot_name: str) -> None:
    problem = Problem(robot_name, FAR_OFF)
    exact = problem.solve(NlpSolver(problem.model), problem.guess())
    assert exact.success and exact.status == "Solve_Succeeded"
    # The problem is not trivial: the plan departs from the feedforward and a limit binds.
    assert np.abs(exact.twists[0] - problem.feedforward[0]).max() > 0.1
    assert max(problem.speed_ratio(exact.twists), problem.accel_ratio(exact.twists)) > 0.999

    default = problem.iterate_qp(QpSolver(problem.model), rounds=8)
    np.testing.assert_allclose(default.twists[0], exact.twists[0], atol=2e-3)
    np.testing.assert_allclose(default.twists, exact.twists, atol=1.5e-2)

    tight = problem.iterate_qp(QpSolver(problem.model, tolerance=1e-9, max_iter=20000), 8)
    np.testing.assert_allclose(tight.twists[0], exact.twists[0], atol=1e-6)
    np.testing.assert_allclose(tight.twists, exact.twists, atol=2e-4)
    np.testing.assert_allclose(tight.poses, exact.poses, atol=2e-5)


@pytest.mark.parametrize("robot_name", ACCEL_PRESETS)
def test_converged_rti_matches_nlp_with_inactive_limits(robot_name: str) -> None:
    problem = Problem(robot_name, NEAR, last="feedforward")
    exact = problem.solve(NlpSolver(problem.model), problem.guess())
    assert exact.success
    assert problem.speed_ratio(exact.twists) < 0.9 and problem.accel_ratio(exact.twists) < 0.9
    assert np.abs(exact.twists[0] - problem.feedforward[0]).max() > 0.01  # feedback acts
    tight = problem.iterate_qp(QpSolver(problem.model, tolerance=1e-9, max_iter=20000), 4)
    np.testing.assert_allclose(tight.twists, exact.twists, atol=1e-6)
    np.testing.assert_allclose(tight.poses, exact.poses, atol=1e-7)


@pytest.mark.parametrize("robot_name", PRESETS)
def test_single_rti_tick_matches_nlp_on_the_reference(robot_name: str) -> None:
    """Starting on the reference with the feedforward, the optimum is within ~2e-2 of the
    reference (the rate terms smooth the feedforward's changes along the horizon), so the
    linearisation around the reference is nearly exact there: one QP tick agrees with the
    NLP to second order, i.e. to OSQP's tolerance."""
    problem = Problem(robot_name, (0.0, 0.0, 0.0), last="feedforward")
    exact = problem.solve(NlpSolver(problem.model), problem.guess())
    assert exact.success
    np.testing.assert_allclose(exact.twists, problem.feedforward, atol=2.5e-2)
    qp = problem.solve(QpSolver(problem.model), problem.guess())
    assert qp.success and qp.status == "solved"
    np.testing.assert_allclose(qp.twists[0], exact.twists[0], atol=2e-3)
    np.testing.assert_allclose(qp.twists, exact.twists, atol=5e-3)
    tight = problem.solve(QpSolver(problem.model, tolerance=1e-9, max_iter=20000),
                          problem.guess())
    np.testing.assert_allclose(tight.twists, exact.twists, atol=1e-5)


def linearised_residual(model: TrackingModel, guess: tuple[np.ndarray, np.ndarray],
                        result: SolveResult) -> float:
    """Largest violation of x_{k+1} = c_k + A_k x_k + B_k u_k, (c, A, B) at the guess."""
    rows = np.asarray(model.linearization(guess[0][:-1].T, guess[1].T).full())
    worst = 0.0
    for k in range(model.horizon):
        c = rows[:3, k]
        a = rows[3:12, k].reshape(3, 3, order="F")
        b = rows[12:, k].reshape(3, 3, order="F")
        predicted = c + a @ result.poses[k] + b @ result.twists[k]
        worst = max(worst, float(np.abs(result.poses[k + 1] - predicted).max()))
    return worst


@pytest.mark.parametrize("robot_name", ["mecanum", "swerve"])
def test_qp_pattern_is_fixed_and_every_update_is_applied(robot_name: str) -> None:
    """A receding-horizon loop on the model itself for 60 ticks, with the guess perturbed
    (seeded) so that consecutive linearisations differ: every tick solves, and every
    solution satisfies the linearisation around
    *that tick's* guess to OSQP's tolerance (1e-7 here, residuals ~1e-6), while it misses
    the previous tick's by ~1e-3: a rejected or misplaced update of A would show. The first
    tick linearises at heading 0 and rest, where many Jacobian entries are exactly zero:
    they must stay in the pattern for later updates to land."""
    robot = preset(robot_name)
    model = TrackingModel(robot, HORIZON, DT, Weights())
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    tick_input = TickInput(model.layouts)
    window = ReferenceWindow(trajectory, model, tick_input)
    solver = QpSolver(model, tolerance=1e-7, max_iter=20000)
    nonzeros = solver.structure.constraints.nnz
    rng = np.random.default_rng(0)
    pose, last = np.zeros(3), np.zeros(3)
    guess = (np.zeros((HORIZON + 1, 3)), np.zeros((HORIZON, 3)))
    previous_guess = None
    for tick in range(60):
        window.fill(tick * DT, float(pose[2]))
        tick_input.pose[:], tick_input.last_twist[:] = pose, last
        tick_input.guess_poses[:], tick_input.guess_twists[:] = guess
        result = solver.solve(tick_input)
        assert result.success and result.status == "solved", (tick, result.status)
        assert linearised_residual(model, guess, result) < 2e-5, tick
        if previous_guess is not None:
            assert linearised_residual(model, previous_guess, result) > 2e-4, tick
        np.testing.assert_allclose(result.poses[0], pose, atol=1e-5)
        # Next tick: the robot moved exactly as the model says; shift and perturb the plan.
        last = result.twists[0]
        pose = np.asarray(model.dynamics(pose, last).full()).ravel()
        poses = np.vstack([result.poses[1:], result.poses[-1:]])
        twists = np.vstack([result.twists[1:], result.twists[-1:]])
        poses[1:] += rng.normal(0.0, 0.05, (HORIZON, 3)) * np.array([1.0, 1.0, 3.0])
        twists += rng.normal(0.0, 0.1, (HORIZON, 3))
        poses[0] = pose
        previous_guess, guess = guess, (poses, twists)
    assert solver.structure.constraints.nnz == nonzeros
    # Despite the perturbed guesses the robot reached the reference (from 0.79 rad off).
    np.testing.assert_allclose(pose[:2], trajectory.sample(60 * DT).pose[:2], atol=5e-3)


def test_qp_solution_respects_the_wheel_rows() -> None:
    problem = Problem("mecanum", FAR_OFF)
    result = problem.solve(QpSolver(problem.model), problem.guess())
    assert result.success
    # OSQP's primal tolerance (1e-4 abs + rel) on rows of size ~20 rad/s.
    assert problem.speed_ratio(result.twists) <= 1.0 + 1e-3
    assert problem.accel_ratio(result.twists) <= 1.0 + 1e-3
    assert result.poses.shape == (HORIZON + 1, 3) and result.twists.shape == (HORIZON, 3)
    assert result.iterations > 0 and result.solve_time > 0.0


def test_statuses_when_the_solvers_run_out_of_iterations() -> None:
    problem = Problem("mecanum", FAR_OFF)
    qp = problem.solve(QpSolver(problem.model, max_iter=1), problem.guess())
    assert not qp.success
    assert qp.status == "maximum iterations reached"
    assert qp.iterations == 1
    nlp = problem.solve(NlpSolver(problem.model, max_iter=1), problem.guess())
    assert not nlp.success
    assert nlp.status == "Maximum_Iterations_Exceeded"


def test_unfinished_qp_iterate_with_small_residual_is_used() -> None:
    """RTI: out of iterations, an iterate whose residuals are small (USABLE_*_RESIDUAL)
    counts as solved, and then it does satisfy the linearised dynamics to that residual."""
    problem = Problem("mecanum", NEAR, last="feedforward")
    guess = problem.guess()
    result = problem.solve(QpSolver(problem.model, max_iter=3), guess)
    assert result.success
    assert result.status == "maximum iterations reached"
    assert result.iterations == 3
    assert np.all(np.isfinite(result.twists))
    assert linearised_residual(problem.model, guess, result) <= USABLE_PRIMAL_RESIDUAL


def test_a_barely_started_qp_iterate_is_a_failure() -> None:
    """One OSQP iteration leaves the cost far from stationary (dual residual ~300):
    that iterate is not a plan, so the controller must fall back."""
    problem = Problem("mecanum", (0.05, 0.0, 0.0))
    result = problem.solve(QpSolver(problem.model, max_iter=1), problem.guess())
    assert not result.success
    assert result.status == "maximum iterations reached"


def test_direct_osqp_calls_match_the_public_api() -> None:
    """The fast path calls OSQP's extension object directly (a private API of osqp 1.x,
    skipping ~50 us of wrapper per tick); the public update/warm_start/solve API must give
    the same answer, so a new osqp version that changes the private one shows here."""
    problem = Problem("swerve", (0.1, -0.05, 0.2))
    direct = QpSolver(problem.model)
    public = QpSolver(problem.model, use_extension=False)
    assert isinstance(direct.backend, _DirectOsqp)
    guess = problem.guess()
    for _ in range(3):
        a, b = problem.solve(direct, guess), problem.solve(public, guess)
        assert a.status == b.status and a.iterations == b.iterations
        np.testing.assert_array_equal(a.twists, b.twists)
        np.testing.assert_array_equal(a.poses, b.poses)
        guess = (a.poses.copy(), a.twists.copy())


def test_daqp_refusing_the_set_up_is_a_failed_tick_and_the_next_tick_sets_up_again(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """daqp's set-up returns a negative flag (bounds that cross, for one) instead of raising:
    the tick fails over to the fallback, and no later call finds a model never set up."""
    import types

    import daqp

    import mpc.solvers.dense as dense
    from mpc import Controller, Status

    class RefusesOnce:
        """daqp.Model, refusing its first set-up."""

        refused = 0

        def __init__(self) -> None:
            self.model = daqp.Model()

        def setup(self, *args: object) -> tuple[int, float]:
            if RefusesOnce.refused == 0:
                RefusesOnce.refused += 1
                return -1, 0.0
            return self.model.setup(*args)  # type: ignore[no-any-return, arg-type]

        @property
        def settings(self) -> dict[str, float]:
            return self.model.settings  # type: ignore[no-any-return]

        @settings.setter
        def settings(self, value: dict[str, float]) -> None:
            self.model.settings = value

        def update(self, **kwargs: object) -> int:
            return self.model.update(**kwargs)  # type: ignore[no-any-return]

        def solve(self) -> tuple[object, ...]:
            return self.model.solve()  # type: ignore[no-any-return]

    monkeypatch.setattr(dense, "daqp", types.SimpleNamespace(Model=RefusesOnce))
    robot = preset("mecanum")
    # with a time budget a failed first tick is not solved again: the fallback
    controller = Controller(robot, FigureEight(1.0, 12.0), time_limit=10.0)
    first = controller.step(controller.trajectory.sample(0.0).pose, 0.0)
    assert first.status is not Status.SOLVED and first.solver_status == "daqp set-up failed"
    assert np.all(np.abs(first.wheel_speeds) <= robot.max_wheel_speed)
    second = controller.step(controller.trajectory.sample(0.05).pose, 0.05)
    assert second.status is Status.SOLVED and RefusesOnce.refused == 1
    # without one, the first tick (its guess the reference's) is solved again at once
    RefusesOnce.refused = 0
    again = Controller(robot, FigureEight(1.0, 12.0))
    assert again.step(again.trajectory.sample(0.0).pose, 0.0).status is Status.SOLVED
    assert RefusesOnce.refused == 1


def test_sparse_rows_times_a_matrix_as_the_dense_product() -> None:
    """Path mode's progress rows are whitened by row gathers: the same as the dense product
    for rows of one, two or more nonzeros, and for none at all."""
    from mpc.solvers.dense import _SparseRows

    rng = np.random.default_rng(4)
    rows = np.zeros((7, 9))
    rows[0, 3] = 1.0
    rows[1, [2, 3]] = [-1.0, 1.0]
    rows[2, [0, 4, 8]] = rng.normal(size=3)
    rows[4, 8] = -2.5  # row 3 and 5 stay empty
    rows[6, [1, 7]] = rng.normal(size=2)
    matrix = rng.normal(size=(9, 9))
    out = np.empty((7, 9))
    _SparseRows(rows).times(matrix, out)
    np.testing.assert_allclose(out, rows @ matrix, rtol=0.0, atol=1e-14)
    none = np.empty((0, 9))
    _SparseRows(np.zeros((0, 9))).times(matrix, none)
    assert none.shape == (0, 9)


@pytest.mark.parametrize(("robot_name", "mode"), [("mecanum", "time"), ("mecanum", "path"),
                                                  ("mpo700", "time"), ("omni3", "path")])
def test_fixed_limit_bounds_are_the_bounds_filled_anew(robot_name: str, mode: str) -> None:
    """Robots whose limit rows never move take the step's bounds from fixed bounds minus one
    product (dense or sparse): the same as filling every bound anew, along a closed loop
    whose guesses and last commands vary."""
    from mpc import Controller
    from mpc.sim import simulate
    from mpc.solvers.qp_structure import fill_inequality_bounds

    robot = preset(robot_name)
    controller = Controller(robot, FigureEight(1.5, 4.0, heading="tangent"), horizon=12,
                            solver="daqp", mode=mode)
    solver = controller.solver
    assert isinstance(solver, DenseSolver) and solver._fixed_bounds is not None
    fixed = solver._fixed_bounds
    compared = 0

    def check(*_: object) -> None:
        nonlocal compared
        tick = controller._tick
        lower, upper = (b.copy() for b in fixed.step(tick))
        fill_inequality_bounds(solver.structure, tick, solver._lower, solver._upper)
        at_guess = solver._rows_at_guess(tick)
        first = solver.condenser.first_row
        np.testing.assert_allclose(lower, solver._lower[first:] - at_guess, rtol=0, atol=1e-12)
        np.testing.assert_allclose(upper, solver._upper[first:] - at_guess, rtol=0, atol=1e-12)
        compared += 1

    original = solver._update

    def update(*args: object, **kwargs: object) -> object:
        check()
        return original(*args, **kwargs)  # type: ignore[arg-type]

    solver._update = update  # type: ignore[method-assign,assignment]
    simulate(controller, 1.5)
    assert compared >= 30


def _turning_guess(horizon: int, period: float, seed: int
                   ) -> tuple[DenseSolver, np.ndarray, np.ndarray]:
    """A Mecanum fast path after one tick on a tangent-heading figure-eight of ``period``
    [s]: its solver, the tick's parameters and a turning, strafing guess (N, 3)."""
    from mpc import Controller

    controller = Controller(preset("mecanum"), FigureEight(1.0, period, heading="tangent"),
                            horizon=horizon)
    solver = controller.solver
    assert isinstance(solver, DenseSolver)
    controller.step(controller.trajectory.sample(0.0).pose, 0.0)
    twists = np.random.default_rng(seed).normal(scale=[0.8, 0.5, 1.5], size=(horizon, 3))
    return solver, np.array(controller._tick.parameters), twists


@pytest.mark.parametrize("horizon", [1, 2, 20])
def test_state_sensitivities_are_the_rollouts_jacobian(horizon: int) -> None:
    """``S`` (gathered block by block, lever arms from the rollout's steps) against central
    differences of the exact SE(2) rollout CasADi computes, on a turning, strafing guess."""
    solver, parameters, twists = _turning_guess(horizon, 12.0, seed=7)

    def rollout(u: np.ndarray) -> np.ndarray:
        poses = solver._terms(parameters, u.T)[1]
        return np.array(poses).T  # (N+1, 3)

    # the terms at the guess, as the tick's own CasADi call gives them
    _, poses, vec_b, _, _ = solver._terms(parameters, twists.T)
    poses = np.array(poses).T
    sensitivity = np.array(vec_b).T.reshape(-1, 3, 3).transpose(0, 2, 1)
    steps = poses[1:, :2] - poses[:-1, :2]
    states = solver.condenser.state_sensitivities(sensitivity, steps)
    h = 1e-6
    for column in range(3 * horizon):
        bump = np.zeros(3 * horizon)
        bump[column] = h
        numeric = (rollout(twists + bump.reshape(-1, 3))
                   - rollout(twists - bump.reshape(-1, 3))) / (2 * h)
        np.testing.assert_allclose(states[:, :, column], numeric, rtol=0.0, atol=1e-7)


def test_plan_poses_are_the_rollout_moved_by_the_state_sensitivities() -> None:
    """The plan's poses after a step (one CasADi call, lever arms summed stage by stage)
    against the rollout plus ``S d`` with ``S`` the state sensitivities (themselves checked
    against central differences of the exact rollout above), on a turning guess."""
    from mpc.solvers.condensed import plan_poses

    horizon = 8
    solver, parameters, twists = _turning_guess(horizon, 6.0, seed=5)
    rng = np.random.default_rng(5)
    _, poses, vec_b, _, steps = solver._terms(parameters, twists.T)
    poses, steps = np.array(poses).T, np.array(steps).T
    np.testing.assert_allclose(steps, poses[1:, :2] - poses[:-1, :2], rtol=0, atol=1e-15)
    sensitivity = np.array(vec_b).T.reshape(-1, 3, 3).transpose(0, 2, 1)
    states = solver.condenser.state_sensitivities(sensitivity, steps)
    step = rng.normal(scale=0.1, size=(horizon, 3))
    planned = np.array(plan_poses(horizon)(poses.T, vec_b, step.T, steps.T)).T
    np.testing.assert_allclose(planned, poses + states @ step.ravel(), rtol=0, atol=1e-14)


@pytest.mark.parametrize("mode", ["time", "path"])
def test_tick_gradient_is_the_cost_along_the_rollout_differentiated(mode: str) -> None:
    """The tick's gradient (the cost's partial derivatives carried back through the rollout
    by the adjoint recursion) against central differences of the cost, in CasADi, of the
    exact rollout of the twists (and the progress), on a turning, strafing guess off the
    reference, with a tick's real parameters."""
    import casadi as ca

    from mpc import Controller

    robot, horizon = preset("mecanum"), 6
    controller = Controller(robot, FigureEight(1.0, 6.0, heading="tangent"), horizon=horizon,
                            mode=mode)
    solver, tick = controller.solver, controller._tick
    assert isinstance(solver, DenseSolver)
    controller.step(controller.trajectory.sample(0.0).pose + [0.05, -0.03, 0.2], 0.0)
    model = controller.model
    variables, _ = model.layouts
    rng = np.random.default_rng(11)
    twists = rng.normal(scale=[0.8, 0.5, 1.5], size=(horizon, 3))
    parameters = np.array(tick.parameters)
    point, p = ca.SX.sym("z", variables.size), ca.SX.sym("p", parameters.size)
    cost = ca.Function("cost", [point, p], [model.cost(point, p)])
    extra: list[np.ndarray] = []
    if tick.path is not None:
        extra = [tick.path.guess_progress + rng.normal(scale=0.02, size=horizon + 1)]

    def along_rollout(y: np.ndarray) -> float:
        u = y[:3 * horizon].reshape(-1, 3)
        poses = np.array(solver._terms(parameters, u.T, *extra)[1]).T
        z = np.zeros(variables.size)
        z[variables["poses"].start:][:3 * (horizon + 1)] = poses.ravel()
        z[variables["twists"].start:][:3 * horizon] = u.ravel()
        if extra:
            field = variables["progress"]
            z[field.start:field.start + field.size] = y[3 * horizon:]
        return float(cost(z, parameters))

    gradient = np.array(solver._terms(parameters, twists.T, *extra)[3]).ravel()
    y = np.concatenate([twists.ravel(), *extra])
    assert gradient.shape == y.shape
    h = 1e-6
    numeric = np.array([(along_rollout(y + h * e) - along_rollout(y - h * e)) / (2 * h)
                        for e in np.eye(y.size)])
    np.testing.assert_allclose(gradient, numeric, rtol=1e-6, atol=1e-5)


def test_drift_is_the_largest_move_of_a_sensitivity_or_a_step_times_dt() -> None:
    """The drift check on one vector of the moving terms weighs the sensitivities as they
    are and the rollout's steps times dt (as they enter S), against its tolerance."""
    from mpc.solvers.hessian_reuse import SENSITIVITY_TOLERANCE, HessianReuse

    rng = np.random.default_rng(12)
    n, dt = 5, 0.1
    p_data = np.ones(4)
    reuse = HessianReuse(p_data, dt, n)
    terms = rng.normal(size=11 * n)
    b, d = terms[:9 * n].reshape(n, 3, 3), terms[9 * n:].reshape(n, 2)
    reuse.remember(p_data, terms, b, d)
    for moved_b, moved_d in ((1e-3, 0.0), (0.0, 1e-3), (2e-3, 5e-3)):
        new = terms.copy()
        new[3] += moved_b
        new[9 * n + 4] -= moved_d
        _, drift = reuse.drift(p_data, new, new[:9 * n].reshape(n, 3, 3),
                               new[9 * n:].reshape(n, 2), False, False, 1.0)
        expected = max(moved_b, dt * moved_d) / (SENSITIVITY_TOLERANCE * dt)
        assert drift == pytest.approx(expected, rel=1e-9)


def test_a_rotation_of_the_whole_plan_is_not_a_drift() -> None:
    """An isotropic cost's drift check turns the terms to stage 0's frame: a plan turned
    as a whole by any angle gives the same turned terms (hand-built ``B_k``: the body
    twist's rotation into the world times ``dt``)."""
    from mpc.solvers.hessian_reuse import _unrotated

    rng = np.random.default_rng(3)
    dt, headings = 0.05, rng.uniform(-1.0, 1.0, size=6)
    steps = rng.normal(size=(6, 2))

    def terms(turn: float) -> tuple[np.ndarray, np.ndarray]:
        c, s = np.cos(headings + turn), np.sin(headings + turn)
        sensitivity = np.zeros((6, 3, 3))
        sensitivity[:, 0, 0], sensitivity[:, 0, 1] = c * dt, -s * dt
        sensitivity[:, 1, 0], sensitivity[:, 1, 1] = s * dt, c * dt
        sensitivity[:, 2, 2] = dt
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        return sensitivity, steps @ rotation.T

    base = _unrotated(*terms(0.0))
    for turn in (0.3, -2.0, 3.1):
        turned = _unrotated(*terms(turn))
        np.testing.assert_allclose(turned[0], base[0], rtol=0.0, atol=1e-15)
        np.testing.assert_allclose(turned[1], base[1], rtol=0.0, atol=1e-14)
    # stage 0's body x axis is the world x axis after turning
    np.testing.assert_allclose(base[0][0, :2, :2], dt * np.eye(2), atol=1e-15)


def test_a_rebuild_for_moved_cost_terms_keeps_the_last_builds_state_sensitivities() -> None:
    """Path mode: a rebuild for cost terms that moved while the sensitivities stayed within
    ``COST_ONLY_DRIFT`` of the last full build's whitens with the Hessian of this tick's
    cost terms and that build's ``S`` (rebuilt here from its terms), not this tick's."""
    from mpc import Controller
    from mpc.model import integrate

    reference = FigureEight(1.0, 8.0)
    control = Controller(preset("mecanum"), reference, horizon=10, dt=0.05, mode="path")
    solver = control.solver
    assert isinstance(solver, DenseSolver)
    pose = reference.sample(0.0).pose
    for k in range(80):
        before = solver.cost_rebuilds
        command = control.step(pose, k * 0.05)
        pose = integrate(pose, command.twist, 0.05)
        if solver.cost_rebuilds > before:
            break
    else:
        pytest.fail("no rebuild kept the last build's S in 80 ticks")
    cache = solver._reuse._cache
    assert cache is not None
    condenser = solver.condenser
    condenser.scatter(cache.p_data)
    unwhiten = solver._unwhiten
    identity = np.eye(unwhiten.shape[0])
    kept = condenser.hessian(condenser.state_sensitivities(cache.sensitivity,
                                                           cache.displacement))
    np.testing.assert_allclose(unwhiten.T @ kept @ unwhiten, identity, rtol=0.0, atol=1e-9)
    fresh = condenser.hessian(condenser.state_sensitivities(solver._sensitivities(),
                                                            solver._displacement))
    assert not np.allclose(unwhiten.T @ fresh @ unwhiten, identity, rtol=0.0, atol=1e-6)
