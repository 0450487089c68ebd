"""Path mode (``Controller(mode="path")``) in closed loop: on the path, as fast as the
wheels allow, never ahead of the reference's own timing.

The yardstick for speed is the time-optimal lap of the same path under the same wheel
limits (``trajectories.time_optimal``, itself checked against an independent method in
test_retiming.py). The plant differs from the controller's model (RK4 of the wheels'
motion at 10 substeps).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from closed_loop import DT, Loop, assert_within_limits, inside_limits

from benchmarks.scenarios import reference
from mpc import Controller, Status
from mpc.robots import preset
from mpc.sim import simulate
from mpc.solvers import SolveResult
from trajectories import time_optimal

#: (layout, shape, heading) at 1.3x the wheel limits; measured lap / max(period,
#: optimal lap) 0.992-1.000 and max path error 0.03-0.9 mm for the Swedish presets.
SCENARIOS = [("mecanum", "circle", "fixed"), ("omni3", "figure8", "tangent"),
             ("omni4", "circle", "tangent"), ("mecanum", "figure8", "fixed")]


@pytest.mark.parametrize(("layout", "shape", "heading"), SCENARIOS)
def test_too_fast_reference_is_driven_at_the_time_optimal_pace_on_the_path(
        layout: str, shape: str, heading: str) -> None:
    robot = preset(layout)
    trajectory = reference(shape, heading, robot, 1.3)
    optimal = time_optimal(trajectory, robot).lap_time
    target = max(trajectory.period or 0.0, optimal)
    result = simulate(Controller(robot, trajectory, mode="path"), 2.0 + 2.3 * target)
    metrics = result.metrics(skip=2.0)
    assert_within_limits(result)
    assert metrics["failures"] == 0
    assert metrics["lap_time"] is not None
    assert 0.98 <= metrics["lap_time"] / target <= 1.02
    assert metrics["max_cross_track_error"] < 2e-3  # [m] on the path
    assert math.degrees(metrics["max_heading_error"]) < 1.0
    progress = result.reference_time
    assert np.all(np.diff(progress) >= 0.0)  # never backwards
    assert np.all(progress <= result.time + 1e-9)  # never ahead of the reference's timing


@pytest.mark.parametrize("solver", ["daqp", "ipopt"])
@pytest.mark.parametrize("trajectory_name", inside_limits().keys())
def test_a_feasible_reference_is_tracked_in_time_as_in_time_mode(
        solver: str, trajectory_name: str) -> None:
    """On a feasible reference, with the robot already moving with it: the progress stays
    on the clock (no lag: the pull on progress holds it at its bound) and the tracking is
    that of time mode on the same stages (both to micrometres; the commands differ by at
    most 2 mm/s, as path mode weighs the error across the path more)."""
    robot, trajectory = preset("mecanum"), inside_limits()[trajectory_name]
    moving = trajectory.body_twist(0.5 * DT)
    commands = {}
    for mode in ("time", "path"):
        controller = Controller(robot, trajectory, solver=solver, mode=mode, stage_dt=DT)
        controller.reset(last_twist=moving)
        loop = Loop(controller, trajectory.sample(0.0).pose)
        loop.last = moving
        commands[mode] = [loop.step() for _ in range(100)]
    assert max(c.lag for c in commands["path"]) < 1e-6  # [s]; measured 4e-8
    np.testing.assert_allclose([c.twist for c in commands["path"]],
                               [c.twist for c in commands["time"]], atol=2e-3)
    for mode in ("time", "path"):
        errors = [np.linalg.norm(c.predicted_poses[0, :2]
                                 - trajectory.sample(k * DT).pose[:2])
                  for k, c in enumerate(commands[mode]) if k >= 40]
        assert max(errors) < 1e-4, mode


def test_it_lags_where_the_reference_is_too_fast_and_catches_up_where_it_is_slow() -> None:
    """A Mecanum figure-eight asking 1.3x the wheel limit at its crossing but slow at its
    ends (optimal lap 8.5 s < period 9.7 s): the robot falls behind at each crossing,
    catches up before the next and so keeps the reference's own lap time."""
    robot = preset("mecanum")
    trajectory = reference("figure8", "fixed", robot, 1.3)
    result = simulate(Controller(robot, trajectory, mode="path"), 2.0 + 2.2 * 9.666)
    lag = result.lag if result.lag is not None else np.zeros(1)
    assert lag.max() > 0.05  # [s] behind at a crossing
    quarter = int(round((trajectory.period or 0.0) / 4 / DT))
    # A quarter lap after each crossing the robot is back on time (crossings every half lap).
    on_time = lag[quarter::2 * quarter]
    assert on_time.size >= 3 and on_time.max() < 1e-3
    metrics = result.metrics(skip=2.0)
    assert metrics["lap_time"] == pytest.approx(trajectory.period, rel=1e-3)
    assert metrics["max_cross_track_error"] < 1e-3


def test_progress_and_fallbacks_under_solver_failures(monkeypatch: pytest.MonkeyPatch) -> None:
    """Path mode keeps the fallback policy and the limits when solves fail (30 %, seeded);
    the progress still never runs backwards or ahead of the clock."""
    robot = preset("mecanum")
    trajectory = reference("figure8", "tangent", robot, 1.3)
    controller = Controller(robot, trajectory, mode="path", horizon=10)
    solve = controller.solver.solve
    rng = np.random.default_rng(8)

    def flaky(tick: object) -> SolveResult:
        result = solve(tick)  # type: ignore[arg-type]
        if rng.uniform() < 0.3:
            return SolveResult(False, "injected", result.poses, result.twists, 0.0, 0)
        return result

    monkeypatch.setattr(controller.solver, "solve", flaky)
    loop = Loop(controller, trajectory.sample(0.0).pose)
    commands = [loop.step() for _ in range(200)]  # Loop checks every limit
    assert {c.status for c in commands} > {Status.SOLVED}
    progress = np.array([c.reference_time for c in commands])
    assert np.all(np.diff(progress) >= -1e-12)
    assert np.all(progress <= DT * np.arange(200) + 1e-9)
