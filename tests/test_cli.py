"""The ``mpc-bench`` command line: outputs exist and parse, errors are one line."""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mpc.plot.writer
from benchmarks.cli import COMMANDS, command_parser, main
from benchmarks.runner import summary_table
from benchmarks.scenarios import DEFAULT_CONTROLLERS
from trajectories import read_choreo


def _runs_not_drawn(patch: pytest.MonkeyPatch) -> None:
    """Each run's own figure left undrawn (progress still counted), here and on the report's
    worker processes: these tests read the results, the page and the summary figures;
    test_report_subcommand_rebuilds_the_report draws the quick run's figures."""
    patch.setattr(mpc.plot.writer, "_draw_runs",
                  lambda jobs, workers, tick: [tick() for _ in jobs])


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench")
    with pytest.MonkeyPatch.context() as patch:
        _runs_not_drawn(patch)
        assert main(["--quick", "--out", str(out)]) == 0
    return out


def test_quick_run_writes_results_and_report(quick_run: Path) -> None:
    document = json.loads((quick_run / "results.json").read_text())
    runs = document["runs"]
    # {mecanum, swerve} x figure8 x fixed heading x beyond x every default controller but
    # mpc-ipopt that applies (the setpoint generator is for swerve)
    shown = set(DEFAULT_CONTROLLERS) - {"mpc-ipopt"}
    assert len(runs) == 2 * len(shown) - 1
    assert {run["controller"] for run in runs} == shown
    assert {(run["layout"], run["speed"]) for run in runs} == {("mecanum", "beyond"),
                                                               ("swerve", "beyond")}
    assert document["meta"]["machine"]["cpu_count"] >= 1
    eta = json.loads((quick_run / "eta.json").read_text())  # the run's ETAs, to check them
    assert eta["log"] and all(later[0] >= earlier[0] for earlier, later in
                              zip(eta["log"], eta["log"][1:], strict=False))
    assert eta["log"][-1][0] <= eta["wall_s"] and set(eta["errors"]) <= {"0.1", "0.5", "0.9"}
    for run in runs:
        series = run["series"]
        assert len(series["time"]) == len(series["pose"]) == len(series["wheel_command"]) == 120
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


def test_quick_shows_mpc_ahead_of_every_baseline(quick_run: Path) -> None:
    runs = json.loads((quick_run / "results.json").read_text())["runs"]
    for layout in ("mecanum", "swerve"):
        errors = {run["controller"]: run["metrics"]["rms_position_error"] for run in runs
                  if run["layout"] == layout}
        best_baseline = min(v for k, v in errors.items() if k.startswith("ff-"))
        assert errors["mpc-daqp"] < 0.8 * best_baseline, errors


def test_mpc_never_exceeds_a_limit_beyond_the_limits(quick_run: Path) -> None:
    runs = json.loads((quick_run / "results.json").read_text())["runs"]
    for run in runs:
        if run["controller"].startswith("mpc"):
            assert run["metrics"]["max_wheel_speed_ratio"] <= 1.0 + 1e-6


def test_report_subcommand_rebuilds_the_report(quick_run: Path, tmp_path: Path) -> None:
    # the quick run's results.json with its mpc-daqp runs only (one per layout): a figure
    # per run drawn either way, without drawing all of them again
    document = json.loads((quick_run / "results.json").read_text())
    document["runs"] = [run for run in document["runs"] if run["controller"] == "mpc-daqp"]
    assert len(document["runs"]) == 2
    results = tmp_path / "results.json"
    results.write_text(json.dumps(document))
    assert main(["report", str(results), "--out", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again" / "index.html").exists()
    figures = list((tmp_path / "again" / "figures").glob("*.png"))
    assert len(figures) == len(document["runs"])


def test_polygon_sides_reach_the_swerve_qp(tmp_path: Path) -> None:
    def run(sides: str) -> dict:
        out = tmp_path / sides
        # in this process: two 1.5 s runs take less than starting worker processes
        assert main(["--layouts", "swerve", "--trajectories", "circle", "--speeds", "beyond",
                     "--controllers", "mpc-osqp", "--duration", "1.5", "--no-report",
                     "--workers", "1", "--polygon-sides", sides, "--out", str(out)]) == 0
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
                 "--headings", "fixed", "--controllers", "mpc-osqp,ff-p-desat",
                 "--robot", str(robot),
                 "--trajectory-csv", str(path), "--duration", "2", "--no-report",
                 "--out", str(out)])
    assert code == 0
    runs = json.loads((out / "results.json").read_text())["runs"]
    assert {run["layout"] for run in runs} == {"mecanum", "tri"}
    assert {run["trajectory"] for run in runs} == {"circle", "csv"}
    assert len(runs) == 2 * 2 * 2
    assert not (out / "report").exists()


DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--layouts", "tank"],
         "--layouts: unknown layout tank; valid: omni3, omni4, mecanum, swerve"),
        (["--controllers", "pid"],
         "--controllers: unknown controller pid; valid: mpc-daqp, mpc-tuned, mpc-osqp"),
        (["--headings", "sideways"],
         "--headings: unknown heading sideways; valid: fixed, tangent, spin"),
        (["--trajectories", "square"],
         "--trajectories: unknown trajectory square; valid: circle, figure8"),
        (["--speeds", "fast"], "--speeds: unknown speed 'fast'"),
        (["--robot", "/no/such/robot.toml", "--quick"],
         "robot file '/no/such/robot.toml' does not exist"),
        (["--trajectory-csv", "/no/such/path.csv", "--quick"], "path.csv"),
        (["report", "/no/such/results.json"], "does not exist"),
        (["--horizon", "0"], "--horizon must be 1 to 1000 ticks, got 0"),
        (["--horizon", "1000000"], "--horizon must be 1 to 1000 ticks, got 1000000"),
        (["--polygon-sides", "5"], "--polygon-sides must be an even integer 4 to 256, got 5"),
        (["--polygon-sides", "200000"], "--polygon-sides must be an even integer 4 to 256"),
        (["--bogus"], "unrecognized arguments: --bogus"),
        (["--control", "ff-p-clip"], "unrecognized arguments: --control ff-p-clip (did you "
                                      "mean --controllers?)"),  # no prefixes
        (["--trajectory", "/no/such/path.traj"], "'/no/such/path.traj'"),
        (["--trajectory", "/no/such/auto.json"],
         "trajectory file '/no/such/auto.json': expected a Choreo .traj or a waypoint .csv"),
        (["prf"], "unknown command 'prf' (did you mean perf?); commands: run, report, perf"),
        (["--skip", "-1", "--quick"], "--skip must be a finite number >= 0 [s], got -1.0"),
        (["--quick", "--duration", "0"], "--duration must be > 0 and at most"),
        (["--duration", "1e12"], "--duration must be > 0 and at most 250000 s"),
        (["--layouts", "", "--quick"], "--layouts: unknown layout "),
        (["--seed", "-1"], "--seed: expected an integer from 0 to 4294967295, got '-1'"),
        (["sweep", "--seed", "-1"], "--seed: expected an integer from 0 to 4294967295"),
        (["tune", "--seed", "4294967296"], "--seed: expected an integer from 0 to 4294967295"),
        (["--speeds", "1e308"], "--speeds: a peak ratio must be a number > 0 and at most 10"),
        (["--dt", "0"], "--dt must be a number > 0 and at most 60 [s], got 0.0"),
        (["--dt", "inf"], "--dt must be a number > 0 and at most 60 [s], got inf"),
        (["--dt", "100"], "--dt must be a number > 0 and at most 60 [s], got 100.0"),
        (["--horizon", "400", "--quick"], "--horizon 400: mpc-daqp on "
                                          "robot 'mecanum': horizon must be at most 300"),
        (["--layouts", "swerve", "--horizon", "250", "--polygon-sides", "256"],
         "--horizon 250 (--polygon-sides 256): mpc-daqp on robot 'swerve': horizon 250 x 512"),
        (["tune", "--robot", "nope", "--trials", "2", "--workers", "1"],
         "--robot: unknown robot preset 'nope'"),
        (["sweep", "--runs", "1", "--kinds", "hover"], "--kinds: unknown robot kind hover"),
        (["--layouts", "caster4", "--controllers", "mpc-tuned", "--quick"],
         "no run: mpc-tuned on caster4 do(es) not apply"),
        (["--trajectory", str(DATA / "minimal.traj"), "--speeds", "beyond"],
         "--speeds apply to the built-in shapes"),
        (["--trajectory", str(DATA / "minimal.traj"), "--layouts", "mecanum"],
         "--layouts apply to the built-in shapes"),
        (["--plant", "motor", "--robot", str(DATA.parent.parent / "mpc" / "robots" / "description"
                                               / "presets" / "omni3.toml"), "--layouts", "mecanum",
          "--quick"], "--plant motor drives robots through their motor models"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(argv: list[str], message: str,
                                               capsys: pytest.CaptureFixture[str],
                                               tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_info:
        code = main([*argv, "--out", str(tmp_path)] if argv[0] not in ("report", "prf")
                    else argv)
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


def test_help_lists_every_command_with_a_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: mpc-bench [COMMAND] [options]")
    for name in COMMANDS:
        assert re.search(rf"^ {{4}}{name} +\w", out, re.MULTILINE), name
    assert "--layouts" in out and "--trajectory FILE" in out and "--force" in out
    for name in COMMANDS:  # each command's own help, named after it
        with pytest.raises(SystemExit) as exit_info:
            main([name, "--help"])
        assert exit_info.value.code == 0
        assert capsys.readouterr().out.startswith(f"usage: mpc-bench {name} ")


def test_every_command_and_option_is_in_the_tree() -> None:
    tree = command_parser()
    choices = next(action.choices for action in tree._actions
                   if isinstance(action, argparse._SubParsersAction))
    assert list(choices) == list(COMMANDS)
    for name, parser in choices.items():
        assert not parser.allow_abbrev, name
    options = {option for action in choices["perf"]._actions for option in action.option_strings}
    assert {"--sections", "--out", "--force"} <= options
    with pytest.raises(SystemExit):  # a subcommand's options take no prefix either
        main(["perf", "--sect", "horizons"])


def test_shell_completion_offers_commands_and_options(tmp_path: Path) -> None:
    pytest.importorskip("argcomplete")

    def complete(line: str) -> set[str]:
        # what the shell hook does: the entry point with argcomplete's variables set, the
        # completions read from file descriptor 8 (in a process of its own: argcomplete
        # takes over descriptors 8 and 9)
        out = tmp_path / "completions"
        env = {**os.environ, "_ARGCOMPLETE": "1", "COMP_LINE": line,
               "COMP_POINT": str(len(line)), "_ARGCOMPLETE_IFS": "\n"}
        subprocess.run(f"{shlex.quote(sys.executable)} -m benchmarks 8>{shlex.quote(str(out))} "
                       "9>/dev/null", shell=True, env=env, check=True, timeout=60)
        return {word.strip() for word in out.read_text().splitlines()}

    assert set(COMMANDS) <= complete("mpc-bench ")
    assert complete("mpc-bench --lay") == {"--layouts"}
    assert complete("mpc-bench perf --sec") == {"--sections"}


def test_a_second_run_into_the_same_folder_is_refused(quick_run: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    before = (quick_run / "results.json").read_bytes()
    assert main(["--quick", "--out", str(quick_run)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"--out {str(quick_run)!r} already holds results (results.json" in err
    assert "--force" in err
    assert (quick_run / "results.json").read_bytes() == before


def test_force_overwrites(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _runs_not_drawn(monkeypatch)
    def run(*extra: str) -> int:
        return main(["--layouts", "omni3", "--trajectories", "circle", "--speeds", "inside",
                     "--headings", "fixed", "--controllers", "ff-p-clip", "--duration", "1",
                     "--no-report", "--workers", "1", "--out", str(tmp_path), *extra])

    assert run("--seed", "1") == 0
    assert run("--seed", "2") == 2
    assert json.loads((tmp_path / "results.json").read_text())["meta"]["settings"]["seed"] == 1
    assert run("--seed", "2", "--force") == 0
    assert json.loads((tmp_path / "results.json").read_text())["meta"]["settings"]["seed"] == 2
    (tmp_path / "perf.json").write_text("{}")  # another command's results do not count
    assert main(["report", str(tmp_path / "results.json"), "--out", str(tmp_path / "r")]) == 0
    assert main(["report", str(tmp_path / "results.json"), "--out", str(tmp_path / "r")]) == 2
    assert main(["report", str(tmp_path / "results.json"), "--out", str(tmp_path / "r"),
                 "--force"]) == 0
    for _ in range(2):  # the report beside its results: derived from them, rebuilt in place
        assert main(["report", str(tmp_path / "results.json")]) == 0
    assert (tmp_path / "report" / "index.html").exists()


@pytest.mark.parametrize(
    ("argv", "held"),
    [
        (["perf", "--quick"], "perf.json"),
        (["motors", "--layouts", "omni3"], "motors.json"),
        (["motors", "--perf"], "motors-perf.json"),
        (["fuzz", "--ticks", "100"], "fuzz.json"),
        (["tune", "--trials", "2"], "study.json"),
        (["sweep", "--runs", "1"], "sweep.json"),
    ],
)
def test_every_command_that_writes_refuses_its_own_results(
        argv: list[str], held: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / held).write_text("earlier")
    started = time.perf_counter()
    assert main([*argv, "--out", str(tmp_path)]) == 2
    assert time.perf_counter() - started < 2.0  # refused before any work
    err = capsys.readouterr().err
    assert f"already holds results ({held})" in err and "--force" in err
    assert (tmp_path / held).read_text() == "earlier"


def test_summary_columns_line_up_with_long_names(quick_run: Path) -> None:
    runs = json.loads((quick_run / "results.json").read_text())["runs"]
    runs[0]["controller"] = "a-controller-with-a-very-long-name"
    runs[1]["layout"] = "a-long-robot-name"
    lines = summary_table(runs).splitlines()
    # every row's "rms pos" column ends where its title ends
    end = lines[0].index("rms pos") + len("rms pos")
    for line in lines[3:]:
        cells = line[:end].split()
        assert line[end] == " " and re.fullmatch(r"[-+.e\d]+", cells[-1]), line


CHOREO_CONFIG = {"frontLeft": {"x": 0.3, "y": 0.25}, "backLeft": {"x": -0.28, "y": 0.27},
                 "mass": 60.0, "inertia": 6.0, "gearing": 6.5, "radius": 0.05, "vmax": 600.0,
                 "tmax": 1.2, "cof": 1.5}


def choreo_file(folder: Path, name: str = "lane-change", **changes: Any) -> Path:
    """A Choreo .traj (schema 3, swerve): rest to rest over 2 s, 1.5 m ahead, 0.5 m left,
    turning 0.5 rad (quintic smoothstep in each axis, sampled every 0.05 s)."""
    duration, rows = 2.0, []
    for t in np.linspace(0.0, duration, 41):
        u = t / duration
        s, ds, dds = (10 * u**3 - 15 * u**4 + 6 * u**5, (30 * u**2 - 60 * u**3 + 30 * u**4)
                      / duration, (60 * u - 180 * u**2 + 120 * u**3) / duration**2)
        rows.append({"t": t, "x": 1.5 * s, "y": 0.5 * s, "heading": 0.5 * s, "vx": 1.5 * ds,
                     "vy": 0.5 * ds, "omega": 0.5 * ds, "ax": 1.5 * dds, "ay": 0.5 * dds,
                     "alpha": 0.5 * dds})
    document: dict[str, Any] = {
        "name": name, "version": 3, "snapshot": None, "params": {}, "events": [],
        "trajectory": {"sampleType": "Swerve", "config": dict(CHOREO_CONFIG),
                       "samples": rows}}
    for dotted, value in changes.items():  # e.g. version=2, trajectory__sampleType=...
        *parents, key = dotted.split("__")
        target = document
        for parent in parents:
            target = target[parent]
        if value is None:
            del target[key]
        else:
            target[key] = value
    path = folder / f"{name}.traj"
    path.write_text(json.dumps(document))
    return path


def test_choreo_trajectory_runs_on_its_own_robot(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    _runs_not_drawn(monkeypatch)  # the page's run names are read, not the runs' figures
    path = choreo_file(tmp_path)
    out = tmp_path / "out"
    # --quick: the file for 3 s (no built-in shape); two processes: the samples cross them
    assert main(["--trajectory", str(path), "--quick", "--controllers",
                 "mpc-daqp,ff-p-clip,ff-p-setpoint", "--workers", "2",
                 "--out", str(out)]) == 0
    document = json.loads((out / "results.json").read_text())
    runs = document["runs"]
    assert [run["controller"] for run in runs] == ["mpc-daqp", "ff-p-clip", "ff-p-setpoint"]
    reference = read_choreo(path)
    for run in runs:
        assert (run["layout"], run["trajectory"], run["heading"], run["speed"]) == (
            "lane-change", "lane-change", "choreo", "as-given")
        assert run["robot"]["kind"] == "swerve"
        np.testing.assert_allclose(run["robot"]["wheel_positions"],
                                   reference.robot.wheel_positions, atol=1e-6)
        series = run["series"]
        assert len(series["time"]) == 60  # 3 s at 0.05 s
        expected = np.array([reference.sample(t).pose for t in series["time"]])
        np.testing.assert_allclose(series["reference"], expected, atol=1e-6)
        assert run["metrics"]["max_wheel_speed_ratio"] < 1.0
    mpc = runs[0]["metrics"]
    assert mpc["rms_position_error"] < 5e-3 and mpc["limit_violations"] == 0
    assert document["meta"]["settings"]["trajectory_files"] == [str(path)]
    index = (out / "report" / "index.html").read_text()
    assert "lane-change-lane-change-choreo-as-given-mpc-daqp" in index


def test_trajectory_files_with_shapes_and_csv(tmp_path: Path) -> None:
    csv_path = tmp_path / "wiggle.csv"
    csv_path.write_text("t,x,y,theta\n0,0,0,0\n2,0.5,0.2,0.3\n4,1.0,0.0,0.0\n")
    out = tmp_path / "out"
    assert main(["--trajectory", str(choreo_file(tmp_path)), "--trajectory", str(csv_path),
                 "--layouts", "omni3,mecanum", "--trajectories", "circle", "--speeds", "inside",
                 "--headings", "fixed", "--controllers", "ff-p-desat", "--duration", "1",
                 "--no-report", "--workers", "1", "--out", str(out)]) == 0
    runs = json.loads((out / "results.json").read_text())["runs"]
    assert {(run["layout"], run["trajectory"], run["heading"]) for run in runs} == {
        ("omni3", "circle", "fixed"), ("mecanum", "circle", "fixed"),
        ("omni3", "wiggle", "csv"), ("mecanum", "wiggle", "csv"),
        ("lane-change", "lane-change", "choreo")}


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"version": 2}, "version: expected 3 (Choreo .traj schema 3), got 2"),
        ({"trajectory__sampleType": "Differential"}, 'trajectory.sampleType: expected "Swerve"'),
        ({"trajectory__config__vmax": None}, "trajectory.config.vmax: missing"),
        ({"trajectory__samples": []}, "trajectory.samples: expected a list of at least 2"),
    ],
)
def test_bad_choreo_file_is_one_line_naming_file_and_field(
        changes: dict[str, Any], field: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    path = choreo_file(tmp_path, **changes)
    assert main(["--trajectory", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == f"mpc-bench: error: choreo file {str(path)!r}: {field}" + err.split(field)[1]
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_two_trajectory_files_of_one_name_are_refused(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    first = choreo_file(tmp_path)
    (tmp_path / "other").mkdir()
    second = choreo_file(tmp_path / "other")
    assert main(["--trajectory", str(first), "--trajectory", str(second),
                 "--out", str(tmp_path / "out")]) == 2
    assert "have one name, 'lane-change': rename one" in capsys.readouterr().err


def test_motor_plant_and_a_choreo_robot_are_refused_up_front(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = choreo_file(tmp_path)
    assert main(["--trajectory", str(path), "--plant", "motor",
                 "--out", str(tmp_path / "out")]) == 2
    assert f"the robot of {str(path)!r} has none (use --plant ideal" in capsys.readouterr().err


def test_an_out_folder_that_cannot_be_written_is_refused_before_the_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--out`` under a file cannot be made: one line, exit 2, before any run (the results
    were lost after the whole run when only the files' existence was checked)."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    started = time.perf_counter()
    assert main(["--quick", "--controllers", "ff-p-clip", "--out", str(blocker / "out")]) == 2
    assert "cannot be written" in capsys.readouterr().err
    assert time.perf_counter() - started < 5.0  # nothing simulated


def test_bad_options_leave_no_output_folder(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["--workers", "0", "--quick"], ["tune", "--robot", "foo"]):
        out = tmp_path / argv[1]
        assert main([*argv, "--out", str(out)]) == 2
        assert not out.exists(), argv
    capsys.readouterr()


def test_names_are_taken_once_and_by_their_prose_names(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    """``--controllers a,a`` runs ``a`` once; ``figure-eight`` (the README's word) is
    ``figure8``; ``--version`` prints the package version."""
    assert main(["--quick", "--layouts", "mecanum", "--trajectories", "figure-eight",
                 "--controllers", "ff-p-clip,ff-p-clip", "--speeds", "inside",
                 "--no-report", "--out", str(tmp_path)]) == 0
    runs = json.loads((tmp_path / "results.json").read_text())["runs"]
    assert [(run["trajectory"], run["controller"]) for run in runs] == [
        ("figure8", "ff-p-clip")]
    capsys.readouterr()
    assert main(["--version"]) == 0
    assert re.fullmatch(r"mpc-bench \d+\.\d+\.\d+.*\n", capsys.readouterr().out)


def test_a_skip_without_a_duration_is_kept_whole(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Without --duration a run lasts its laps after the skip: the skip is not halved
    (it was: --skip 100 scored from 62 s on, while the settings said 100)."""
    assert main(["--layouts", "mecanum", "--trajectories", "circle", "--headings", "fixed",
                 "--controllers", "ff-p-clip", "--speeds", "inside", "--skip", "12",
                 "--no-report", "--out", str(tmp_path)]) == 0
    run = json.loads((tmp_path / "results.json").read_text())["runs"][0]
    assert run["skip"] == 12.0
    capsys.readouterr()


def _command_parsers() -> dict[str, argparse.ArgumentParser]:
    return {name: command.function(command.parser)() for name, command in COMMANDS.items()}


def test_every_list_option_has_one_name_in_every_command() -> None:
    from benchmarks.options import LIST_OPTIONS

    plurals = {flag.removeprefix("--"): flag for flag in LIST_OPTIONS}
    singulars = {old: flag for flag, olds in LIST_OPTIONS.items() for old in olds}
    seen: dict[str, set[str]] = {}
    for name, parser in _command_parsers().items():
        shown = [action for action in parser._actions if action.help != argparse.SUPPRESS]
        for action in shown:
            for option in action.option_strings:  # no old spelling of a list option shown
                assert option not in singulars, f"{name} {option}: spell it {singulars[option]}"
            if action.dest in plurals or action.dest == "mode":  # a list of names
                seen.setdefault(action.dest, set()).update(action.option_strings)
        for action in parser._actions:  # an old spelling stores where the new one does
            if action.help == argparse.SUPPRESS and action.option_strings[0] in singulars:
                new = singulars[action.option_strings[0]]
                assert any(new in a.option_strings and a.dest == action.dest for a in shown)
    # the same list, the same name everywhere: --layouts in run, perf, motors, qp-replay
    assert seen["layouts"] == {"--layouts"}
    assert seen["headings"] == {"--headings"}
    assert seen["mode"] == {"--modes"}  # tune's --modes stores its one mode as mode
    assert {"layouts", "trajectories", "headings", "speeds", "controllers", "modes",
            "solvers"} <= set(seen)
    commands = {name for name, parser in _command_parsers().items()
                if any("--headings" in a.option_strings for a in parser._actions)}
    assert commands == {"run", "perf", "qp-replay", "motors", "tune"}


def test_old_singular_spellings_still_work_hidden_with_a_note(
        capsys: pytest.CaptureFixture[str]) -> None:
    from benchmarks import perf, qp_replay

    args = perf._parser().parse_args(["--heading", "fixed", "--layouts", "mecanum"])
    assert args.headings == "fixed" and args.layouts == "mecanum"
    assert "mpc-bench perf: note: --heading is now spelled --headings" in capsys.readouterr().err
    args = qp_replay._parser().parse_args(["--layout", "mecanum", "--speed", "inside"])
    assert (args.layouts, args.speeds, args.trajectories) == ("mecanum", "inside", "figure8")
    with pytest.raises(SystemExit):
        perf._parser().print_help()
        raise SystemExit(0)
    assert "--heading " not in capsys.readouterr().out  # hidden from --help


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--layots", "mecanum"],
         "mpc-bench: error: unrecognized arguments: --layots mecanum (did you mean --layouts?)"),
        (["perf", "--headigns", "fixed"],
         "mpc-bench perf: error: unrecognized arguments: --headigns fixed (did you mean "
         "--headings?)"),
        (["--layouts", "mecanm"], "--layouts: unknown layout mecanm (did you mean mecanum?)"),
        (["--controllers", "mpc-dqap"], "unknown controller mpc-dqap (did you mean mpc-daqp?)"),
        (["--speeds", "beyon"], "--speeds: unknown speed 'beyon' (did you mean beyond?)"),
        (["--plant", "idael"], "invalid choice: 'idael' (choose from ideal, motor, realistic) "
                               "(did you mean ideal?)"),
        (["tune", "--modes", "pth"], "mpc-bench tune: error: argument --modes: invalid choice: "
                                     "'pth' (choose from time, path) (did you mean path?)"),
        (["repot", "x.json"], "mpc-bench: error: unknown command 'repot' (did you mean "
                              "report?)"),
        (["report", "/no/such/results.json"], "mpc-bench report: error: results file "),
        (["qp-replay", "--layouts", "swerve,mecanum"],
         "mpc-bench qp-replay: error: --layouts takes one layout here"),
        (["motors", "--headings", "spin"], "mpc-bench motors: error: argument --headings: "
                                           "invalid choice: 'spin'"),
    ],
)
def test_mistakes_get_the_closest_name_and_errors_name_the_command(
        argv: list[str], message: str, capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    writes = argv[0] not in ("report", "repot")
    with pytest.raises(SystemExit) as exit_info:
        raise SystemExit(main([*argv, "--out", str(tmp_path / "out")] if writes else argv))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    command = f"mpc-bench {argv[0]}" if argv[0] in COMMANDS else "mpc-bench"
    assert err.startswith(f"{command}: error: ") and message in err, err
    assert err.count("\n") == 1
    assert not (tmp_path / "out").exists()
