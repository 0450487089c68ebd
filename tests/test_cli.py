"""The ``mpc-bench`` command line: outputs exist and parse, errors are one line."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from benchmarks.cli import main
from benchmarks.scenarios import DEFAULT_CONTROLLERS


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench")
    assert main(["--quick", "--out", str(out)]) == 0
    return out


def test_quick_run_writes_results_and_report(quick_run: Path) -> None:
    document = json.loads((quick_run / "results.json").read_text())
    runs = document["runs"]
    # mecanum x figure8 x fixed heading x {inside, beyond} x every default controller that
    # applies (the setpoint generator is for swerve)
    shown = set(DEFAULT_CONTROLLERS) - {"ff-p-setpoint"}
    assert len(runs) == 2 * len(shown)
    assert {run["controller"] for run in runs} == shown
    assert {run["speed"] for run in runs} == {"inside", "beyond"}
    assert document["meta"]["machine"]["cpu_count"] >= 1
    for run in runs:
        series = run["series"]
        assert len(series["time"]) == len(series["pose"]) == len(series["wheel_command"]) == 60
        assert run["metrics"]["limit_violations"] == 0 or run["controller"].startswith("ff-")
    with (quick_run / "results.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == len(runs)
    for row, run in zip(rows, runs, strict=True):  # the CSV holds the JSON's metrics
        assert row["controller"] == run["controller"]
        assert float(row["rms_position_error"]) == pytest.approx(
            run["metrics"]["rms_position_error"], rel=1e-12)
    index = (quick_run / "report" / "index.html").read_text()
    assert "mecanum-figure8-fixed-beyond-mpc-daqp" in index
    assert (quick_run / "report" / "summary.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_mpc_never_exceeds_a_limit_beyond_the_limits(quick_run: Path) -> None:
    runs = json.loads((quick_run / "results.json").read_text())["runs"]
    for run in runs:
        if run["controller"].startswith("mpc"):
            assert run["metrics"]["max_wheel_speed_ratio"] <= 1.0 + 1e-6


def test_report_subcommand_rebuilds_the_report(quick_run: Path, tmp_path: Path) -> None:
    assert main(["report", str(quick_run / "results.json"), "--out", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again" / "index.html").exists()
    figures = list((tmp_path / "again" / "figures").glob("*.png"))
    assert len(figures) == 2 * (len(DEFAULT_CONTROLLERS) - 1)
    assert not (tmp_path / "again" / "pace.png").exists()  # 3 s runs: no lap to time


def test_polygon_sides_reach_the_swerve_qp(tmp_path: Path) -> None:
    def run(sides: str) -> dict:
        out = tmp_path / sides
        assert main(["--layouts", "swerve", "--trajectories", "circle", "--speeds", "beyond",
                     "--controllers", "mpc-osqp", "--duration", "1.5", "--no-report",
                     "--polygon-sides", sides, "--out", str(out)]) == 0
        return json.loads((out / "results.json").read_text())

    square, fine = run("4"), run("16")
    assert square["meta"]["settings"]["polygon_sides"] == 4
    rms = [doc["runs"][0]["metrics"]["rms_position_error"] for doc in (square, fine)]
    assert rms[0] != pytest.approx(rms[1], rel=1e-3)  # a square plans other commands
    for doc in (square, fine):
        assert doc["runs"][0]["metrics"]["max_wheel_speed_ratio"] <= 1.0 + 1e-6


def test_robot_file_and_csv_trajectory(tmp_path: Path) -> None:
    robot = tmp_path / "robot.toml"
    robot.write_text('type = "omni"\nname = "tri"\nn_wheels = 3\nbase_radius = 0.2\n'
                     "wheel_radius = 0.04\nmax_wheel_speed = 25.0\nmax_wheel_accel = 80.0\n")
    path = tmp_path / "path.csv"
    path.write_text("t,x,y,theta\n0,0,0,0\n2,0.5,0.2,0.3\n4,1.0,0.0,0.0\n")
    out = tmp_path / "out"
    code = main(["--layouts", "mecanum", "--trajectories", "circle", "--speeds", "0.5",
                 "--heading", "fixed", "--controllers", "mpc-osqp,ff-p-desat",
                 "--robot", str(robot),
                 "--trajectory-csv", str(path), "--duration", "2", "--no-report",
                 "--out", str(out)])
    assert code == 0
    runs = json.loads((out / "results.json").read_text())["runs"]
    assert {run["layout"] for run in runs} == {"mecanum", "tri"}
    assert {run["trajectory"] for run in runs} == {"circle", "csv"}
    assert len(runs) == 2 * 2 * 2
    assert not (out / "report").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--layouts", "tank"], "unknown layout tank; valid: omni3, omni4, mecanum, swerve"),
        (["--controllers", "pid"], "unknown controller pid; valid: mpc-daqp, mpc-tuned, mpc-osqp"),
        (["--heading", "sideways"], "unknown heading sideways; valid: fixed, tangent, spin"),
        (["--trajectories", "square"], "unknown trajectory square; valid: circle, figure8"),
        (["--speeds", "fast"], "unknown speed 'fast'"),
        (["--robot", "/no/such/robot.toml", "--quick"],
         "robot file '/no/such/robot.toml' does not exist"),
        (["--trajectory-csv", "/no/such/path.csv", "--quick"], "path.csv"),
        (["report", "/no/such/results.json"], "not found"),
        (["--horizon", "0"], "--horizon must be >= 1"),
        (["--polygon-sides", "5"], "--polygon-sides must be an even integer >= 4, got 5"),
        (["--bogus"], "unrecognized arguments: --bogus"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(argv: list[str], message: str,
                                               capsys: pytest.CaptureFixture[str],
                                               tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_info:
        code = main([*argv, "--out", str(tmp_path)] if argv[0] != "report" else argv)
        raise SystemExit(code)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_perf_and_soak_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["perf", "--sections", "horizons", "--horizons", "5,10", "--ticks", "40",
                 "--ipopt-ticks", "20",
                 "--out", str(tmp_path)]) == 0
    perf = json.loads((tmp_path / "perf.json").read_text())
    assert {row["horizon"] for row in perf["rows"] if row["solver"] == "osqp"} == {5, 10}
    assert all(row["tick_p50"] >= row["solve_p50"] > 0 for row in perf["rows"])
    assert main(["soak", "--ticks", "200", "--blocks", "2"]) == 0
    assert "memory growth" in capsys.readouterr().out
