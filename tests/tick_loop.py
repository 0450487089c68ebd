"""Helpers of the compiled tick's tests (imported by test modules; not a test module): the
Python tick with the compiled tick's Hessian-reuse rule (or its Hessian rebuilt every
tick), run in a closed loop on a plant that
differs from the model, and a reference that fails for a second."""

from __future__ import annotations

import math
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import mpc.solvers.dense as dense
import mpc.tick.build
import mpc.tick.reuse as reuse
from benchmarks.export_check import compiled_reuse_rule as same_reuse_rule
from mpc import Command, Controller
from mpc.robots import preset
from trajectories import FigureEight, Trajectory, TrajectoryError

HORIZON = 8  # short: the library compiles in seconds (the benchmark runs N = 20)
TICKS = 240
DT = 0.05




@contextmanager
def hessian_every_tick() -> Iterator[None]:
    """Both ticks with their Hessian rebuilt at once every tick (no reuse): the Python
    tick's, and the compiled ticks built meanwhile."""
    saved = dense.REBUILD_NOW, dense.COST_ONLY_DRIFT, reuse.REBUILD_DRIFT
    dense.REBUILD_NOW, dense.COST_ONLY_DRIFT, reuse.REBUILD_DRIFT = -1.0, -1.0, -1.0
    try:
        yield
    finally:
        dense.REBUILD_NOW, dense.COST_ONLY_DRIFT, reuse.REBUILD_DRIFT = saved


def plant_step(pose: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """A plant that differs from the model: 3 % slip along the body x axis, integrated
    with five Euler substeps (the model integrates SE(2) exactly)."""
    pose = pose.copy()
    vx, vy, omega = twist[0] * 0.97, twist[1], twist[2]
    for _ in range(5):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        pose += DT / 5 * np.array([c * vx - s * vy, s * vx + c * vy, omega])
    return pose


def record(robot_name: str, trajectory: Trajectory, every_tick: bool = False,
           **options: object) -> tuple[list[np.ndarray], list[Command]]:
    """A closed loop of the Python tick (its Hessian kept by the compiled tick's rule,
    :func:`same_reuse_rule`; rebuilt every tick if ``every_tick``): the poses it was given
    and its commands."""
    with hessian_every_tick() if every_tick else same_reuse_rule():
        controller = Controller(preset(robot_name), trajectory, horizon=HORIZON, dt=DT,
                                **options)  # type: ignore[arg-type]
        pose = trajectory.sample(0.0).pose + np.array([0.15, -0.05, 0.2])
        poses, commands = [], []
        for k in range(TICKS):
            command = controller.step(pose, k * DT)
            poses.append(pose)
            commands.append(command)
            pose = plant_step(pose, command.twist)
    return poses, commands



class Broken(FigureEight):
    """A figure-eight that cannot be sampled between 3 and 4 s (a user's reference that
    fails there): ticks whose window reaches into it fall back."""

    def sample(self, t: object) -> object:  # type: ignore[override]
        times = np.asarray(t, dtype=float)
        if np.any((times >= 3.0) & (times < 4.0)):
            raise TrajectoryError("no reference between 3 and 4 s")
        return super().sample(t)  # type: ignore[arg-type]


def cmake_example(source: Path, build: Path) -> Path:
    """The exported library's example program, built with its own ``CMakeLists.txt``."""
    subprocess.run(["cmake", "-S", str(source), "-B", str(build)], check=True,
                   capture_output=True)
    subprocess.run(["cmake", "--build", str(build)], check=True, capture_output=True)
    return build / "mpc_tick_example"


def sanitized_example(source: Path, program: Path) -> Path:
    """The exported example built with AddressSanitizer and UndefinedBehaviorSanitizer (any
    report fatal), or the test skipped where the sanitizer runtime is missing."""
    casadi = Path(mpc.tick.build.casadi_folder())
    built = subprocess.run(
        ["gcc", "-g", "-O0", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
         *(str(source / name) for name in ("main.c", "tick.c", "mpc_tick_graphs.c")),
         f"-I{source}", f"-I{casadi / 'include'}", f"-L{casadi}", "-l:libdaqpstat.a", "-lm",
         "-o", str(program)], capture_output=True, text=True)
    if built.returncode != 0:
        pytest.skip(f"no sanitizer runtime here: {built.stderr.strip()[-200:]}")
    return program


def example_input(poses: list[np.ndarray], windows: list[tuple[np.ndarray, np.ndarray]]
                  ) -> str:
    """The example program's input: a line per tick, the pose, then the reference window's
    poses and velocities (``mpc_tick_step``'s arguments)."""
    return "".join(" ".join(repr(float(value)) for value in
                            np.concatenate([pose, window.ravel(), velocities.ravel()])) + "\n"
                   for pose, (window, velocities) in zip(poses, windows, strict=True))
