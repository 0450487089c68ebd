"""``mpc.export_c``: the exported C library, built with CMake and gcc, gives the Python
tick's commands and statuses (its Hessian kept by the compiled tick's rule)
over recorded closed-loop ticks, inside and beyond the limits and through a reference
that fails for a second."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from tick_loop import (
    DT,
    HORIZON,
    Broken,
    cmake_example,
    example_input,
    record,
    sanitized_example,
)

import mpc
import mpc.tick.build
from mpc import Controller, ControllerError, Status
from mpc.control.lookahead import Lookahead
from mpc.robots import preset
from trajectories import FigureEight, Trajectory, TrajectoryError

pytestmark = pytest.mark.skipif(shutil.which("cmake") is None or shutil.which("gcc") is None,
                                reason="needs cmake and gcc")


@pytest.fixture(scope="module")
def program(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The exported Mecanum controller's example program, built with CMake (once: the
    reference is the caller's, so every test's trajectory runs on it)."""
    folder = tmp_path_factory.mktemp("export")
    controller = Controller(preset("mecanum"), FigureEight(1.0, 16.0), horizon=HORIZON,
                            dt=DT, compiled="virtual-machine")
    source = mpc.export_c(controller, folder / "src")
    for name in ("mpc_tick.h", "mpc_tick_graphs.c", "tick.c", "CMakeLists.txt", "README.md",
                 "main.c"):
        assert (source / name).is_file(), name
    return cmake_example(source, folder / "build")


def _windows(trajectory: Trajectory, ticks: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The reference at each tick's stage times, as the controller samples it (NaN where
    the trajectory cannot be sampled)."""
    controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT)
    ahead = Lookahead(trajectory, controller.model.offsets, DT)
    windows = []
    for k in range(ticks):
        try:
            windows.append(ahead.window(k * DT))
        except TrajectoryError:
            nan = np.full((HORIZON + 1, 3), np.nan)
            windows.append((nan, nan))
    return windows


@pytest.mark.parametrize("trajectory", [FigureEight(1.0, 6.0, heading="tangent"),
                                        Broken(1.0, 16.0, heading="tangent")],
                         ids=["beyond", "reference fails"])
def test_the_exported_library_gives_the_python_commands(trajectory: Trajectory,
                                                         program: Path) -> None:
    poses, expected = record("mecanum", trajectory)
    done = subprocess.run([str(program)],
                          input=example_input(poses, _windows(trajectory, len(poses))),
                          check=True, capture_output=True, text=True)
    rows = [np.array(line.split(), dtype=float) for line in done.stdout.splitlines()]
    assert len(rows) == len(expected)
    statuses = (Status.SOLVED, Status.PREVIOUS_PLAN, Status.FEEDFORWARD, Status.STOPPING)
    for tick, (row, command) in enumerate(zip(rows, expected, strict=True)):
        assert statuses[int(row[0])] is command.status, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:], command.wheel_speeds, rtol=0, atol=1e-9)
    assert np.all(np.isfinite(np.array(rows)))


def test_export_needs_the_compiled_tick(tmp_path: Path) -> None:
    controller = Controller(preset("mecanum"), FigureEight(1.0, 16.0), horizon=HORIZON)
    with pytest.raises(ControllerError, match="compiled=True"):
        mpc.export_c(controller, tmp_path)


def test_the_exported_library_runs_clean_under_the_sanitizers(tmp_path: Path) -> None:
    """main.c, tick.c and the generated graphs built with AddressSanitizer and
    UndefinedBehaviorSanitizer (any report fatal) run 200 ticks beyond the limits clean."""
    trajectory = FigureEight(1.0, 6.0, heading="tangent")
    controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                            compiled="virtual-machine")
    source = mpc.export_c(controller, tmp_path / "src")
    program = sanitized_example(source, tmp_path / "sanitized")
    windows = _windows(trajectory, 200)
    pose = trajectory.sample(0.0).pose + np.array([0.1, 0.0, 0.1])
    done = subprocess.run([str(program)], input=example_input([pose] * len(windows), windows),
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "runtime error" not in done.stderr and len(done.stdout.splitlines()) == 200
