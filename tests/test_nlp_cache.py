"""IPOPT's derivatives are built once per problem (mpc.solvers.nlp._DERIVATIVES): solvers of
one problem build their IPOPT from the same ones and solve exactly as a solver built from
scratch; anything that changes the problem derives anew; IPOPT's own options and the
bounds stay each solver's own."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pytest

from mpc.control.timing import ReferenceWindow
from mpc.model import TickInput, TrackingModel, Weights
from mpc.robots import Robot, preset
from mpc.solvers import NlpSolver, SolveResult, nlp
from trajectories import FigureEight

TRAJECTORY = FigureEight(1.0, 16.0, heading="tangent")
OFFSET = np.array([0.2, -0.1, 0.3])  # [m, m, rad] from rest: the acceleration limits bind


def model(robot: Robot | None = None, horizon: int = 10, dt: float = 0.05,
          weights: Weights | None = None) -> TrackingModel:
    return TrackingModel(robot or preset("mecanum"), horizon, dt, weights or Weights())


def solve(solver: NlpSolver, offset: np.ndarray = OFFSET) -> SolveResult:
    """One tick from rest at ``offset`` off the reference, guessed at the reference."""
    tick = TickInput(solver.model.layouts)
    pose = TRAJECTORY.sample(0.0).pose + offset
    ReferenceWindow(TRAJECTORY, solver.model, tick).fill(0.0, float(pose[2]))
    tick.pose[:] = pose
    tick.last_twist[:] = 0.0
    tick.guess_poses[:] = tick.poses_ref
    tick.guess_poses[0] = pose
    tick.guess_twists[:] = tick.twists_ref
    return solver.solve(tick)


def same(a: SolveResult, b: SolveResult) -> None:
    assert a.success and b.success and a.iterations == b.iterations
    np.testing.assert_array_equal(a.twists, b.twists)
    np.testing.assert_array_equal(a.poses, b.poses)


@pytest.fixture()
def builds(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """From no derivatives built (the session's are left as they were): whether each IPOPT
    built was given derivatives built before."""
    monkeypatch.setattr(nlp, "_DERIVATIVES", type(nlp._DERIVATIVES)())
    given: list[bool] = []
    build = nlp.ca.nlpsol

    def spy(name: str, plugin: str, problem: dict[str, Any], options: dict[str, Any]) -> Any:
        given.append("hess_lag" in options)
        return build(name, plugin, problem, options)

    monkeypatch.setattr(nlp.ca, "nlpsol", spy)
    return given


def test_one_problem_derives_once_and_solves_as_a_fresh_build(builds: list[bool]) -> None:
    first, second = NlpSolver(model()), NlpSolver(model())
    assert builds == [False, True] and len(nlp._DERIVATIVES) == 1
    shared = solve(second)
    assert shared.success and shared.iterations > 1
    other = solve(first, OFFSET * -0.5)  # another tick between: no state kept between calls
    same(solve(second), shared)
    nlp._DERIVATIVES.clear()
    fresh = NlpSolver(model())
    assert builds[-1] is False
    same(solve(fresh), shared)
    same(solve(fresh, OFFSET * -0.5), other)
    # IPOPT's own options are each solver's: one iteration stops after one
    capped = NlpSolver(model(), max_iter=1)
    assert builds[-1] is True
    result = solve(capped)
    assert result.iterations == 1 and not result.success
    same(solve(fresh), shared)


def test_a_changed_problem_derives_anew(builds: list[bool]) -> None:
    NlpSolver(model())
    for changed in (model(horizon=11), model(dt=0.04),
                    model(weights=Weights(pose=np.array([10.0, 10.0, 1.0]))),
                    model(preset("omni4")), model(preset("omni3")),
                    model(preset("mecanum"), horizon=12)):
        NlpSolver(changed)
    assert builds == [False] * 7
    assert len(nlp._DERIVATIVES) == min(7, nlp._DERIVATIVES_MAX)
    NlpSolver(model(preset("omni3")), tolerance=1e-6, time_limit=5.0)  # options: shared
    assert builds[-1] is True


def test_the_kept_derivatives_are_bounded_least_recently_used_first(
        builds: list[bool], monkeypatch: pytest.MonkeyPatch) -> None:
    NlpSolver(model(horizon=12))
    NlpSolver(model(horizon=11))
    budget = nlp._kept_instructions()  # these two just fit
    monkeypatch.setattr(nlp, "_DERIVATIVES_INSTRUCTIONS", budget)
    for horizon in (12, 10, 11, 12):
        NlpSolver(model(horizon=horizon))
    # 12 again: kept, now the most recent; 10 drops 11; 11 built anew drops 12, so 12 too
    assert builds == [False, False, True, False, False, False]
    assert nlp._kept_instructions() <= budget and list(nlp._DERIVATIVES) != []
    monkeypatch.setattr(nlp, "_DERIVATIVES_MAX", 1)
    NlpSolver(model(horizon=13))
    assert len(nlp._DERIVATIVES) == 1


def test_bounds_stay_each_solvers_own(builds: list[bool]) -> None:
    """A wheel at a fifth of its speed changes only the constraints' bounds: the two solvers
    share the build, and each keeps its own limits."""
    robot = preset("mecanum")
    full, slow_solver = NlpSolver(model(robot)), NlpSolver(model(robot.derated({1: 0.2})))
    assert builds == [False, True]
    fast, slow = solve(full, OFFSET * 2.0), solve(slow_solver, OFFSET * 2.0)
    assert fast.success and slow.success
    slow_limit = 0.2 * robot.max_wheel_speed[1]
    assert np.abs(robot.wheel_speeds(fast.twists)[:, 1]).max() > 1.05 * slow_limit
    assert np.abs(robot.wheel_speeds(slow.twists)[:, 1]).max() <= slow_limit * (1 + 1e-6)


def test_threads_sharing_derivatives_get_their_own_answers(builds: list[bool]) -> None:
    solvers = [NlpSolver(model()) for _ in range(3)]
    assert builds == [False, True, True]
    offsets = [OFFSET * k for k in (1.0, -0.5, 0.25)]
    expected = [solve(solver, offset) for solver, offset in zip(solvers, offsets, strict=True)]
    wrong: list[int] = []

    def work(i: int) -> None:
        for _ in range(3):
            result = solve(solvers[i], offsets[i])
            if not np.array_equal(result.twists, expected[i].twists):
                wrong.append(i)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not wrong
