"""``mpc.export_c`` in path mode: the exported library, built once with CMake and gcc, asks
for the reference at the Python controller's times (its progress guess and warm-up rounds)
and, fed the samples the Python controller took there, gives its commands, statuses and
reference times (to 1e-9) over recorded closed loops inside and beyond the limits and
through a reference that drops out; clean under the sanitizers; no allocation after
``mpc_tick_init``; cross-built for armhf and aarch64, the same under qemu-user."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_compiled_path import Flaky
from test_export_cross import TARGETS, daqp_source  # noqa: F401 (a fixture)
from test_export_cross import _build as cross_build
from test_export_cross import _run as run_command
from tick_loop import DT, HORIZON, cmake_example, sanitized_example

import mpc
from benchmarks.export_check import compiled_reuse_rule, plant_step
from benchmarks.exported import STATUSES, SampleLog, path_tick_inputs
from mpc import Command, Controller, Status
from mpc.robots import preset
from mpc.tick.build import casadi_folder
from trajectories import FigureEight, Trajectory

pytestmark = pytest.mark.skipif(shutil.which("cmake") is None or shutil.which("gcc") is None,
                                reason="needs cmake and gcc")

TICKS = 300


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The exported path-mode Mecanum controller (its sources) and its example program,
    built with CMake once (the reference is the caller's: every test's runs on it)."""
    folder = tmp_path_factory.mktemp("export-path")
    controller = Controller(preset("mecanum"), FigureEight(1.0, 16.0), horizon=HORIZON,
                            dt=DT, mode="path", compiled="virtual-machine")
    source = mpc.export_c(controller, folder / "src")
    readme = (source / "README.md").read_text()
    assert "mpc_tick_path_times" in readme and "path mode" in readme
    return source, cmake_example(source, folder / "build")


def recorded(trajectory: Trajectory, ticks: int = TICKS
             ) -> tuple[str, list[Command], list[int]]:
    """The Python controller's closed loop in path mode (its Hessian kept by the compiled
    tick's rule) on a plant with slip: the example's input (the samples it took each
    tick), its commands and the samples a tick."""
    log = SampleLog(trajectory)
    with compiled_reuse_rule(path=True):
        controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                                mode="path")
        pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
        times, poses, commands, samples = [], [], [], []
        for k in range(ticks):
            log.take()
            commands.append(controller.step(pose, k * DT))
            times.append(k * DT)
            poses.append(pose)
            samples.append(log.take())
            pose = plant_step(pose, commands[-1].twist, DT)
    return path_tick_inputs(times, poses, samples), commands, [len(s) for s in samples]


def run(program: Path, inputs: str) -> np.ndarray:
    done = subprocess.run([str(program)], input=inputs, check=True, capture_output=True,
                          text=True)
    return np.array([line.split() for line in done.stdout.splitlines()], dtype=float)


@pytest.mark.parametrize("trajectory", [FigureEight(1.0, 16.0, heading="tangent"),
                                        FigureEight(1.0, 6.0, heading="tangent"),
                                        Flaky(1.0, 16.0, heading="tangent")],
                         ids=["inside", "beyond", "reference drops out"])
def test_the_exported_path_library_gives_the_python_commands(
        trajectory: Trajectory, exported: tuple[Path, Path]) -> None:
    inputs, expected, samples = recorded(trajectory)
    rows = run(exported[1], inputs)
    assert rows.shape == (TICKS, 1 + 3 + 4 + 3)
    for tick, (row, command) in enumerate(zip(rows, expected, strict=True)):
        assert STATUSES[int(row[0])] is command.status, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:8], command.wheel_speeds, rtol=0, atol=1e-9)
        assert row[8] == pytest.approx(command.reference_time, abs=1e-9), tick
        assert row[9] <= 1e-9, tick  # the library asked for the recorded times
    assert np.all(np.isfinite(rows))
    statuses = [command.status for command in expected]
    assert max(samples) > 1  # the warm-up's rounds happened (the first tick at least)
    if isinstance(trajectory, Flaky):  # fallbacks, then solved again
        assert {Status.PREVIOUS_PLAN, Status.STOPPING} <= set(statuses)
        assert statuses[-1] is Status.SOLVED
    else:
        assert all(status is Status.SOLVED for status in statuses)


def test_the_exported_path_library_runs_clean_under_the_sanitizers(
        exported: tuple[Path, Path], tmp_path: Path) -> None:
    """main.c, tick.c and the generated graphs with AddressSanitizer and
    UndefinedBehaviorSanitizer (any report fatal): 200 ticks beyond the limits, a
    reference that drops out among them, clean."""
    program = sanitized_example(exported[0], tmp_path / "sanitized")
    inputs, expected, _ = recorded(Flaky(1.0, 6.0, heading="tangent"), 200)
    done = subprocess.run([str(program)], input=inputs, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "runtime error" not in done.stderr
    rows = np.array([line.split() for line in done.stdout.splitlines()], dtype=float)
    assert [STATUSES[int(code)] for code in rows[:, 0]] == [c.status for c in expected]


COUNTING = r"""
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
/* a line at 0.4 m/s, its heading turning at 0.2 rad/s, sampled at the library's times */
static void sample(const double* times, double* poses, double* velocities,
                   double* accelerations) {
  int i;
  for (i = 0; i < MPC_PROGRESS; i++) {
    poses[3 * i] = 0.4 * times[i]; poses[3 * i + 1] = 0.0; poses[3 * i + 2] = 0.2 * times[i];
    velocities[3 * i] = 0.4; velocities[3 * i + 1] = 0.0; velocities[3 * i + 2] = 0.2;
    accelerations[3 * i] = accelerations[3 * i + 1] = accelerations[3 * i + 2] = 0.0;
  }
}
int main(void) {
  double pose[3] = {0.05, -0.02, 0.1}, times[MPC_PROGRESS], poses[3 * MPC_PROGRESS];
  double velocities[3 * MPC_PROGRESS], accelerations[3 * MPC_PROGRESS];
  double last[3] = {0.0, 0.0, 0.0}, out[MPC_OUT_SIZE];
  int k, solved = 0, steps = 0;
  mpc_tick* tick = mpc_tick_init(1000, 0, 1.0);
  if (!tick) return 2;
  mpc_tick_reset(tick, last);
  counting = 1;
  for (k = 0; k < 200; k++) {
    if (k == 100) mpc_tick_reset(tick, last); /* the warm-up again */
    mpc_tick_path_times(tick, 0.05 * k, times);
    sample(times, poses, velocities, accelerations);
    mpc_tick_path_step(tick, pose, poses, velocities, accelerations, out);
    steps++;
    while (mpc_tick_path_again(tick, times)) {
      sample(times, poses, velocities, accelerations);
      mpc_tick_path_step(tick, pose, poses, velocities, accelerations, out);
      steps++;
    }
    solved += out[MPC_OUT_STATUS] == 0.0;
    pose[0] += 0.05 * out[MPC_OUT_TWIST]; pose[2] += 0.05 * out[MPC_OUT_TWIST + 2];
  }
  counting = 0;
  mpc_tick_free(tick);
  printf("%ld %d %d\n", allocations, solved, steps);
  return 0;
}
"""


def test_the_path_calls_allocate_nothing(exported: tuple[Path, Path],
                                         tmp_path: Path) -> None:
    """The exported sources and tick.c built with malloc, calloc and realloc wrapped (daqp's
    static library included): 200 path-mode ticks (the three calls, a reset and its
    warm-up among them) after mpc_tick_init allocate nothing."""
    source = exported[0]
    (tmp_path / "counting.c").write_text(COUNTING)
    casadi = casadi_folder()
    wraps = [f"-Wl,--wrap={name}" for name in ("malloc", "calloc", "realloc")]
    subprocess.run(["gcc", "-O1", str(tmp_path / "counting.c"),
                    str(source / "mpc_tick_graphs.c"), f"-I{source}",
                    f"-I{casadi / 'include'}", f"-L{casadi}", "-l:libdaqpstat.a", "-lm",
                    *wraps, "-o", str(tmp_path / "counting")], check=True, capture_output=True)
    done = subprocess.run([str(tmp_path / "counting")], check=True, capture_output=True,
                          text=True)
    allocations, solved, steps = map(int, done.stdout.split())
    assert allocations == 0
    assert solved == 200
    assert steps > 200  # (warm-up rounds at the start and after the reset)


# armhf only: the roboRIO's class, and the 32-bit target; tests/test_export_cross.py builds
# time mode's library for both targets (one cross build of path mode's added C is enough)
@pytest.mark.parametrize("target", ["armhf"])
def test_the_cross_built_path_library_gives_the_same_commands_under_qemu(
        target: str, exported: tuple[Path, Path], request: pytest.FixtureRequest) -> None:
    """Built for armhf with daqp from its released source (as
    tests/test_export_cross.py builds time mode), statically linked, under qemu-user: the
    Python controller's statuses, commands and reference times to 1e-9 beyond the limits,
    and the recorded times asked for."""
    compiler, qemu, processor = TARGETS[target]
    missing = [tool for tool in (compiler, qemu) if shutil.which(tool) is None]
    if missing:
        pytest.skip(f"{target}: {' and '.join(missing)} not installed")
    daqp: Path = request.getfixturevalue("daqp_source")
    source = exported[0]
    program = cross_build(source, source.parent / target, daqp,
                          "-DCMAKE_SYSTEM_NAME=Linux", f"-DCMAKE_SYSTEM_PROCESSOR={processor}",
                          f"-DCMAKE_C_COMPILER={compiler}", "-DCMAKE_EXE_LINKER_FLAGS=-static")
    inputs, expected, _ = recorded(FigureEight(1.0, 6.0, heading="tangent"), 120)
    rows = run_command([qemu, str(program)], inputs)
    assert rows.shape == (120, 11)
    for tick, (row, command) in enumerate(zip(rows, expected, strict=True)):
        assert STATUSES[int(row[0])] is command.status, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:8], command.wheel_speeds, rtol=0, atol=1e-9)
        assert row[8] == pytest.approx(command.reference_time, abs=1e-9), tick
        assert row[9] <= 1e-9, tick
