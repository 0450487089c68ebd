"""Every script in examples/ runs, writes its figure and prints sensible numbers.

Each is run through its own ``main(argv)`` with a short ``--duration`` into a temporary
folder; the printed summary is read back and held to bounds a working run meets (the
scripts' own numbers, not copies of them). Scripts needing an optional extra are skipped
when it is not installed.
"""

from __future__ import annotations

import re
import runpy
from collections.abc import Callable
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PNG = b"\x89PNG"


def run_example(name: str, args: list[str], out: Path,
                capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``examples/<name>.py`` with ``args`` and ``--out out``; its printed text."""
    main: Callable[[list[str]], None] = runpy.run_path(str(EXAMPLES / f"{name}.py"),
                                                       run_name="example")["main"]
    main([*args, "--out", str(out)])
    text = capsys.readouterr().out
    figure = out / f"{name}.png"
    assert figure.read_bytes()[:4] == PNG, f"{name} wrote no PNG figure"
    assert f"figure: {figure}" in text
    return text


def number(text: str, label: str) -> float:
    """The number printed after ``label:`` (e.g. ``rms position error: 1.6 mm``)."""
    found = re.search(re.escape(label) + r":\s*([-+0-9.eE]+)", text)
    assert found, f"{label!r} not in the output:\n{text}"
    return float(found.group(1))


def test_own_loop(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = run_example("own_loop", ["--duration", "3"], tmp_path, capsys)
    assert 0.0 < number(text, "rms position error") < 20.0        # mm, after 1 s
    assert number(text, "rms heading error") < 2.0                  # deg
    assert 0.5 < number(text, "peak wheel speed") <= 1.0 + 1e-6     # of the limit


def test_choreo_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = run_example("choreo_run", [], tmp_path, capsys)         # the 3 s file + 1 s
    assert "trajectory: s-curve.traj, 3.00 s" in text
    assert 0.0 < number(text, "rms position error") < 30.0
    assert number(text, "final position error") < 20.0              # mm, at rest at its end
    assert 0.2 < number(text, "peak wheel speed") <= 1.0 + 1e-6


def test_ros_bag_round_trip(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("rosbags")
    text = run_example("ros_bag_round_trip", ["--duration", "3", "--bags",
                                              str(tmp_path / "bags")], tmp_path, capsys)
    assert re.search(r"run bag: 8 topics, 60 /odom messages for 60 ticks", text)
    assert number(text, "/odom against the run") < 1e-9            # m: the bag holds the run
    assert 0.0 < number(text, "rms position error") < 100.0
    assert number(text, "peak wheel command") <= 1.0 + 1e-6
    assert (tmp_path / "bags" / "plan_bag").is_dir() and (tmp_path / "bags" / "run_bag").is_dir()


def test_wpilib_loop(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("wpimath")
    text = run_example("wpilib_loop", [], tmp_path, capsys)        # the trajectory + 1 s
    assert 0.0 < number(text, "rms position error") < 10.0
    assert number(text, "final position error") < 10.0
    assert 1.0 < number(text, "fastest module") <= 4.5 + 1e-9       # m/s, within the limit


def test_dask_sweep(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("distributed")
    text = run_example("dask_sweep", ["--runs", "4", "--duration", "2"], tmp_path, capsys)
    assert "ran on: Dask cluster at tcp://127.0.0.1:" in text and "(2 workers)" in text
    rows = [line.split() for line in text.splitlines()   # the summary table's rows
            if line.startswith(("mpc-daqp ", "ff-p-clip ")) and len(line.split()) == 9]
    assert {row[1] for row in rows} >= {"all"} and len(rows) >= 4
    for row in rows:                  # controller kind runs raised fallbk viol ...
        assert row[3] == "0", f"a run raised: {row}"
        if row[0] == "mpc-daqp":
            assert row[5] == "0", f"the MPC commanded beyond a limit: {row}"
    assert sum(int(row[2]) for row in rows if row[1] == "all") == 8  # 4 cases x 2 controllers
    assert re.search(r"tracked better than ff-p-clip in [0-4] of 4 cases", text)


def test_motor_aware(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = run_example("motor_aware", ["--duration", "3"], tmp_path, capsys)
    found = {name: [float(v) for v in re.findall(r"[-+0-9.]+(?=\D|$)", line.split(":", 1)[1])]
             for line in text.splitlines()
             for name in ("motor-aware", "kinematic stand-in") if line.startswith(name + ":")}
    aware, stand_in = found["motor-aware"], found["kinematic stand-in"]   # rms, V, I, slip
    assert aware[1:] == [0.0, 0.0, 0.0]        # within the battery, the current and traction
    assert all(v >= 0.0 for v in stand_in[1:])  # the stand-in's limit events, counted
    assert 0.0 < aware[0] <= 1.05 * stand_in[0]  # mm: knowing the motors costs no tracking
    assert number(text, "largest motor current") > 0.0
