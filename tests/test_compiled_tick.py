"""The compiled tick (:mod:`mpc.tick`): the same commands, plans and statuses as the Python
tick over recorded closed-loop runs, both keeping their Hessian across ticks by the same
rule (:mod:`mpc.tick.reuse`; the Python tick's rebuild at once, not staged: a kept
Hessian moves a real-time-iteration step by far more than rounding, so the rule must be
the same) and both rebuilding it every tick; the reuse tracking as the exact rebuild does;
the virtual machine the same as the compiled library, a missing compiler falling back to
the virtual machine, and the controllers it does not cover refused by name."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from tick_loop import DT, HORIZON, TICKS, Broken, hessian_every_tick, plant_step, record
from toolchain import COMPILED_PATH, needs_cmake

import benchmarks.perf as perf
from benchmarks.cli import main
from mpc import Command, Controller, ControllerError, Status
from mpc.control.lookahead import Lookahead
from mpc.robots import preset
from mpc.tick import UnsupportedTickError
from mpc.tick.build import casadi_folder, write_sources
from mpc.tick.graphs import FEEDFORWARD, PREVIOUS_PLAN, SOLVED, UNPLANNED, build_graphs
from trajectories import FigureEight


def replay(controller: Controller, poses: list[np.ndarray]) -> list[Command]:
    return [controller.step(pose, k * DT) for k, pose in enumerate(poses)]


def assert_same(expected: list[Command], got: list[Command], tolerance: float = 1e-9) -> None:
    """Commands, plans, statuses and failure counts equal tick by tick; ``clamped`` may
    differ only where the clamp moved the twist by rounding (a plan that rides an
    acceleration limit exactly: one side of the rounding clamps, the other not)."""
    for tick, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert a.status is b.status, tick
        assert a.consecutive_failures == b.consecutive_failures, tick
        np.testing.assert_allclose(b.wheel_speeds, a.wheel_speeds, rtol=0, atol=tolerance,
                                   err_msg=f"tick {tick}")
        np.testing.assert_allclose(b.twist, a.twist, rtol=0, atol=tolerance)
        np.testing.assert_allclose(b.predicted_poses, a.predicted_poses, rtol=0,
                                   atol=tolerance)


def assert_safe(robot_name: str, commands: list[Command]) -> None:
    """No NaN, no wheel command beyond its speed limit or its acceleration limit."""
    robot = preset(robot_name)
    last = np.zeros(3)
    for command in commands:
        assert np.all(np.isfinite(command.wheel_speeds))
        assert np.all(np.isfinite(command.predicted_poses))
        assert np.all(np.abs(command.wheel_speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        change = np.abs(robot.wheel_speeds(command.twist - last))
        assert np.all(change <= robot.max_wheel_accel * DT * (1 + 1e-9))
        last = command.twist


SCENARIOS = {
    # name: (robot, figure-eight period [s]): inside the limits, and beyond them
    "mecanum inside": ("mecanum", 16.0),
    "mecanum beyond": ("mecanum", 6.0),
    "omni3 inside": ("omni3", 16.0),
    "omni3 beyond": ("omni3", 6.0),
}


@pytest.mark.parametrize("name", SCENARIOS)
def test_compiled_tick_matches_the_python_tick(name: str) -> None:
    robot_name, period = SCENARIOS[name]
    trajectory = FigureEight(1.0, period, heading="tangent")
    poses, expected = record(robot_name, trajectory)
    compiled = Controller(preset(robot_name), trajectory, horizon=HORIZON, dt=DT,
                          compiled=True)
    assert compiled.tick_path == COMPILED_PATH
    got = replay(compiled, poses)
    assert_same(expected, got)
    assert_safe(robot_name, got)
    clamped = sum(command.clamped for command in expected)
    if "beyond" in name:  # the reference is beyond the wheels: the plan rides the limits
        assert max(float(np.max(np.abs(c.wheel_speeds) / preset(robot_name).max_wheel_speed))
                   for c in got) > 0.99
    else:
        assert clamped <= TICKS // 10


def test_rebuilt_every_tick_matches_the_python_tick_rebuilt_every_tick() -> None:
    """With :data:`~mpc.tick.reuse.REBUILD_DRIFT` below 0 the compiled tick builds its
    Hessian every tick, and gives the Python tick's commands with its Hessian built every
    tick (no reuse on either side)."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    poses, expected = record("omni3", trajectory, every_tick=True)
    for compiled in (True, "virtual-machine"):
        with hessian_every_tick():
            controller = Controller(preset("omni3"), trajectory, horizon=HORIZON, dt=DT,
                                    compiled=compiled)
        got = replay(controller, poses)
        assert_same(expected, got)
        assert controller._compiled is not None
        assert controller._compiled.rebuilds == TICKS


def closed_loop(controller: Controller, trajectory: FigureEight) -> float:
    """RMS position error [m] of ``controller`` in its own closed loop on
    :func:`~tick_loop.plant_step`'s plant (after the first second's settling)."""
    pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
    errors = []
    for k in range(TICKS):
        if k * DT >= 1.0:
            errors.append(float(np.hypot(*(pose[:2] - trajectory.sample(k * DT).pose[:2]))))
        pose = plant_step(pose, controller.step(pose, k * DT).twist)
    return float(np.sqrt(np.mean(np.square(errors))))


@pytest.mark.parametrize("period", [16.0, 6.0], ids=["inside", "beyond"])
def test_a_kept_hessian_tracks_as_the_rebuilt_one(period: float) -> None:
    """The compiled tick keeping its Hessian (the default rule) against itself rebuilding
    it every tick, each in its own closed loop on a plant that differs from the model: the
    RMS position error within 2 % (a kept Hessian shapes only the step, not the fixed
    point of the iteration), with fewer Hessians built."""
    trajectory = FigureEight(1.0, period, heading="tangent")
    kept = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT, compiled=True)
    with hessian_every_tick():
        every = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                           compiled=True)
    error_kept, error_every = closed_loop(kept, trajectory), closed_loop(every, trajectory)
    assert error_kept == pytest.approx(error_every, rel=0.02)
    assert kept._compiled is not None and every._compiled is not None
    assert every._compiled.rebuilds == TICKS
    assert kept._compiled.rebuilds < TICKS * (0.7 if period > 10 else 0.97)


def test_the_virtual_machine_runs_the_same_tick() -> None:
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    poses, _ = record("mecanum", trajectory)
    compiled = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                          compiled=True)
    virtual = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                         compiled="virtual-machine")
    assert (compiled.tick_path, virtual.tick_path) == (COMPILED_PATH, "virtual-machine")
    assert_same(replay(compiled, poses[:120]), replay(virtual, poses[:120]))


def test_no_compiler_falls_back_to_the_virtual_machine(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CC", "/nonexistent/bin/cc")
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    controller = Controller(preset("omni3"), trajectory, horizon=HORIZON, dt=DT,
                            compiled=True)
    assert controller.tick_path == "virtual-machine"
    assert controller._compiled is not None
    assert "/nonexistent/bin/cc" in (controller._compiled.compile_error or "")
    pose = trajectory.sample(0.0).pose
    command = controller.step(pose, 0.0)
    assert command.status is Status.SOLVED and np.all(np.isfinite(command.wheel_speeds))
    assert Controller(preset("omni3"), trajectory, horizon=HORIZON).tick_path == "python"


def test_fallbacks_match_the_python_tick() -> None:
    """A reference that fails for a while: the previous plan, then stopping, then solved
    again; the same statuses and commands on both ticks."""
    trajectory = Broken(1.0, 16.0, heading="tangent")
    poses, expected = record("mecanum", trajectory)
    statuses = {command.status for command in expected}
    assert {Status.SOLVED, Status.PREVIOUS_PLAN, Status.STOPPING} <= statuses
    for compiled in (True, "virtual-machine"):
        controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                                compiled=compiled)
        got = replay(controller, poses)
        assert_same(expected, got)
        assert_safe("mecanum", got)


def test_reset_and_a_new_trajectory_start_over() -> None:
    trajectory = FigureEight(1.0, 16.0, heading="tangent")
    with hessian_every_tick():
        python = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT)
        compiled = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                              compiled=True)
        pose = trajectory.sample(0.0).pose
        for controller in (python, compiled):
            for k in range(5):
                controller.step(pose, k * DT)
            controller.reset(last_twist=[0.2, 0.0, 0.1])
            controller.trajectory = FigureEight(0.8, 12.0, heading=0.0)
        assert_same([python.step(pose, 1.0)], [compiled.step(pose, 1.0)])


@pytest.mark.parametrize("options, named", [
    ({"robot": "swerve-cable"}, "swerve with a steering range"),
    ({"robot": "swerve", "mode": "path"}, "mode='path' on a swerve robot"),
    ({"solver": "osqp"}, "solver='osqp'"),
    ({"delay_ticks": 1}, "delay_ticks=1"),
    ({"time_limit": 0.01}, "time_limit=0.01"),
])
def test_unsupported_controllers_are_refused_by_name(options: dict[str, object],
                                                     named: str) -> None:
    settings = dict(options)
    robot = preset(str(settings.pop("robot", "mecanum")))
    with pytest.raises(UnsupportedTickError, match="supports constant-Jacobian") as error:
        Controller(robot, FigureEight(1.0, 16.0), horizon=HORIZON, compiled=True,
                   **settings)  # type: ignore[arg-type]
    assert named in str(error.value)
    assert isinstance(error.value, ControllerError)


def test_compiled_takes_true_false_or_virtual_machine() -> None:
    with pytest.raises(ControllerError, match="compiled must be"):
        Controller(preset("mecanum"), FigureEight(1.0, 16.0), horizon=HORIZON,
                   compiled="yes")


HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include "tick.c"
static long allocations;
static int counting;
void* __real_malloc(size_t size);
void* __real_calloc(size_t count, size_t size);
void* __real_realloc(void* pointer, size_t size);
void* __wrap_malloc(size_t size) { allocations += counting; return __real_malloc(size); }
void* __wrap_calloc(size_t count, size_t size) {
  allocations += counting; return __real_calloc(count, size);
}
void* __wrap_realloc(void* pointer, size_t size) {
  allocations += counting; return __real_realloc(pointer, size);
}
int main(void) {
  double pose[3] = {0.05, -0.02, 0.1}, poses[3 * (MPC_N + 1)], velocities[3 * (MPC_N + 1)];
  double last[3] = {0.0, 0.0, 0.0}, out[4096];
  int k, i, solved = 0;
  mpc_tick* tick = mpc_tick_init(1000, 0, 1.0);
  if (!tick) return 2;
  mpc_tick_reset(tick, last);
  counting = 1;
  for (k = 0; k < 200; k++) {
    for (i = 0; i <= MPC_N; i++) {  /* a line at 0.4 m/s, turning its heading slowly */
      double t = 0.05 * (k + i);
      poses[3 * i] = 0.4 * t; poses[3 * i + 1] = 0.0; poses[3 * i + 2] = 0.2 * t;
      velocities[3 * i] = 0.4; velocities[3 * i + 1] = 0.0; velocities[3 * i + 2] = 0.2;
    }
    solved += mpc_tick_step(tick, pose, poses, velocities, out) == 0;
    pose[0] += 0.05 * out[6]; pose[2] += 0.05 * out[8];
  }
  counting = 0;
  mpc_tick_free(tick);
  printf("%ld %d\n", allocations, solved);
  return 0;
}
"""


@pytest.mark.parametrize("robot_name", ["mecanum", "swerve"])
def test_the_compiled_step_allocates_nothing(tmp_path: Path, robot_name: str) -> None:
    """The generated sources and tick.c built with malloc, calloc and realloc wrapped (daqp's
    static library included): 200 steps after mpc_tick_init allocate nothing."""
    compiler = shutil.which("gcc")
    if compiler is None:
        pytest.skip("no gcc")
    robot = preset(robot_name)
    controller = Controller(robot, FigureEight(1.0, 16.0), horizon=HORIZON, dt=DT)
    wheels = robot.scalar_wheels or robot.planar_modules
    assert wheels is not None
    sources = write_sources(build_graphs(controller.model, wheels, DT), tmp_path)
    (tmp_path / "harness.c").write_text(HARNESS)
    casadi = casadi_folder()
    wraps = [f"-Wl,--wrap={name}" for name in ("malloc", "calloc", "realloc")]
    subprocess.run([compiler, "-O1", str(tmp_path / "harness.c"), str(sources[0]),
                    f"-I{tmp_path}", f"-I{casadi / 'include'}", f"-L{casadi}",
                    "-l:libdaqpstat.a", "-lm", *wraps, "-o", str(tmp_path / "harness")],
                   check=True, capture_output=True)
    done = subprocess.run([str(tmp_path / "harness")], check=True, capture_output=True,
                          text=True)
    allocations, solved = map(int, done.stdout.split())
    assert allocations == 0
    assert solved == 200


@needs_cmake
def test_perf_shows_the_compiled_tick_beside_the_others(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    """``mpc-bench perf --sections compiled``: rows of the compiled tick, the Python tick,
    the virtual machine, the compiled tick rebuilding its Hessian every tick and the IPOPT
    path on the same ticks, with their ratios; a layout it does not cover (swerve with a
    steering range) says why in one line (at N = 8 here, for a quick build)."""
    monkeypatch.setattr(perf, "REFERENCE_HORIZON", HORIZON)
    assert main(["perf", "--sections", "compiled", "--layouts", "mecanum,swerve-cable",
                 "--modes", "time", "--speeds", "beyond", "--plants", "ideal",
                 "--ipopt-ticks", "20",
                 "--peer-rounds", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert ("swerve-cable time  beyond  not supported: compiled tick: robot 'swerve-cable' "
            "(swerve with a steering range") in out
    rows = [row for row in json.loads((tmp_path / "perf.json").read_text())["rows"]
            if row["section"] == "compiled"]
    assert {row["solver"] for row in rows} == {"compiled", "compiled-rebuild", "python",
                                               "virtual-machine", "ipopt", "exported"}
    by = {row["solver"]: row for row in rows}
    # the rebuild row builds a Hessian every tick, the compiled tick keeps one between
    assert by["compiled-rebuild"]["hessian_builds"] == 20
    assert 0 < by["compiled"]["hessian_builds"] <= 20
    assert by["compiled"]["tick_path"] == "compiled"
    assert by["virtual-machine"]["tick_path"] == "virtual-machine"
    assert by["ipopt"]["ipopt_over_compiled_tick"] == pytest.approx(
        by["ipopt"]["tick_p50"] / by["compiled"]["tick_p50"])
    assert all(row["limit_violations"] == 0 and row["accel_violations"] == 0 for row in rows)
    # the same plan on the same ticks: the compiled tick and its virtual machine agree
    assert by["compiled"]["rms_position_error"] == pytest.approx(
        by["virtual-machine"]["rms_position_error"], rel=1e-9)


def test_an_iteration_budget_gives_the_same_fallbacks() -> None:
    """``max_iter=30`` beyond the limits: the solves that run out of iterations fall back
    (the feedforward: a cold start after a failure, which a budget does not solve again)
    on both ticks alike. (daqp in the casadi wheel and daqp's Python module are different
    versions; with the same rows and warm starts they took the same iterations here.)"""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    poses, expected = record("mecanum", trajectory, max_iter=30)
    assert {Status.SOLVED, Status.FEEDFORWARD} <= {command.status for command in expected}
    for compiled in (True, "virtual-machine"):
        controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                                max_iter=30, compiled=compiled)
        got = replay(controller, poses)
        assert_same(expected, got)
        assert_safe("mecanum", got)


@pytest.mark.parametrize("flag", [1, 2, -1, -2, -3, -4, -5, -6, UNPLANNED])
def test_every_exit_flag_gets_a_status_and_a_safe_twist(flag: int) -> None:
    """``finish`` for each of daqp's exit flags (and a tick with no QP), with and without a
    kept plan: solved only for a positive flag and a finite step, else the fallback in
    :class:`~mpc.control.fallback.FallbackPolicy`'s order; the twist finite and within the
    wheel speed limits either way (a NaN step included)."""
    robot = preset("mecanum")
    controller = Controller(robot, FigureEight(1.0, 16.0), horizon=HORIZON, dt=DT)
    assert robot.scalar_wheels is not None
    graphs = build_graphs(controller.model, robot.scalar_wheels, DT)
    trajectory = FigureEight(1.0, 16.0)
    window = Lookahead(trajectory, controller.model.offsets, DT).window(0.0)
    pose = trajectory.sample(0.0).pose
    last, plan = np.array([0.1, 0.0, 0.0]), np.tile([[0.2], [0.0], [0.1]], (1, HORIZON))
    carry = graphs.prepare(pose, window[0].T, window[1].T, last, plan, 0.0,
                           np.zeros(graphs.terms))[3]
    step = np.full(graphs.variables, 0.01)
    for kept_plan in (0.0, 1.0):
        for values in (step, np.full(graphs.variables, np.nan)):
            out = graphs.finish(values, float(flag), carry, last, plan, [0.0, kept_plan])
            status, twist, speeds = int(out[0]), np.array(out[1]).ravel(), np.array(out[2])
            solved = flag > 0 and np.all(np.isfinite(values))
            expected = SOLVED if solved else (PREVIOUS_PLAN if kept_plan else FEEDFORWARD)
            assert status == expected, (kept_plan, values[0])
            assert np.all(np.isfinite(twist))
            assert np.all(np.abs(speeds) <= robot.max_wheel_speed * (1 + 1e-9))
            assert int(out[6][0]) == (0 if solved else 1)  # failures in a row


def test_the_iteration_cap_bounds_every_tick() -> None:
    """``max_iter=30`` beyond the limits (a budget: no second solve): no tick runs more than
    30 of daqp's iterations; the ticks that run out say so and fall back, within the
    limits; the others solve."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    for compiled in (True, "virtual-machine"):
        controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                                max_iter=30, compiled=compiled)
        pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
        commands = []
        for k in range(TICKS):
            commands.append(controller.step(pose, k * DT))
            pose = plant_step(pose, commands[-1].twist)
        assert max(command.iterations for command in commands) <= 30
        capped = [c for c in commands if c.solver_status == "maximum iterations reached"]
        assert capped and all(c.status is not Status.SOLVED for c in capped)
        assert any(c.status is Status.SOLVED for c in commands)
        assert_safe("mecanum", commands)
