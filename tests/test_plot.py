"""mpc.plot: a loop of your own plots and reports like the benchmark; matplotlib stays out
of the control path; the report states its terms and opens on the headline."""

from __future__ import annotations

import json
import math
import re
import struct
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.collections import LineCollection

import mpc.plot
import mpc.plot.writer
from benchmarks.executor import TIMING_METRICS, RunSpec, execute
from benchmarks.report import write_report
from benchmarks.scenarios import reference
from benchmarks.screenshot import find_browser, first_screen, main, off_first_screen, screenshot
from mpc import Controller, ReportError, SimulationError
from mpc.plot.headline import headline
from mpc.plot.terms import SETTING_TERMS, UNKNOWN_TERM, setting_rows, settings_line
from mpc.robots import preset
from mpc.sim import Plant, PlantConfig, Recorder, SimResult, simulate
from trajectories import Circle

SKIP = 1.0  # [s]
BENCH_SETTINGS = ("horizon", "dt", "polygon_sides", "duration", "plant", "skip", "headings",
                  "seed")


# --------------------------------------------------------------------------- a loop of your own


@pytest.fixture(scope="module")
def benchmark_run() -> dict[str, Any]:
    """The benchmark's run of the Mecanum circle inside the limits (0.8x), mpc-daqp."""
    spec = RunSpec(robot="mecanum", trajectory={"shape": "circle", "heading": "fixed",
                                                "ratio": 0.8},
                   controller="mpc-daqp", duration=4.0, skip=SKIP, series=True,
                   labels={"layout": "mecanum", "trajectory": "circle", "heading": "fixed",
                           "speed": "inside"})
    run, _ = execute(spec)
    assert "error" not in run, run.get("error")
    return run


def _own_loop(ticks: int) -> SimResult:
    """A user's loop: their controller, their plant (here the project's), the Recorder."""
    robot = preset("mecanum")
    trajectory = reference("circle", "fixed", robot, 0.8)
    controller = Controller(robot, trajectory, 20, 0.05, solver="daqp")
    plant = Plant(robot, 0.05, trajectory.sample(0.0).pose, PlantConfig(),
                  np.random.default_rng(0))
    recorder = Recorder(robot, trajectory, controller.dt)
    for k in range(ticks):
        t = k * controller.dt
        pose = plant.pose
        command = controller.step(pose, t)
        recorder.record(t, pose, command, wheel_actual=plant.apply(command))
    return recorder.result()


@pytest.fixture(scope="module")
def own_run(benchmark_run: dict[str, Any]) -> dict[str, Any]:
    labels = {key: benchmark_run[key] for key in ("layout", "trajectory", "heading", "speed",
                                                  "peak_ratio", "optimal_lap", "target_lap")}
    result = _own_loop(len(benchmark_run["series"]["time"]))
    run = mpc.plot.run_record(result, skip=SKIP, controller="mpc-daqp", **labels)
    # tick times measure the machine, not the run: take the benchmark's
    for key in ("tick_time", "solve_time"):
        run["series"][key] = benchmark_run["series"][key]
    run["metrics"].update({key: benchmark_run["metrics"][key] for key in TIMING_METRICS})
    return run


def test_own_loop_records_what_the_benchmark_packs(benchmark_run: dict[str, Any],
                                                   own_run: dict[str, Any]) -> None:
    assert own_run.keys() == benchmark_run.keys()
    assert own_run["series"].keys() == benchmark_run["series"].keys()
    assert json.dumps(own_run, sort_keys=True) == json.dumps(benchmark_run, sort_keys=True)
    assert "predicted" in own_run["series"] and own_run["skip"] == SKIP


def _line_data(figure: Any) -> list[np.ndarray]:
    return [np.asarray(line.get_xydata()) for ax in figure.axes for line in ax.get_lines()]


def test_own_loop_draws_the_benchmark_figure(benchmark_run: dict[str, Any],
                                             own_run: dict[str, Any]) -> None:
    mine, theirs = mpc.plot.plot_run(own_run), mpc.plot.plot_run(benchmark_run)
    assert [ax.get_title() for ax in mine.axes] == [ax.get_title() for ax in theirs.axes]
    assert mine.get_suptitle() == theirs.get_suptitle()
    ours, bench = _line_data(mine), _line_data(theirs)
    assert len(ours) == len(bench) > 5
    for a, b in zip(ours, bench, strict=True):
        np.testing.assert_array_equal(a, b)


def _without_setup(page: str) -> str:
    """The page less what says how it was made (command, creation time, settings)."""
    page = re.sub(r'<details id="setup">.*?</details>', "", page, flags=re.S)
    return re.sub(r'<p class="terms">.*?</p>', "", page, flags=re.S)


def test_own_loop_writes_the_benchmark_page(benchmark_run: dict[str, Any],
                                            own_run: dict[str, Any], tmp_path: Path) -> None:
    theirs = write_report({"meta": {"settings": {"dt": 0.05, "skip": SKIP}},
                           "runs": [benchmark_run]}, tmp_path / "bench")
    mine = mpc.plot.report({"mpc-daqp": own_run}, tmp_path / "own", skip=SKIP)
    assert _without_setup(mine.read_text()) == _without_setup(theirs.read_text())
    names = sorted(p.relative_to(tmp_path / "own").as_posix()
                   for p in (tmp_path / "own").rglob("*.png"))
    assert names == sorted(p.relative_to(tmp_path / "bench").as_posix()
                           for p in (tmp_path / "bench").rglob("*.png"))
    assert mpc.plot.load_results(tmp_path / "own" / "results.json")["runs"][0]["controller"] \
        == "mpc-daqp"


def test_recorder_takes_the_reference_tracked() -> None:
    """A reference pose given per tick is what the errors measure against; other ticks
    keep the trajectory's."""
    robot = preset("mecanum")
    trajectory = Circle(1.0, 12.0)
    controller = Controller(robot, trajectory, 10, 0.05, solver="daqp")
    recorder = Recorder(robot, trajectory, controller.dt)
    pose = trajectory.sample(0.0).pose
    recorder.record(0.0, pose, controller.step(pose, 0.0), reference=pose + [0.003, 0.004, 0])
    recorder.record(0.05, pose, controller.step(pose, 0.05))
    result = recorder.result()
    assert result.position_error()[0] == pytest.approx(0.005)
    np.testing.assert_allclose(result.reference[1], trajectory.sample(0.05).pose)


def test_recorder_rejects_what_is_not_a_tick() -> None:
    robot = preset("mecanum")
    trajectory = Circle(1.0, 12.0)
    controller = Controller(robot, trajectory, 10, 0.05, solver="daqp")
    recorder = Recorder(robot, trajectory, controller.dt)
    command = controller.step(np.array([1.0, 0.0, 0.0]), 0.1)
    with pytest.raises(SimulationError, match="command must be the Command"):
        recorder.record(0.0, [1.0, 0.0, 0.0], command.wheel_speeds)  # type: ignore[arg-type]
    recorder.record(0.1, [1.0, 0.0, 0.0], command)
    with pytest.raises(SimulationError, match="t must not decrease"):
        recorder.record(0.05, [1.0, 0.0, 0.0], command)
    with pytest.raises(SimulationError, match=r"reference must have shape \(3,\)"):
        recorder.record(0.15, [1.0, 0.0, 0.0], command, reference=[1.0, 0.0])
    # a refused call keeps nothing, not even its (valid) reference
    with pytest.raises(SimulationError, match="wheel_actual"):
        recorder.record(0.15, [1.0, 0.0, 0.0], command, wheel_actual=[1.0],
                        reference=[9.0, 9.0, 0.0])
    recorder.record(0.2, [1.0, 0.0, 0.0], command)
    assert not np.allclose(recorder.result().reference[1], [9.0, 9.0, 0.0])


def test_readme_loop(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The README's ten-line loop runs and writes its figure and report."""
    monkeypatch.chdir(tmp_path)
    import mpc
    from mpc.model import integrate
    from trajectories import FigureEight

    robot = preset("mecanum")
    controller = mpc.Controller(robot, FigureEight(1.0, 20.0), horizon=20, dt=0.05)
    recorder = Recorder(robot, controller.trajectory, controller.dt)
    pose = controller.trajectory.sample(0.0).pose + [0.05, 0.0, 0.0]  # your robot's pose
    for k in range(120):
        t = k * controller.dt
        command = controller.step(pose, t)        # send command.wheel_speeds [rad/s]
        recorder.record(t, pose, command)
        pose = integrate(pose, command.twist, controller.dt)  # read your robot's pose
    mpc.plot.plot_run(recorder.result(), skip=1.0).savefig("run.png")
    mpc.plot.report({"mpc": recorder.result()}, "report", skip=1.0)
    assert (tmp_path / "run.png").stat().st_size > 10_000
    assert (tmp_path / "report" / "index.html").is_file()
    assert recorder.result().metrics(skip=1.0)["rms_position_error"] < 1e-3


# --------------------------------------------------------------------------- peak ratio


def test_peak_wheel_ratio_inside_reads_about_0_8(benchmark_run: dict[str, Any]) -> None:
    """Over the ticks after skip (as the errors): the reference asks 0.8x and the exact
    tracker commands that, not the start-up transient's 1.0."""
    ratio = benchmark_run["metrics"]["max_wheel_speed_ratio"]
    assert benchmark_run["peak_ratio"] == pytest.approx(0.8, abs=1e-3)
    assert ratio == pytest.approx(0.8, abs=0.02)
    data = mpc.plot.read_series(benchmark_run, "run", default_dt=0.05)
    assert data.skip == SKIP
    assert float(data.wheel_ratio[data.scored].max()) == pytest.approx(ratio, rel=1e-5)
    assert float(data.wheel_ratio.max()) > ratio + 0.05  # the transient left out


def test_peak_wheel_ratio_window_is_the_errors_window() -> None:
    robot = preset("mecanum")
    trajectory = reference("circle", "fixed", robot, 0.8)
    result = simulate(Controller(robot, trajectory, 20, 0.05, solver="daqp"), 4.0,
                      initial_pose=trajectory.sample(0.0).pose + [0.1, 0.0, 0.0])
    ratio = np.abs(result.wheel_command) / result.wheel_limit
    skip = 2.0  # [s] the 0.1 m start error is corrected at the limit, then 0.8x
    late = result.time >= skip - 1e-12
    metrics = result.metrics(skip=skip)
    assert metrics["max_wheel_speed_ratio"] == pytest.approx(ratio[late].max())
    assert result.metrics()["max_wheel_speed_ratio"] == pytest.approx(1.0, abs=1e-6)
    assert metrics["max_wheel_speed_ratio"] < 0.85
    assert metrics["max_position_error"] == pytest.approx(
        result.position_error()[late].max())


# --------------------------------------------------------------------------- plot_run


@pytest.fixture(scope="module")
def simulated() -> SimResult:
    robot = preset("mecanum")
    return simulate(Controller(robot, Circle(1.0, 12.0), 20, 0.05, solver="daqp"), 3.0)


def test_plot_run_overlays_predicted_paths_and_shades_skip(simulated: SimResult) -> None:
    figure = mpc.plot.plot_run(simulated, skip=SKIP)
    path, errors, wheels, ticks = figure.axes[:4]
    plans = [c for c in path.collections if isinstance(c, LineCollection)]
    assert len(plans) == 1 and str(plans[0].get_label()).startswith("predicted path")
    kept = simulated.predicted_poses
    assert kept is not None
    first = plans[0].get_segments()[0]
    np.testing.assert_allclose(first, kept[0, :, :2], atol=1e-6)  # the first plan [m]
    for ax in (errors, wheels):
        spans = [p for p in ax.patches if "not scored" in str(p.get_label())]
        assert len(spans) == 1
        span = spans[0]
        corners = np.asarray(span.get_verts())  # display coordinates
        x = ax.transData.inverted().transform(corners)[:, 0]
        assert (x.min(), x.max()) == pytest.approx((0.0, SKIP))
    assert not [p for p in ticks.patches if "not scored" in str(p.get_label())]
    assert "after 1 s" in wheels.get_title()
    assert errors.get_ylabel() == "position error [mm]"


def test_plot_run_without_skip_shades_nothing(simulated: SimResult) -> None:
    figure = mpc.plot.plot_run(simulated)
    assert not [p for ax in figure.axes for p in ax.patches if "not scored" in str(p.get_label())]


def test_plot_run_rejects_other_inputs() -> None:
    with pytest.raises(ReportError, match="SimResult or a run record"):
        mpc.plot.plot_run(42)  # type: ignore[arg-type]
    with pytest.raises(ReportError, match="lacks the keys"):
        mpc.plot.plot_run({"series": {}})


def test_report_rejects_other_inputs(tmp_path: Path) -> None:
    with pytest.raises(ReportError, match="must be a SimResult"):
        mpc.plot.report(42, tmp_path)  # type: ignore[arg-type]
    with pytest.raises(ReportError, match="no runs"):
        mpc.plot.report([], tmp_path)
    with pytest.raises(ReportError, match="neither a SimResult nor a run record"):
        mpc.plot.report({"mpc": 3.0}, tmp_path)  # type: ignore[dict-item]


@pytest.fixture(scope="module")
def one_run_report(simulated: SimResult, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of the simulated run (its ``index.html``); read, never written to."""
    return mpc.plot.report(simulated, tmp_path_factory.mktemp("one"), skip=SKIP)


def test_report_of_one_run(simulated: SimResult, one_run_report: Path) -> None:
    """Phrased for one run: its labels in the title (no ``-``), its errors in the
    headline, no ranking, no terms for speeds or ties it does not have."""
    index = one_run_report
    tmp_path = index.parent
    page = index.read_text()
    metrics = simulated.metrics(skip=SKIP)
    assert "<h1>Tracking report: mpc on mecanum / circle</h1>" in page
    assert (f"mpc on mecanum / circle: RMS position error "
            f"{1e3 * metrics['rms_position_error']:.3g} mm") in page
    assert f"peak wheel command {metrics['max_wheel_speed_ratio']:.2f}\u00d7 its limit" in page
    for absent in ("1 of 1", "lowest", "Inside and beyond", "inside asks", " / - ",
                   "tie", "MPC (the best"):
        assert absent not in page, absent
    assert "skip 1 s" in page and "dt 0.05 s" in page
    run = mpc.plot.load_results(tmp_path / "results.json")["runs"][0]
    assert (tmp_path / "figures" / f"{mpc.plot.run_id(run)}.png").is_file()


# --------------------------------------------------------------------------- the page


def _run(controller: str, rms: float, speed: str, ratio: float) -> dict[str, Any]:
    return {"layout": "mecanum", "trajectory": "circle", "heading": "fixed", "speed": speed,
            "peak_ratio": ratio, "controller": controller,
            "metrics": {"rms_position_error": rms}, "series": {}}


def test_headline_speaks_of_beyond_the_limits() -> None:
    runs = [_run("a", 0.001, "inside", 0.8), _run("b", 0.002, "inside", 0.8),
            _run("a", 0.05, "beyond", 1.3), _run("b", 0.01, "beyond", 1.3),
            {**_run("a", 0.02, "beyond", 1.3), "trajectory": "figure8"},
            {**_run("b", math.nan, "beyond", 1.3), "trajectory": "figure8"}]
    lead = headline(runs)
    assert lead.focus == "beyond the wheel limits"
    assert [r.winner for r in lead.rankings] == ["b", "a"]
    assert lead.wins == (("a", 1), ("b", 1))
    assert lead.sentence == ("Beyond the wheel limits, a has the lowest RMS position error "
                             "in 1 of 2 scenarios; b in 1.")
    inside = headline(runs[:2])
    assert inside.focus == "across all scenarios" and inside.wins == (("a", 1),)


def test_every_benchmark_setting_has_a_unit() -> None:
    settings = {"horizon": 20, "dt": 0.05, "polygon_sides": 16, "duration": None,
                "plant": "ideal", "skip": 2.0, "headings": ["fixed", "tangent"], "seed": 0}
    assert set(settings) == set(BENCH_SETTINGS)
    rows = setting_rows(settings)
    assert all(unit != UNKNOWN_TERM[0] and meaning for _, _, unit, meaning in rows)
    assert rows[1] == ("dt", "0.05", "s", SETTING_TERMS["dt"][1])
    assert ("headings", "fixed, tangent") == rows[6][:2]
    assert settings_line(settings) == ("horizon 20 ticks (1 s) \u00b7 dt 0.05 s \u00b7 "
                                       "polygon_sides 16 sides \u00b7 duration default \u00b7 "
                                       "plant ideal \u00b7 skip 2 s")


@pytest.fixture()
def runs_not_drawn(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each run's own figure left undrawn, for tests of the page and its first screen: the
    runs' figures come last on the page (below every part these tests look at) and the
    page is the same text either way; the one-run report above draws one."""
    monkeypatch.setattr(mpc.plot.writer, "write_run_figure", lambda run, data, path: None)


@pytest.mark.usefixtures("runs_not_drawn")
def test_page_order_headline_terms_scenarios_then_details(tmp_path: Path) -> None:
    robot = preset("mecanum")
    runs = {}
    for name, solver in (("mpc-daqp", "daqp"), ("mpc-osqp", "osqp")):
        runs[name] = simulate(Controller(robot, reference("circle", "fixed", robot, 1.3), 20,
                                         0.05, solver=solver), 2.0)
    page = mpc.plot.report(runs, tmp_path, skip=0.5,
                           labels={"speed": "beyond", "peak_ratio": 1.3}).read_text()
    order = [page.index(mark) for mark in (
        '<nav class="toc">', 'id="headline"', "Beyond the wheel limits",
        'src="headline.png"', 'id="terms"', "time-indexed", 'id="scenarios"',
        'src="scenarios/', '<details id="table">',
        '<table class="summary">', '<details id="setup">', "<th>unit</th>", 'id="runs"')]
    assert order == sorted(order)
    assert "inside asks 0.8\u00d7" in page and "beyond asks 1.3\u00d7" in page
    assert "skip 0.5 s" in page


# --------------------------------------------------------------------------- no matplotlib


def test_import_and_step_do_not_import_matplotlib() -> None:
    code = textwrap.dedent("""
        import sys
        import mpc, mpc.plot, mpc.sim
        from mpc import Controller
        from mpc.robots import preset
        from trajectories import Circle
        controller = Controller(preset("mecanum"), Circle(1.0, 8.0), 10, 0.05, solver="daqp")
        recorder = mpc.sim.Recorder(controller.robot, controller.trajectory, controller.dt)
        for k in range(3):
            recorder.record(0.05 * k, [1.0, 0.0, 0.0], controller.step([1.0, 0.0, 0.0], 0.05 * k))
        mpc.plot.run_record(recorder.result(), skip=0.05)
        print(sorted(name for name in sys.modules if name.split(".")[0] == "matplotlib"))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "[]"


# --------------------------------------------------------------------------- the first screen


def _png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


@pytest.mark.skipif(find_browser() is None, reason="no Chromium-like browser on PATH")
def test_screenshot_of_the_first_screen(one_run_report: Path, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """The headline, the settings with units and a path plot show without scrolling, for
    one run and for several controllers in several scenarios (whose runs' own figures,
    last on the page, are left undrawn: see runs_not_drawn)."""
    index = one_run_report
    shot = screenshot(index, tmp_path / "first.png")
    assert _png_size(shot) == (1400, 1000)
    assert shot.stat().st_size > 20_000  # text and figures, not a blank page
    parts = first_screen(index)
    assert off_first_screen(parts) == []
    assert parts["headline"][0] < parts["settings with units"][0] < 200
    robot = preset("mecanum")
    runs = []
    for shape in ("circle", "figure8"):
        for speed, ratio in (("inside", 0.8), ("beyond", 1.3)):
            trajectory = reference(shape, "fixed", robot, ratio)
            for name, solver in (("mpc-daqp", "daqp"), ("mpc-osqp", "osqp")):
                result = simulate(Controller(robot, trajectory, 10, 0.05, solver=solver), 1.0)
                runs.append(mpc.plot.run_record(result, skip=0.3, controller=name,
                                                trajectory=shape, speed=speed))
    monkeypatch.setattr(mpc.plot.writer, "write_run_figure", lambda run, data, path: None)
    index = mpc.plot.report(runs, tmp_path / "many")
    # main measures the page as first_screen does and fails if a part is off the first screen
    assert main([str(index), "--out", str(tmp_path / "many.png")]) == 0


def test_first_screen_names_what_is_below_it() -> None:
    parts = {"headline": (40.0, 60.0), "settings with units": (70.0, 100.0),
             "tables": (500.0, 1050.0), "figure": (880.0, 1300.0)}
    assert off_first_screen(parts) == ["tables"]
    del parts["headline"]
    assert off_first_screen(parts, height=1100.0) == ["headline"]


def test_screenshot_errors(tmp_path: Path) -> None:
    with pytest.raises(ReportError, match="not found"):
        screenshot(tmp_path / "missing.html", tmp_path / "out.png")
    page = tmp_path / "page.html"
    page.write_text("<p>hi</p>")
    with pytest.raises(ReportError, match="failed|no screenshot"):
        screenshot(page, tmp_path / "out.png", browser=str(tmp_path / "no-such-browser"))


def test_headline_ranks_clock_keepers_and_states_path_followers_apart() -> None:
    """A path follower's position error is against the point it tracks (its clock lags),
    so it is not ranked on it: the headline gives its pace and path error instead."""
    keeper = _run("mpc", 0.05, "beyond", 1.3)
    follower = {**_run("mpc-path", 0.0005, "beyond", 1.3), "target_lap": 10.0}
    follower["metrics"] = {"rms_position_error": 0.0005, "max_lag": 2.5, "lap_time": 10.1,
                           "max_cross_track_error": 0.0021}
    lead = headline([keeper, follower])
    assert [entry[0] for entry in lead.rankings[0].entries] == ["mpc"]
    assert lead.sentence == (
        "Beyond the wheel limits, mpc has the lowest RMS position error (keeping the "
        "reference's clock). In path mode: mpc-path at 1.01-1.01\u00d7 the time-optimal "
        "lap, at most 2.1 mm off the path.")


def test_a_missing_or_undefined_value_is_a_dash_in_the_tables() -> None:
    """NaN (a lap time with no lap) reads as the terminal table shows it, ``-``, not nan."""
    from mpc.plot.results import format_value

    assert format_value(math.nan) == "-" and format_value(None) == "-"
    assert format_value(math.inf) == "inf" and format_value(0.0123456) == "0.0123"


def test_a_steered_run_has_its_steering_rates_against_the_limit() -> None:
    """Swerve: a fifth panel, each module's steering rate [rad/s] with the +-limit lines
    (the figure a third of a row taller); a Swedish robot keeps its four panels."""
    robot = preset("swerve")
    result = simulate(Controller(robot, Circle(1.0, 8.0, heading="tangent")), 2.0)
    figure = mpc.plot.plot_run(result)
    steering = [ax for ax in figure.axes if ax.get_title().startswith("(e) steering rates")]
    assert len(steering) == 1
    lines = {str(line.get_label()): line for line in steering[0].get_lines()}
    rates = result.steer_rates()
    assert rates is not None
    drawn = np.asarray(lines["FL"].get_ydata(), dtype=float)  # the robot's wheel names
    np.testing.assert_allclose(drawn, rates[:, 0], rtol=0,
                               atol=1e-7)  # (run records round to 7 decimals)
    limit = float(np.asarray(result.steer_rate_limit).max())
    dashed = [np.asarray(line.get_ydata(), dtype=float) for line in steering[0].get_lines()
              if line.get_linestyle() == "--"]
    assert sorted({float(y) for ys in dashed for y in ys}) == [-limit, limit]
    assert figure.get_size_inches()[1] == pytest.approx(12.0)
    plain = mpc.plot.plot_run(simulate(Controller(preset("mecanum"), Circle(1.0, 8.0)), 1.0))
    assert not [ax for ax in plain.axes if ax.get_title().startswith("(e)")]


def test_wheel_names_come_from_the_layout() -> None:
    """Four wheels one to a quadrant are named by it (x forward, y left), in the robot's
    order; other layouts are numbered from 1; the figures label the wheels so, and name
    the wheels of records that lack names from their positions."""
    from mpc.plot.run_figure import wheel_names

    assert preset("mecanum").wheel_names == ("FL", "FR", "RL", "RR")
    assert preset("omni4").wheel_names == ("FL", "RL", "RR", "FR")  # counter-clockwise
    assert preset("mpo700").wheel_names == ("FL", "FR", "RL", "RR")
    assert preset("omni3").wheel_names == ("wheel 1", "wheel 2", "wheel 3")
    record = mpc.plot.run_record(simulate(Controller(preset("swerve"), Circle(1.0, 8.0)), 0.2))
    assert record["robot"]["wheel_names"] == ["FL", "FR", "RL", "RR"]
    del record["robot"]["wheel_names"]
    assert wheel_names(record, 4) == ["FL", "FR", "RL", "RR"]
    record["robot"]["wheel_positions"] = [[0.2, 0.0], [0.0, 0.2], [-0.2, 0.0], [0.0, -0.2]]
    assert wheel_names(record, 4) == ["module 1", "module 2", "module 3", "module 4"]
    assert wheel_names({}, 3) == ["wheel 1", "wheel 2", "wheel 3"]
