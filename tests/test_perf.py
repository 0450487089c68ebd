"""``mpc-bench perf``: what one run writes, the do-mpc peer only when installed, flag errors.

Behaviour only: no test here depends on how fast anything is.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from toolchain import HAS_COMPILER

from benchmarks import peers
from benchmarks.cli import main
from benchmarks.scenarios import reference
from mpc.robots import preset

ROW_KEYS = {"section", "solver", "horizon", "ticks", "settle", "tick_p50", "tick_p99", "tick_max",
            "cpu_p50", "cpu_p99", "solve_p50", "overhead_p50", "iterations_p50",
            "rms_position_error", "max_position_error", "limit_violations", "accel_violations",
            "failures"}


def _sane(row: dict[str, Any]) -> None:
    assert ROW_KEYS <= set(row), ROW_KEYS - set(row)
    assert row["ticks"] > 0 and row["settle"] >= 0
    assert 0 < row["solve_p50"] <= row["tick_p50"] <= row["tick_p99"] <= row["tick_max"]
    assert 0 <= row["cpu_p50"] <= row["cpu_p99"]
    assert row["overhead_p50"] >= 0
    assert row["iterations_p50"] >= 0
    assert math.isfinite(row["rms_position_error"]) and row["rms_position_error"] >= 0
    assert row["limit_violations"] == 0 and row["accel_violations"] == 0


def test_quick_run_writes_every_section_and_skips_an_absent_peer(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(peers, "available", lambda: False)  # as if do-mpc were not installed
    assert main(["perf", "--quick", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count(peers.INSTALL_HINT) == 1
    for header in ("1. tick split", "2. horizons", "3. scenarios", "4. peers", "summary",
                   "growth daqp: tick(N=20) / tick(N=10)"):
        assert header in out
    # --quick leaves the compiled section out (it compiles a library per robot) unless named
    assert "5. compiled" not in out and "mpc-compiled" not in out

    document = json.loads((tmp_path / "perf.json").read_text())
    assert {"command", "commit", "machine", "settings", "profiles", "rows", "peers", "jit",
            "summary", "wall_time"} <= set(document)
    assert document["command"] == f"mpc-bench perf --quick --out {tmp_path}"
    assert document["compiled"] is None and "issue37" not in document["summary"]
    assert {"cpu_count", "python", "processor", "load_average_start",
            "thread_env"} <= set(document["machine"])
    assert document["settings"]["horizons"] == [10, 20]

    (profile,) = document["profiles"]
    assert profile["scenario"]["horizon"] == 20 and profile["scenario"]["solver"] == "daqp"
    assert profile["phases"] and profile["ticks"] > 0
    for phase in profile["phases"]:
        assert 1 <= phase["runs"] <= profile["ticks"]
        assert 0 <= phase["p50"] <= phase["p99"] and phase["mean_per_tick"] >= 0
    assert "tick split" in (tmp_path / "tick_profile.txt").read_text()
    assert json.loads((tmp_path / "tick_profile.json").read_text())["profiles"] == [profile]
    assert "summary" in (tmp_path / "perf.txt").read_text()

    rows = document["rows"]
    for row in rows:
        _sane(row)
    horizons = {(row["solver"], row["horizon"]) for row in rows if row["section"] == "horizons"}
    assert horizons == {(s, n) for s in ("daqp", "osqp", "ipopt") for n in (10, 20)}
    compiler = shutil.which(os.environ.get("CC") or "gcc")
    if compiler:  # daqp with jit=True against the default
        jit = document["jit"]
        assert jit["same_commands"] is True and jit["repeats"] == 3 and jit["build_s"] > 0
        assert 0 < jit["jit_p50"] <= jit["jit_p99"] and 0 < jit["default_p50"]
        assert document["summary"]["daqp_jit"]["jit_over_default_p50"] > 0
        assert "daqp with jit=True (its terms compiled to C)" in out
    else:
        assert document["jit"] is None and "skipped: jit=True" in out
    scenarios = {(row["layout"], row["mode"], row["speed"]) for row in rows
                 if row["section"] == "scenarios"}
    assert scenarios == {("mecanum", m, s) for m in ("time", "path") for s in ("inside", "beyond")}
    assert all(isinstance(row["over_p99_limit"], bool) for row in rows
               if row["section"] == "scenarios")
    same_ticks = {(row["solver"], row["speed"]) for row in rows if row["section"] == "peers"}
    peered = ("mpc-daqp", "mpc-ipopt") + (("mpc-daqp-jit",) if compiler else ())
    assert same_ticks == {(s, v) for s in peered for v in ("inside", "beyond")}
    assert document["peers"]["status"] == "do-mpc not installed"

    summary = document["summary"]
    for solver in ("daqp", "osqp", "ipopt"):
        growth = summary["growth"][solver]
        assert (growth["from"], growth["to"], growth["horizon_ratio"]) == (10, 20, 2.0)
        assert growth["tick_ratio"] > 0 and isinstance(growth["at_most_linear"], bool)
    assert summary["osqp_over_daqp_tick_N20"] > 0 and summary["ipopt_over_daqp_tick_N20"] > 0
    assert summary["daqp_tick_over_solve_N20"] >= 1
    assert "do_mpc_over_daqp_tick" not in summary["same_ticks_inside"]
    assert summary["same_ticks_inside"]["ipopt_over_daqp_tick"] > 0
    assert ("ipopt_over_jit_tick" in summary["same_ticks_inside"]) == bool(compiler)
    assert summary["drift"]["end_over_start"] > 0
    assert summary["targets"] and all(isinstance(item["met"], bool)
                                      for item in summary["targets"].values())


def test_sections_and_profile_horizons_are_chosen(tmp_path: Path) -> None:
    assert main(["perf", "--sections", "profile,horizons", "--solvers", "daqp",
                 "--horizons", "5,10", "--profile-horizons", "5,10", "--ticks", "20",
                 "--out", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "perf.json").read_text())
    assert [p["scenario"]["horizon"] for p in document["profiles"]] == [5, 10]
    assert {(row["solver"], row["horizon"]) for row in document["rows"]} == {("daqp", 5),
                                                                             ("daqp", 10)}
    assert document["peers"] is None and "scenario_count" not in document["summary"]


@pytest.mark.skipif(shutil.which(os.environ.get("CC") or "gcc") is None,
                    reason="no C compiler")
def test_scenarios_with_jit_say_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--jit`` builds the scenarios' controllers with ``jit=True``: the rows, the settings
    and the summary say so (the same plan as the default: its RMS error to the bit)."""
    args = ["--sections", "scenarios", "--layouts", "mecanum", "--modes", "time",
            "--speeds", "inside", "--ticks", "20"]
    documents = []
    for extra, folder in (([], "default"), (["--jit"], "jit")):
        assert main(["perf", *args, *extra, "--out", str(tmp_path / folder)]) == 0
        documents.append(json.loads((tmp_path / folder / "perf.json").read_text()))
    out = capsys.readouterr().out
    assert out.count("with jit=True") == 1 and out.count("scenarios (jit=True):") == 1
    default, compiled = documents
    assert [row["jit"] for row in default["rows"]] == [False]
    assert [row["jit"] for row in compiled["rows"]] == [True]
    assert (default["settings"]["jit_scenarios"], compiled["settings"]["jit_scenarios"]) == (
        False, True)
    assert compiled["summary"]["scenarios_jit"] and not default["summary"]["scenarios_jit"]
    assert (compiled["rows"][0]["rms_position_error"]
            == default["rows"][0]["rms_position_error"])


def test_the_profile_splits_the_scenario_asked_for(tmp_path: Path) -> None:
    """``--profile-scenario`` names the layout, mode and speed the tick is split in; the
    daqp tick's phases include the whitening, daqp's update and solve, and the checks."""
    assert main(["perf", "--sections", "profile", "--profile-scenario", "swerve,path,beyond",
                 "--ticks", "20", "--out", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "perf.json").read_text())
    (profile,) = document["profiles"]
    assert {key: profile["scenario"][key] for key in ("layout", "mode", "speed")} == {
        "layout": "swerve", "mode": "path", "speed": "beyond"}
    assert document["settings"]["profile_scenario"] == ["swerve", "path", "beyond"]
    phases = [row["phase"] for row in profile["phases"]]
    assert phases.index("solve: whiten") < phases.index("solve: daqp update") < phases.index(
        "solve: daqp solve") < phases.index("solve: checks") < phases.index("solve: result")
    assert "swerve figure8 fixed heading, path mode, beyond" in (
        tmp_path / "tick_profile.txt").read_text()


@pytest.mark.parametrize("argv, message", [
    (["--profile-scenario", "swerve,path"], "--profile-scenario must be LAYOUT,MODE,SPEED"),
    (["--profile-scenario", "tank,time,inside"], "--profile-scenario: unknown layout 'tank'"),
    (["--profile-scenario", "swerve,fast,inside"], "--profile-scenario: unknown mode 'fast'"),
    (["--profile-scenario", "swerve,time,warp"], "--profile-scenario: unknown speed 'warp'"),
    (["--solvers", "cvxpy"], "--solvers: unknown solver cvxpy"),
    (["--layouts", "tank"], "--layouts: unknown layout tank"),
    (["--modes", "fast"], "--modes: unknown mode fast"),
    (["--sections", "all"], "--sections: unknown section all"),
    (["--speeds", "warp"], "--speeds: unknown speed 'warp'"),
    (["--horizons", "ten"], "--horizons must be a comma list of integers"),
    (["--profile-horizons", "0"], "--profile-horizons must list integers >= 1"),
    (["--ticks", "5"], "--ticks must be >= 20"),
    (["--ipopt-ticks", "3"], "--ipopt-ticks must be >= 20"),
    (["--peer-rounds", "0"], "--peer-rounds must be >= 1"),
    (["--out", __file__], "--out must be a folder"),
])
def test_bad_flags_are_one_line_errors(argv: list[str], message: str, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["perf", "--out", str(tmp_path), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_control_path_and_benchmarks_never_import_do_mpc() -> None:
    code = ("import sys, mpc, benchmarks.cli, benchmarks.perf, benchmarks.peers\n"
            "from mpc import Controller\n"
            "from mpc.robots import preset\n"
            "from trajectories import Circle\n"
            "Controller(preset('mecanum'), Circle(1.0, 10.0)).step([1.0, 0.0, 0.0], 0.0)\n"
            "assert 'do_mpc' not in sys.modules, 'do_mpc imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=Path(__file__).parents[1])


def test_do_mpc_peer_refuses_steered_wheels() -> None:
    robot = preset("swerve")
    with pytest.raises(ValueError, match="steered"):
        peers.DoMpcController(robot, reference("figure8", "fixed", robot, 0.8))


def test_do_mpc_solves_the_same_problem(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("do_mpc")
    assert main(["perf", "--sections", "peers", "--ipopt-ticks", "40", "--peer-rounds", "2",
                 "--plants", "ideal", "--out", str(tmp_path)]) == 0
    assert peers.INSTALL_HINT not in capsys.readouterr().out
    document = json.loads((tmp_path / "perf.json").read_text())
    assert document["peers"]["status"] == "measured" and document["peers"]["version"]
    assert document["settings"]["peer_rounds"] == 2
    rows = {(row["solver"], row["speed"]): row for row in document["rows"]}
    for speed in ("inside", "beyond"):
        ours, theirs = rows[("mpc-ipopt", speed)], rows[("do-mpc", speed)]
        for row in (ours, theirs):  # both rounds' ticks pooled, each without its settling
            assert row["rounds"] == 2 and row["ticks"] == 2 * (40 - row["settle"])
        _sane(theirs)
        assert theirs["failures"] == 0
        # The same NLP, the same plant: the closed loops agree to IPOPT's tolerance.
        assert theirs["rms_position_error"] == pytest.approx(ours["rms_position_error"],
                                                             rel=1e-2, abs=1e-7)
        ratios = document["summary"][f"same_ticks_{speed}"]
        assert ratios["do_mpc_over_daqp_tick"] > 0 and ratios["do_mpc_over_ipopt_tick"] > 0


def test_the_summary_checks_swerve_against_mecanum_in_the_same_run() -> None:
    """Issue 11's speed lines: swerve's tick p99 and its p50 over Mecanum's, time mode
    beyond the limits, from the scenario rows of the same run."""
    from benchmarks.perf import summarise

    def row(layout: str, p50: float, p99: float) -> dict[str, Any]:
        return {"layout": layout, "trajectory": "figure8", "heading": "fixed", "mode": "time",
                "speed": "beyond", "tick_p50": p50, "tick_p99": p99, "cpu_p99": p99,
                "over_p99_limit": p99 > 1e-3, "cpu_over_p99_limit": p99 > 1e-3}

    summary = summarise([], [row("mecanum", 2e-4, 4e-4), row("swerve", 9e-4, 1.5e-3)], None,
                        None)
    assert summary["swerve_over_mecanum_tick_p50_beyond"] == pytest.approx(4.5)
    targets = summary["targets"]
    assert targets["swerve_tick_p99_beyond"]["met"] is True
    assert targets["swerve_over_mecanum_tick_p50_beyond"]["met"] is False
    assert "swerve_tick_p99_beyond" not in summarise([], [row("mecanum", 2e-4, 4e-4)], None,
                                                     None)["targets"]


@pytest.mark.skipif(shutil.which("cmake") is None, reason="needs cmake")
def test_the_compiled_section_covers_every_scenario_or_says_why(
        capsys: pytest.CaptureFixture[str]) -> None:
    """Every scenario gets the six controllers' rows (the exported library's commands the
    compiled tick's), or one line with the reason the compiled tick refuses it: the very
    error ``Controller(compiled=True)`` raises (so rows appear as support widens)."""
    from benchmarks.compiled_tick import EXPORTED, UNSCREENED, compiled_section
    from benchmarks.perf import _row, _run, _settle
    from mpc import Controller
    from mpc.tick import UnsupportedTickError

    lines: list[str] = []
    section = compiled_section(["mecanum", "swerve"], ["time", "path"], {"inside": 0.8},
                               "figure8", "fixed", 8, 0.05, 20, 2, reference, _run, _row,
                               _settle, lines.append)
    names = {"python", "compiled", "compiled-rebuild", "virtual-machine", "ipopt", EXPORTED}
    refused = {(item["layout"], item["mode"]): item["reason"]
               for item in section["unsupported"]}
    measured = {(row["layout"], row["mode"]) for row in section["rows"]}
    assert ("mecanum", "time") in measured
    for layout in ("mecanum", "swerve"):
        robot = preset(layout)
        for mode in ("time", "path"):
            try:
                Controller(robot, reference("figure8", "fixed", robot, 0.8), horizon=8,
                           mode=mode, compiled="virtual-machine")
            except UnsupportedTickError as error:
                assert refused[(layout, mode)] == str(error)
                assert (layout, mode) not in measured
                head = str(error).partition("; it supports ")[0]
                assert any(line.endswith(f"not supported: {head}") for line in lines)
                continue
            rows = {row["solver"]: row for row in section["rows"]
                    if (row["layout"], row["mode"]) == (layout, mode)}
            exports = mode == "time"  # path mode's replay is mpc-bench export-check's
            screened = layout == "swerve"  # its guard faces (mpc.tick.screen)
            assert set(rows) == ((names if exports else names - {EXPORTED})
                                 | ({UNSCREENED} if screened else set()))
            for row in rows.values():
                _sane(row)
                assert row["rounds"] == 2 and row["horizon"] == 8
                assert row["over_compiled_tick"] == pytest.approx(
                    row["tick_p50"] / rows["compiled"]["tick_p50"])
            if not exports:
                assert any(line.startswith(f"{layout:8s} {mode:5s}")
                           and "exported: not built (" in line for line in lines)
                continue
            exported = rows[EXPORTED]
            assert exported["ticks"] == 2 * (20 - exported["settle"])
            assert exported["export_max_difference"] <= 1e-9
            assert exported["export_status_mismatches"] == 0
            assert exported["rms_position_error"] == pytest.approx(
                rows["compiled"]["rms_position_error"], rel=1e-9)  # the same run, again
    assert set(section["builds"]) == {layout for layout, _ in measured}
    assert any("exported / compiled" in line for line in lines)


def test_the_summary_states_issue_37s_lines() -> None:
    """do-mpc and the IPOPT path over the compiled tick on the reference scenario (peers'
    same ticks), and every scenario's worst ratio, p99 spread and p99, each named."""
    from benchmarks.perf import summarise

    def peer(solver: str, speed: str, p50: float, rms: float) -> dict[str, Any]:
        return {"solver": solver, "speed": speed, "tick_p50": p50, "rms_position_error": rms}

    peer_rows = [peer(solver, speed, p50, rms) for speed in ("inside", "beyond")
                 for solver, p50, rms in (("mpc-daqp", 2e-4, 1.0), ("mpc-compiled", 1e-4, 1.02),
                                          ("mpc-ipopt", 1e-2, 1.0), ("do-mpc", 3e-2, 1.0))]

    def compiled(layout: str, p50: float, p99: float, ipopt: float) -> dict[str, Any]:
        return {"solver": "compiled", "layout": layout, "mode": "time", "speed": "inside",
                "tick_p50": p50, "tick_p99": p99, "cpu_p50": p50, "cpu_p99": 0.5 * p99,
                "ipopt_over_compiled_tick": ipopt}

    section = {"rows": [compiled("mecanum", 1e-4, 2e-4, 100.0),
                        compiled("omni3", 2e-4, 8e-4, 40.0)],
               "unsupported": [{"layout": "swerve", "mode": "time", "speed": "inside",
                                "reason": "x"}]}
    summary = summarise([], [], {"rows": peer_rows}, None, None, section)
    assert summary["compiled_scenarios"] == {"measured": 2, "not_supported": 1}
    lines = summary["issue37"]
    assert lines["mecanum_inside_do_mpc_over_compiled_tick"]["measured"] == pytest.approx(300)
    assert lines["mecanum_inside_do_mpc_over_compiled_tick"]["met"] is True
    assert lines["mecanum_inside_ipopt_over_compiled_tick"]["measured"] == pytest.approx(100)
    assert lines["mecanum_inside_ipopt_over_compiled_tick"]["met"] is False
    assert lines["mecanum_inside_compiled_rms_over_ipopt_rms"]["met"] is True
    assert lines["ipopt_over_compiled_tick_min"]["scenario"] == "omni3 time inside"
    assert lines["ipopt_over_compiled_tick_min"]["met"] is False
    assert lines["compiled_p99_over_p50_max"]["measured"] == pytest.approx(4.0)
    assert lines["compiled_p99_over_p50_max"]["met"] is False
    assert lines["compiled_tick_p99_max"]["met"] is True
    assert lines["compiled_cpu_p99_over_p50_max"]["measured"] == pytest.approx(2.0)
    assert lines["compiled_cpu_p99_over_p50_max"]["met"] is True
    assert lines["compiled_cpu_p99_max"]["scenario"] == "omni3 time inside"
    assert "issue37" not in summarise([], [], {"rows": peer_rows}, None)


def test_the_realistic_plant_starts_off_and_differs_from_the_model() -> None:
    """``--plants``' realistic loop: the plant preset with its faults, from a start 0.28 m
    off the reference (hand-derived: 0.2 m in x and y), the same noise in every run (its
    seed); the ideal loop is simulate's default, from the reference."""
    from benchmarks.perf import _run
    from benchmarks.perf_plants import simulate_options
    from mpc import Controller

    robot = preset("mecanum")
    trajectory = reference("figure8", "fixed", robot, 0.8)
    assert simulate_options("ideal", trajectory) == {}
    options = simulate_options("realistic", trajectory)
    assert options["plant"] == "realistic" and isinstance(options["seed"], int)
    start = trajectory.sample(0.0).pose
    assert math.hypot(*(options["initial_pose"] - start)[:2]) == pytest.approx(
        math.sqrt(0.08))
    control = Controller(robot, trajectory, horizon=8, dt=0.05)
    ideal, first, again = (_run(control, 20, plant=plant).result
                           for plant in ("ideal", "realistic", "realistic"))
    assert ideal.pose[0] == pytest.approx(start)
    assert first.pose[0] == pytest.approx(options["initial_pose"])
    assert abs(math.hypot(*(first.measured[0] - start)[:2]) - 0.283) < 0.01  # (2 mm noise)
    assert (first.measured == again.measured).all()  # seeded: the same draws each run
    assert (first.wheel_actual != first.wheel_command).any()  # lag, delay and slip


def test_peers_run_on_each_plant_in_each_run(tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """``--plants`` and ``--runs``: every peers row once per plant and run, labelled, and
    the settings say which; the ideal plant's rows are the ones issue 12's lines use."""
    monkeypatch.setattr(peers, "available", lambda: False)
    assert main(["perf", "--sections", "peers", "--plants", "ideal,realistic", "--runs", "2",
                 "--ipopt-ticks", "20", "--peer-rounds", "1", "--out", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "perf.json").read_text())
    assert (document["settings"]["plants"], document["settings"]["runs"]) == (
        ["ideal", "realistic"], 2)
    assert document["settings"]["plant_settings"]["realistic"]["start_offset"] == [
        0.2, 0.2, 0.0]
    rows = document["rows"]
    labels = [(row["run"], row["plant"], row["speed"], row["solver"]) for row in rows]
    peer_rows = 3 if HAS_COMPILER else 2  # (the jit=True row needs a C compiler)
    assert len(labels) == len(set(labels)) == 2 * 2 * 2 * peer_rows  # runs, plants, speeds
    by = {label: row for label, row in zip(labels, rows, strict=True)}
    for plant in ("ideal", "realistic"):  # the same ticks in both runs: the same errors
        assert (by[(1, plant, "inside", "mpc-daqp")]["rms_position_error"]
                == by[(2, plant, "inside", "mpc-daqp")]["rms_position_error"])
    assert (by[(1, "ideal", "inside", "mpc-daqp")]["rms_position_error"]
            != by[(1, "realistic", "inside", "mpc-daqp")]["rms_position_error"])
    ideal = by[(1, "ideal", "inside", "mpc-ipopt")]["tick_p50"] / by[
        (1, "ideal", "inside", "mpc-daqp")]["tick_p50"]
    assert document["summary"]["same_ticks_inside"]["ipopt_over_daqp_tick"] == (
        pytest.approx(ideal))
    assert main(["perf", "--plants", "lab", "--out", str(tmp_path / "x")]) == 2
    assert main(["perf", "--runs", "0", "--out", str(tmp_path / "y")]) == 2


def test_issue_37s_lines_per_plant_and_in_every_run() -> None:
    """Each plant's lines from its own rows (a row without a plant is the ideal plant's);
    over runs, each line's value in each run and whether it held in all of them."""
    from benchmarks.perf import every_run, issue37_by_plant

    def compiled(plant: str, p50: float, p99: float, ipopt: float) -> dict[str, Any]:
        return {"solver": "compiled", "layout": "omni3", "mode": "time", "speed": "beyond",
                "plant": plant, "tick_p50": p50, "tick_p99": p99, "cpu_p50": p50,
                "cpu_p99": p99, "ipopt_over_compiled_tick": ipopt}

    def peer(plant: str, solver: str, p50: float) -> dict[str, Any]:
        return {"solver": solver, "speed": "inside", "plant": plant, "tick_p50": p50,
                "rms_position_error": 1.0}

    peer_rows = [peer(plant, solver, p50) for plant in ("ideal", "realistic")
                 for solver, p50 in (("mpc-daqp", 2e-4), ("mpc-compiled", 1e-4),
                                     ("mpc-ipopt", 1.5e-2 if plant == "ideal" else 1e-2))]
    peer_rows += [{**row, "speed": "beyond"} for row in peer_rows]
    first = issue37_by_plant(peer_rows, [compiled("ideal", 1e-4, 2e-4, 80.0),
                                         compiled("realistic", 2e-4, 1.2e-3, 45.0)],
                             ["ideal", "realistic"])
    assert first["ideal"]["mecanum_inside_ipopt_over_compiled_tick"]["measured"] == (
        pytest.approx(150))
    assert first["realistic"]["mecanum_inside_ipopt_over_compiled_tick"]["met"] is False
    assert first["realistic"]["compiled_tick_p99_max"]["scenario"] == "omni3 time beyond"
    assert first["realistic"]["ipopt_over_compiled_tick_min"]["met"] is False
    second = issue37_by_plant([], [{**compiled("", 1e-4, 2e-4, 60.0), "plant": "ideal"},
                                   compiled("realistic", 1e-4, 2e-4, 60.0)],
                              ["ideal", "realistic"])
    table = every_run([first, second])
    assert table["ideal"]["ipopt_over_compiled_tick_min"]["measured"] == [80.0, 60.0]
    assert table["ideal"]["ipopt_over_compiled_tick_min"]["met_in_every_run"] is True
    realistic = table["realistic"]["ipopt_over_compiled_tick_min"]
    assert realistic["met"] == [False, True] and realistic["met_in_every_run"] is False
    # a line run 2 could not state (no peers): not met in every run
    assert table["ideal"]["mecanum_inside_ipopt_over_compiled_tick"][
        "met_in_every_run"] is False


@pytest.mark.skipif(shutil.which("cmake") is None, reason="needs cmake")
def test_the_compiled_section_runs_each_scenario_on_each_plant() -> None:
    """The same controllers on each plant: every controller's row once per plant, labelled;
    on the realistic plant too the exported library repeats the compiled tick's commands,
    and the lines name the plant."""
    from benchmarks.compiled_tick import EXPORTED, compiled_section
    from benchmarks.perf import _row, _run, _settle

    lines: list[str] = []
    section = compiled_section(["mecanum"], ["time"], {"inside": 0.8}, "figure8", "fixed", 8,
                               0.05, 20, 1, reference, _run, _row, _settle, lines.append,
                               plants=["ideal", "realistic"])
    rows = {(row["plant"], row["solver"]): row for row in section["rows"]}
    assert len(rows) == len(section["rows"])
    for plant in ("ideal", "realistic"):
        assert {solver for (each, solver) in rows if each == plant} == {
            solver for (each, solver) in rows if each == "ideal"}
        assert rows[(plant, EXPORTED)]["export_max_difference"] <= 1e-9
        assert rows[(plant, EXPORTED)]["export_status_mismatches"] == 0
        assert any(line.startswith(f"mecanum  time  inside  {plant:9s} compiled ")
                   for line in lines)
    assert (rows[("ideal", "compiled")]["rms_position_error"]
            != rows[("realistic", "compiled")]["rms_position_error"])
