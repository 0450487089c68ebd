"""``mpc-bench export-check``: the exported library, built with CMake, fed the Python
controller's recorded closed-loop ticks, gives its commands and statuses; a changed
command or status is counted; a preset the compiled tick refuses is one line with the
reason."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.export_check import check, robot_named, robot_names
from benchmarks.exported import Replay, differences
from mpc import Status
from mpc.robots import MOTOR_ROBOT_PRESETS, shipped_presets

pytestmark = pytest.mark.skipif(shutil.which("cmake") is None or shutil.which("gcc") is None,
                                reason="needs cmake and gcc")


def test_the_exported_library_repeats_the_python_controller_beyond_the_limits() -> None:
    item = check("omni3", "time", 1.3, ticks=80, horizon=8, dt=0.05)
    assert item["supported"] and item["ticks"] == 80
    assert item["max_difference"] <= 1e-9 and item["status_mismatches"] == 0
    assert item["hessians_built"] >= 1  # (the first tick builds one)


def test_the_exported_path_library_repeats_the_python_controller() -> None:
    """Path mode: the library asks for the reference where the Python controller sampled
    it (its progress guess and warm-up rounds) and gives its commands."""
    item = check("mecanum", "path", 1.3, ticks=80, horizon=8, dt=0.05)
    assert item["supported"] and item["ticks"] == 80
    assert item["max_difference"] <= 1e-9 and item["status_mismatches"] == 0
    assert item["time_gap"] <= 1e-9 and item["reference_time_difference"] <= 1e-9


def test_the_command_reports_each_preset_or_why_not(capsys: pytest.CaptureFixture[str]
                                                    ) -> None:
    assert main(["export-check", "--layouts", "omni3,swerve", "--modes", "time",
                 "--speeds", "beyond", "--ticks", "30", "--horizon", "8"]) == 0
    out = capsys.readouterr().out
    (omni,) = [line for line in out.splitlines() if line.startswith("omni3 ")]
    words = omni.split()
    assert words[:4] == ["omni3", "time", "beyond", "30"]
    assert float(words[4]) <= 1e-9 and words[5] == "0"
    (swerve,) = [line for line in out.splitlines() if line.startswith("swerve ")]
    if "not supported: " not in swerve:  # (covered once the compiled tick widens)
        assert float(swerve.split()[4]) <= 1e-9 and swerve.split()[5] == "0"


def test_motor_presets_are_named_as_their_files_and_checked() -> None:
    """``LAYOUT-motors`` is the layout's motor preset (its file's name), listed after every
    shipped preset; the library repeats the compiled tick in this process exactly (the same
    graphs and daqp build) and the Python controller to the two daqp releases' tolerance
    (tests/test_compiled_motor_tick.py: 1e-5)."""
    names = robot_names()
    assert names[:len(shipped_presets())] == shipped_presets()
    assert names[len(shipped_presets()):] == tuple(f"{name}-motors"
                                                   for name in MOTOR_ROBOT_PRESETS)
    assert robot_named("mecanum-motors").dynamics is not None
    assert robot_named("mecanum").dynamics is None
    item = check("mecanum-motors", "time", 1.3, ticks=30, horizon=8, dt=0.05)
    assert item["supported"] and item["ticks"] == 30 and item["fallbacks"] == 0
    assert item["compiled_difference"] == 0.0 and item["compiled_status_mismatches"] == 0
    assert item["max_difference"] <= 1e-5 and item["status_mismatches"] == 0


def test_a_refused_motor_preset_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export-check", "--layouts", "swerve-motors", "--modes", "time",
                 "--speeds", "beyond", "--ticks", "5", "--horizon", "8"]) == 0
    (line,) = [line for line in capsys.readouterr().out.splitlines()
               if line.startswith("swerve-motors ")]
    assert "not supported: " in line and "motor model" in line


def test_bad_options_are_one_line_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export-check", "--layouts", "tank"]) == 2
    assert main(["export-check", "--ticks", "0"]) == 2
    err = capsys.readouterr().err
    assert "unknown layout tank" in err and "--ticks must be >= 1" in err


def _replay(twist: np.ndarray, speeds: np.ndarray, status: list[int]) -> Replay:
    count = len(status)
    zeros = np.zeros(count, dtype=int)
    return Replay(status=np.array(status), flag=zeros, iterations=zeros,
                  solve_time=np.zeros(count), failures=zeros, rebuilt=zeros, twist=twist,
                  speeds=speeds, wall=np.zeros((1, count)), cpu=np.zeros((1, count)))


def test_a_changed_command_or_status_is_counted() -> None:
    twist = np.array([[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]])
    speeds = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    statuses = [Status.SOLVED, Status.PREVIOUS_PLAN]
    assert differences(_replay(twist, speeds, [0, 1]), twist, speeds, statuses) == (0.0, 0)
    moved = speeds.copy()
    moved[1, 2] += 2.5e-7
    assert differences(_replay(twist, moved, [0, 3]), twist, speeds, statuses) == (
        pytest.approx(2.5e-7), 1)
    lost = twist.copy()
    lost[0, 0] = math.nan  # NaN on one side only: no agreement
    assert differences(_replay(lost, speeds, [0, 1]), twist, speeds, statuses)[0] == math.inf
