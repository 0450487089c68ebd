"""``mpc-bench export``: a named preset and options written as the C library
``mpc.export_c`` writes for the same controller; the example program it writes, built
with gcc, gives the compiled tick's commands; overwriting needs ``--force``; a robot the
compiled tick does not cover is one line and exit code 2."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from tick_loop import DT, HORIZON

import mpc
import mpc.tick.reuse as reuse
from benchmarks.cli import main
from benchmarks.export import WRITES
from mpc import Controller, Status
from mpc.control.lookahead import Lookahead
from mpc.robots import preset
from mpc.tick.build import casadi_folder
from trajectories import FigureEight


def test_export_writes_the_library_of_the_named_preset(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    out = tmp_path / "omni3"
    assert main(["export", "omni3", "--out", str(out), "--horizon", str(HORIZON), "--dt",
                 str(DT), "--max-iter", "50", "--rebuild-drift", "0.5"]) == 0
    assert str(out) in capsys.readouterr().out
    for name in WRITES:
        assert (out / name).is_file(), name
    config = (out / "mpc_tick_config.h").read_text()
    assert f"#define MPC_N {HORIZON}\n" in config and "#define MPC_W 3\n" in config
    assert f"#define MPC_DT {DT!r}" in config
    # the options reach the example: the budget (no second solve) and the rebuild rule
    assert "mpc_tick_init(50, 1, 0.5)" in (out / "main.c").read_text()
    # the same sources as mpc.export_c of the same controller
    saved = reuse.REBUILD_DRIFT
    reuse.REBUILD_DRIFT = 0.5
    try:
        controller = Controller(preset("omni3"), FigureEight(0.5, 20.0), horizon=HORIZON,
                                dt=DT, max_iter=50, compiled="virtual-machine")
    finally:
        reuse.REBUILD_DRIFT = saved
    expected = mpc.export_c(controller, tmp_path / "direct")
    for name in WRITES:
        assert (out / name).read_bytes() == (expected / name).read_bytes(), name


def test_the_exported_example_gives_the_compiled_ticks_commands(tmp_path: Path) -> None:
    compiler = shutil.which("gcc")
    if compiler is None:
        pytest.skip("no gcc")
    out = tmp_path / "mecanum"
    assert main(["export", "mecanum", "--out", str(out), "--horizon", str(HORIZON),
                 "--dt", str(DT)]) == 0
    casadi = casadi_folder()
    program = tmp_path / "example"
    subprocess.run([compiler, "-O0", *(str(out / name) for name in
                                       ("main.c", "tick.c", "mpc_tick_graphs.c")),
                    f"-I{out}", f"-I{casadi / 'include'}", f"-L{casadi}",
                    "-l:libdaqpstat.a", "-lm", "-o", str(program)],
                   check=True, capture_output=True)
    trajectory = FigureEight(1.0, 8.0, heading="tangent")
    controller = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                            compiled="virtual-machine")
    ahead = Lookahead(trajectory, controller.model.offsets, DT)
    pose = trajectory.sample(0.0).pose + np.array([0.1, -0.05, 0.1])
    lines, commands = [], []
    for k in range(60):
        window, velocities = ahead.window(k * DT)
        lines.append(" ".join(repr(float(value)) for value in
                              np.concatenate([pose, window.ravel(), velocities.ravel()])))
        commands.append(controller.step(pose, k * DT))
        twist = commands[-1].twist
        c, s = np.cos(pose[2]), np.sin(pose[2])
        pose = pose + DT * np.array([c * twist[0] - s * twist[1],
                                     s * twist[0] + c * twist[1], twist[2]])
    done = subprocess.run([str(program)], input="\n".join(lines) + "\n", check=True,
                          capture_output=True, text=True)
    rows = [np.array(line.split(), dtype=float) for line in done.stdout.splitlines()]
    assert len(rows) == len(commands)
    for tick, (row, command) in enumerate(zip(rows, commands, strict=True)):
        assert int(row[0]) == 0 and command.status is Status.SOLVED, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:], command.wheel_speeds, rtol=0, atol=1e-9)


def test_export_refuses_to_overwrite_and_names_what_it_covers(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "lib"
    arguments = ["export", "mecanum", "--out", str(out), "--horizon", str(HORIZON)]
    assert main(arguments) == 0
    capsys.readouterr()
    assert main(arguments) == 2
    assert "--force" in capsys.readouterr().err
    assert main([*arguments, "--force"]) == 0
    capsys.readouterr()
    assert main(["export", "swerve-cable", "--out", str(tmp_path / "swerve-cable"),
                 "--horizon", str(HORIZON)]) == 2
    error = capsys.readouterr().err
    assert ("robot 'swerve-cable'" in error and "steering range" in error
            and "supports " in error)
    assert main(["export", "nonesuch", "--out", str(tmp_path / "x")]) == 2
    assert "unknown robot preset 'nonesuch'" in capsys.readouterr().err


def test_export_writes_path_mode_with_its_three_calls(tmp_path: Path) -> None:
    out = tmp_path / "path"
    assert main(["export", "omni4", "--out", str(out), "--horizon", str(HORIZON), "--dt",
                 str(DT), "--path"]) == 0
    controller = Controller(preset("omni4"), FigureEight(0.5, 20.0), horizon=HORIZON,
                            dt=DT, mode="path", compiled="virtual-machine")
    expected = mpc.export_c(controller, tmp_path / "direct")
    for name in WRITES:
        assert (out / name).read_bytes() == (expected / name).read_bytes(), name
    assert f"#define MPC_PROGRESS {HORIZON + 1}\n" in (out / "mpc_tick_config.h").read_text()
    main_c = (out / "main.c").read_text()
    for call in ("mpc_tick_path_times", "mpc_tick_path_step", "mpc_tick_path_again"):
        assert call in main_c and call in (out / "README.md").read_text(), call
