"""The compiled tick in path mode (:mod:`mpc.tick.path`): the Python tick's commands, plans,
statuses and progress over recorded closed loops, inside and beyond the limits and through
a reference that fails for a second; the virtual machine the same; safe commands; issue
9's path-mode lines on one scenario.

The compiled path tick keeps its Hessian by the Python tick's measure (the cost values'
drift beside the sensitivities'), rebuilt whole: it is compared with the Python tick under
the same rule (:func:`path_reuse_rule`: rebuilt at once, never staged, never with the last
build's sensitivities) and with both rebuilding every tick, and separately, in its own
closed loop, against the Python tick as it runs by default.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext

import numpy as np
import pytest
from closed_loop import assert_within_limits
from test_compiled_tick import assert_safe, assert_same, replay
from tick_loop import (
    DT,
    HORIZON,
    TICKS,
    hessian_every_tick,
    plant_step,
    record,
    same_reuse_rule,
)
from toolchain import COMPILED_PATH

import mpc.solvers.dense as dense
from benchmarks.scenarios import reference
from mpc import Command, Controller, Status
from mpc.robots import preset
from mpc.sim import simulate
from trajectories import FigureEight, TrajectoryError, time_optimal


def assert_same_progress(expected: list[Command], got: list[Command]) -> None:
    """The reference time tracked (the progress) and the lag equal tick by tick."""
    for tick, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert b.reference_time == pytest.approx(a.reference_time, abs=1e-9), tick
        assert b.lag == pytest.approx(a.lag, abs=1e-9), tick


@contextmanager
def path_reuse_rule() -> Iterator[None]:
    """The Python tick rebuilding its Hessian at once, whole, when the cost values or the
    sensitivities drifted beyond :data:`~mpc.tick.reuse.REBUILD_DRIFT`: the compiled tick's
    rule (:func:`~tick_loop.same_reuse_rule`, and no rebuild that keeps the last build's
    sensitivities)."""
    saved = dense.COST_ONLY_DRIFT
    dense.COST_ONLY_DRIFT = -1.0
    try:
        with same_reuse_rule():
            yield
    finally:
        dense.COST_ONLY_DRIFT = saved


def recorded(robot_name: str, trajectory: FigureEight, every_tick: bool
             ) -> tuple[list[np.ndarray], list[Command]]:
    """The Python tick's closed loop in path mode under the compiled tick's rule."""
    if every_tick:
        return record(robot_name, trajectory, every_tick=True, mode="path")
    with path_reuse_rule():
        return record(robot_name, trajectory, mode="path")


def compiled_loop(robot_name: str, trajectory: FigureEight, compiled: bool | str,
                  every_tick: bool = False) -> Controller:
    with hessian_every_tick() if every_tick else nullcontext():
        return Controller(preset(robot_name), trajectory, horizon=HORIZON, dt=DT,
                          mode="path", compiled=compiled)


def own_loop(controller: Controller, trajectory: FigureEight) -> list[Command]:
    """``controller`` in its own closed loop on :func:`~tick_loop.plant_step`'s plant."""
    pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
    commands = []
    for k in range(TICKS):
        commands.append(controller.step(pose, k * DT))
        pose = plant_step(pose, commands[-1].twist)
    return commands


@pytest.mark.parametrize("robot_name, period, compiled, every_tick", [
    ("mecanum", 16.0, True, False),
    ("mecanum", 6.0, True, False),
    ("mecanum", 6.0, True, True),
    ("mecanum", 6.0, "virtual-machine", False),
    ("omni3", 6.0, "virtual-machine", False),
    ("omni3", 16.0, "virtual-machine", True),
], ids=["mecanum-inside", "mecanum-beyond", "mecanum-beyond-every-tick", "mecanum-beyond-vm",
        "omni3-beyond-vm", "omni3-inside-vm-every-tick"])
def test_the_path_tick_matches_the_python_tick(robot_name: str, period: float,
                                               compiled: bool | str, every_tick: bool
                                               ) -> None:
    trajectory = FigureEight(1.0, period, heading="tangent")
    poses, expected = recorded(robot_name, trajectory, every_tick)
    controller = compiled_loop(robot_name, trajectory, compiled, every_tick)
    assert controller.tick_path == (COMPILED_PATH if compiled is True else "virtual-machine")
    got = replay(controller, poses)
    assert_same(expected, got)
    assert_same_progress(expected, got)
    assert_safe(robot_name, got)
    assert all(command.status is Status.SOLVED for command in got)
    lags = [command.lag for command in got]
    if period < 10.0:  # beyond the wheels: the progress falls behind the clock and the
        # plan rides the limits
        assert max(lags) > 0.1
        assert max(float(np.max(np.abs(c.wheel_speeds) / preset(robot_name).max_wheel_speed))
                   for c in got) > 0.99
    progress = [command.reference_time for command in got]
    assert np.all(np.diff(progress) >= -1e-12)  # never backwards
    assert np.all(np.asarray(progress) <= DT * np.arange(TICKS) + 1e-9)  # never ahead
    assert controller._compiled is not None
    if every_tick:
        assert controller._compiled.rebuilds >= TICKS
    else:  # (the warm-up's rounds rebuild too)
        assert 0 < controller._compiled.rebuilds < TICKS


class Flaky(FigureEight):
    """A figure-eight whose sampling fails on its 60th to 79th call (a reference source
    that drops out for a while; in reference time a hole, such as
    :class:`~tick_loop.Broken`'s, would stop path mode for good: the progress cannot pass
    it)."""

    calls = 0

    def sample(self, t: object) -> object:  # type: ignore[override]
        self.calls += 1
        if 60 <= self.calls < 80:
            raise TrajectoryError("the reference source dropped out")
        return super().sample(t)  # type: ignore[arg-type]


def test_fallbacks_in_path_mode_match_the_python_tick() -> None:
    """A reference that fails for a while: the same fallbacks, commands and progress, then
    the warm-up's rounds again when it is back."""
    python, compiled = Flaky(1.0, 16.0, heading="tangent"), Flaky(1.0, 16.0,
                                                                  heading="tangent")
    poses, expected = recorded("mecanum", python, every_tick=False)
    statuses = [command.status for command in expected]
    assert {Status.PREVIOUS_PLAN, Status.STOPPING} <= set(statuses)
    assert statuses[-1] is Status.SOLVED
    compiled.sample(0.0)  # (record sampled the start pose)
    got = replay(compiled_loop("mecanum", compiled, True), poses)
    assert_same(expected, got)
    assert_same_progress(expected, got)
    assert_safe("mecanum", got)


def test_the_path_tick_tracks_as_the_python_tick_with_its_shortcuts() -> None:
    """Each in its own closed loop (the Python tick as it runs by default: its rebuild
    staged over four ticks, or with the last build's sensitivities where only the cost
    moved): the same path error to 10 % and the same progress to a tick."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    python = own_loop(Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                                 mode="path"), trajectory)
    compiled = own_loop(compiled_loop("mecanum", trajectory, True), trajectory)

    def path_error(commands: list[Command]) -> float:
        return float(np.sqrt(np.mean([
            np.sum((c.predicted_poses[0, :2] - trajectory.sample(c.reference_time).pose[:2])
                   ** 2) for c in commands[20:]])))

    assert path_error(compiled) == pytest.approx(path_error(python), rel=0.1, abs=1e-4)
    assert abs(compiled[-1].reference_time - python[-1].reference_time) < DT


def test_issue_9_lines_on_the_virtual_machine() -> None:
    """Issue 9's lines (lap <= 1.05x max(period, the time-optimal lap), path error <= 10
    mm, heading <= 1 deg, no violation) at horizon 20 on the default plant, the Mecanum
    circle at 1.3x the wheel limits, fixed heading: the virtual machine (the same graphs as
    the compiled library, tested equal above; no N = 20 build in the test)."""
    robot = preset("mecanum")
    trajectory = reference("circle", "fixed", robot, 1.3)
    target = max(trajectory.period or 0.0, time_optimal(trajectory, robot).lap_time)
    controller = Controller(robot, trajectory, mode="path", compiled="virtual-machine")
    assert controller.horizon == 20
    result = simulate(controller, 2.0 + 2.3 * target)
    metrics = result.metrics(skip=2.0)
    assert_within_limits(result)
    assert metrics["failures"] == 0
    assert metrics["lap_time"] is not None
    assert metrics["lap_time"] / target <= 1.05
    assert metrics["max_cross_track_error"] <= 10e-3
    assert math.degrees(metrics["max_heading_error"]) <= 1.0


def test_a_new_trajectory_and_a_reset_start_the_progress_over() -> None:
    """The progress state (``tick.c``'s, and the virtual machine's ``VirtualPath``) is
    forgotten with the plan: a new trajectory mid-run and a reset give the Python tick's
    commands, progress and warm-up again."""
    first, second = FigureEight(1.0, 16.0, heading="tangent"), FigureEight(0.8, 6.0)

    def run(controller: Controller, poses: list[np.ndarray] | None) -> tuple[
            list[np.ndarray], list[Command]]:
        pose = first.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
        seen: list[np.ndarray] = []
        commands: list[Command] = []
        for k in range(120):
            if k == 40:
                controller.trajectory = second
            if k == 80:
                controller.reset(commands[-1].twist)
            if poses is not None:
                pose = poses[k]
            seen.append(pose)
            commands.append(controller.step(pose, k * DT))
            pose = plant_step(pose, commands[-1].twist)
        return seen, commands

    with path_reuse_rule():
        poses, expected = run(Controller(preset("mecanum"), first, horizon=HORIZON, dt=DT,
                                         mode="path"), None)
    _, got = run(compiled_loop("mecanum", first, "virtual-machine"), poses)
    assert_same(expected, got)
    assert_same_progress(expected, got)
    assert got[40].reference_time == pytest.approx(40 * DT)  # on time after the switch
