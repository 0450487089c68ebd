"""Reports from synthetic results: files written, values shown, loading errors."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Collection
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from matplotlib.patches import Rectangle

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.axis import Axis
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend
    from matplotlib.text import Text

import mpc.plot.writer
from benchmarks.report import ReportError, load_results, run_id, verdict, write_report

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
TICKS = 50
DT = 0.05

MECANUM = {"name": "mecanum", "kind": "swedish",
           "wheel_positions": [[0.15, 0.125], [0.15, -0.125], [-0.15, 0.125], [-0.15, -0.125]]}
SWERVE = {"name": "swerve", "kind": "swerve",
          "wheel_positions": [[0.3, 0.3], [0.3, -0.3], [-0.3, 0.3], [-0.3, -0.3]]}

# (layout, trajectory, speed, peak ratio, robot) x (controller, RMS position error [m])
SCENARIOS = [("mecanum", "circle", "inside", 0.8, MECANUM),
             ("swerve", "figure8", "beyond", 1.3, SWERVE)]
CONTROLLERS = [("mpc-osqp", 0.0123), ("ff-p-clip", 0.0456)]


def _series(rng: np.random.Generator, trajectory: str, baseline: bool) -> dict:
    time = np.arange(TICKS) * DT
    phase = 2 * np.pi * time / (TICKS * DT)
    if trajectory == "circle":
        xy = np.column_stack([np.cos(phase), np.sin(phase)])
    else:
        xy = np.column_stack([np.sin(phase), np.sin(2 * phase) / 2])
    theta = np.unwrap(np.arctan2(np.gradient(xy[:, 1]), np.gradient(xy[:, 0])))
    reference = np.column_stack([xy, theta])
    pose = reference + rng.normal(scale=[0.01, 0.01, 0.05], size=reference.shape)
    pose[:, 2] += 2 * np.pi  # a whole turn must not show as heading error
    commands = 20 * np.sin(phase[:, None] + np.arange(4)) + rng.normal(size=(TICKS, 4))
    status = ["solved"] * TICKS
    if not baseline:
        status[10:13] = ["previous_plan"] * 3
    return {
        "time": time.tolist(),
        "pose": pose.tolist(),
        "reference": reference.tolist(),
        "wheel_command": commands.tolist(),
        "wheel_limit": [20.0, 20.0, 20.0, 0.0 if baseline else 20.0],
        "tick_time": (rng.lognormal(np.log(3e-4), 0.3, TICKS)).tolist(),
        "solve_time": [0.0] * TICKS if baseline else rng.uniform(5e-5, 1e-4, TICKS).tolist(),
        "status": status,
        "dt": DT,
    }


def _results() -> dict:
    rng = np.random.default_rng(7)
    runs = []
    for layout, trajectory, speed, ratio, robot in SCENARIOS:
        for controller, rms in CONTROLLERS:
            baseline = controller.startswith("ff")
            runs.append({
                "layout": layout, "trajectory": trajectory, "speed": speed,
                "peak_ratio": ratio, "controller": controller,
                "metrics": {
                    "rms_position_error": rms, "max_position_error": 3 * rms,
                    "rms_cross_track_error": rms / 2, "max_cross_track_error": 0.0789,
                    "rms_heading_error": math.radians(2.5), "max_heading_error": 0.2,
                    # a baseline with a failed wheel (limit 0): an infinite ratio
                    "max_wheel_speed_ratio": math.inf if baseline else ratio,
                    "limit_violations": 7 if baseline else 0, "accel_violations": 0,
                    "control_effort": 1.0, "tick_time_p50": 3e-4, "tick_time_p95": 4e-4,
                    "tick_time_p99": 5e-4, "tick_time_max": 6e-4,
                    "solve_time_p50": 0.0 if baseline else 8e-5,
                    "solve_time_p99": 0.0 if baseline else 1e-4,
                    "deadline_misses": 0, "failures": 0 if baseline else 3,
                    "failures_by_status": {} if baseline else {"previous_plan": 3},
                },
                "series": _series(rng, trajectory, baseline),
                "robot": robot,
            })
    return {
        "meta": {"command": "mpc-bench --quick", "created": "2026-11-23T10:00:00+00:00",
                 "machine": {"platform": "Linux <test>", "python": "3.11.7", "cpu_count": 2,
                             "processor": "x86_64"},
                 "settings": {"horizon": 20, "dt": DT, "duration": TICKS * DT,
                              "plant": "ideal", "skip": 0.0}},
        "runs": runs,
    }


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[tuple[int, int]]]:
    out_dir = tmp_path_factory.mktemp("report")
    progress: list[tuple[int, int]] = []
    index = write_report(_results(), out_dir / "nested", lambda i, n: progress.append((i, n)))
    return index, progress


@pytest.fixture()
def runs_not_drawn(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each run's own figure left undrawn, for tests of the page and of the figures beside
    it: the page is the same text either way, and the module's report draws runs of these
    synthetic series (the run figure reads the series, not the metrics)."""
    monkeypatch.setattr(mpc.plot.writer, "write_run_figure", lambda run, data, path: None)


def test_index_references_every_figure_and_run(report: tuple[Path, list[tuple[int, int]]]) -> None:
    index, _ = report
    assert index.name == "index.html" and index.is_file()
    page = index.read_text(encoding="utf-8")
    assert 'src="summary.png"' in page
    for run in _results()["runs"]:
        rid = run_id(run)
        assert f'src="figures/{rid}.png"' in page
        assert f'id="{rid}"' in page and f'href="#{rid}"' in page


def test_index_shows_metadata_escaped(report: tuple[Path, list[tuple[int, int]]]) -> None:
    page = report[0].read_text(encoding="utf-8")
    assert "mpc-bench --quick" in page and "2026-11-23T10:00:00+00:00" in page
    assert "Linux &lt;test&gt;" in page and "<test>" not in page


def _full_table(page: str) -> str:
    """The page's full table (the headline has a table of its own)."""
    start = page.index('<table class="summary">')
    return page[start:page.index("</table></div>", start)]


def test_index_formats_table_values(report: tuple[Path, list[tuple[int, int]]]) -> None:
    page = _full_table(report[0].read_text(encoding="utf-8"))
    # 0.0123 m -> 12.3 mm is the best of its scenario, 45.6 mm is not
    assert page.count('<td class="best"><b>12.3</b></td>') == 2
    assert page.count("<td>45.6</td>") == 2
    assert "<td>78.9</td>" in page  # max cross-track [mm]
    assert "<td>2.5</td>" in page  # RMS heading [deg]
    assert "<td>0.3</td>" in page and "<td>0.5</td>" in page  # tick p50, p99 [ms]
    assert "<td>inf</td>" in page
    assert "<td>3 (previous_plan: 3)</td>" in page


def test_figures_are_png(report: tuple[Path, list[tuple[int, int]]]) -> None:
    index, _ = report
    pngs = [index.parent / "summary.png"]
    pngs += [index.parent / "figures" / f"{run_id(run)}.png" for run in _results()["runs"]]
    assert sorted((index.parent / "figures").iterdir()) == sorted(pngs[1:])
    for png in pngs:
        data = png.read_bytes()
        assert len(data) > 1000 and data[:8] == PNG_MAGIC


def test_progress_called_per_figure(report: tuple[Path, list[tuple[int, int]]]) -> None:
    # 4 runs, 2 scenarios, the headline and the summary figures
    assert report[1] == [(i, 8) for i in range(1, 9)]


def test_summary_markdown_has_a_row_per_run(report: tuple[Path, list[tuple[int, int]]]) -> None:
    lines = (report[0].parent / "summary.md").read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("| layout | trajectory | heading | speed |")
    assert set(lines[1]) <= set("|- ")
    rows = lines[2:]
    assert len(rows) == 4
    for row, run in zip(rows, _results()["runs"], strict=True):
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        # runs without a heading (results of older versions) count as fixed heading
        assert cells[:6] == [run["layout"], run["trajectory"], "fixed", run["speed"],
                             f"{run['peak_ratio']:.2f}", run["controller"]]
        assert cells[6] == ("**12.3**" if run["controller"] == "mpc-osqp" else "45.6")


def test_run_id_is_a_safe_file_name() -> None:
    run = {"layout": "omni 3", "trajectory": "figure8", "speed": "beyond/1.3",
           "controller": "mpc-osqp"}
    assert run_id(run) == "omni_3-figure8-beyond_1.3-mpc-osqp"
    assert re.fullmatch(r"[A-Za-z0-9._+-]+", run_id(run))


def test_repeated_run_ids_get_distinct_figures(tmp_path: Path) -> None:
    results = _results()
    results["runs"] = [results["runs"][0], results["runs"][0]]
    write_report(results, tmp_path)
    rid = run_id(results["runs"][0])
    assert {p.name for p in (tmp_path / "figures").iterdir()} == {f"{rid}.png", f"{rid}-2.png"}


def test_load_results_round_trip(tmp_path: Path) -> None:
    results = _results()
    path = tmp_path / "results.json"
    path.write_text(json.dumps(results), encoding="utf-8")  # inf is written as Infinity
    loaded = load_results(path)
    assert loaded["meta"] == results["meta"]
    assert loaded["runs"][1]["metrics"]["max_wheel_speed_ratio"] == math.inf
    assert loaded["runs"][0]["series"]["pose"] == results["runs"][0]["series"]["pose"]


def test_load_results_errors(tmp_path: Path) -> None:
    with pytest.raises(ReportError, match="does not exist"):
        load_results(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_results(bad)
    bad.write_text(json.dumps({"meta": {}}), encoding="utf-8")
    with pytest.raises(ReportError, match='"runs"'):
        load_results(bad)
    run = _results()["runs"][0]
    del run["metrics"], run["series"]["pose"]
    bad.write_text(json.dumps({"runs": [run]}), encoding="utf-8")
    with pytest.raises(ReportError, match="run 0 lacks the keys 'metrics'"):
        load_results(bad)


def test_write_report_rejects_bad_series(tmp_path: Path) -> None:
    results = _results()
    del results["runs"][1]["series"]["reference"]
    with pytest.raises(ReportError, match="run 1 .*series lacks 'reference'"):
        write_report(results, tmp_path)
    results = _results()
    results["runs"][0]["series"]["pose"] = [[0.0, 0.0]] * TICKS
    with pytest.raises(ReportError, match=r"'pose' should have shape \(K, 3\)"):
        write_report(results, tmp_path)


def test_degenerate_runs_do_not_crash(tmp_path: Path) -> None:
    """No robot, no ticks, a two-wheel robot, infinite limits, null metrics, numeric labels."""
    results = _results()
    no_robot, empty, two_wheels = (results["runs"][i] for i in (0, 1, 2))
    del no_robot["robot"]
    no_robot["series"]["wheel_limit"] = [math.inf] * 4
    del no_robot["series"]["dt"], no_robot["series"]["status"]
    no_robot["metrics"]["rms_position_error"] = None
    empty["series"] = {"time": [], "pose": [], "reference": [], "wheel_command": [],
                       "wheel_limit": [], "tick_time": [], "solve_time": [], "status": []}
    empty["speed"] = 1.3
    two_wheels["robot"]["wheel_positions"] = [[0.0, 0.2], [0.0, -0.2]]
    two_wheels["series"]["tick_time"] = [1e-3] * TICKS
    index = write_report(results, tmp_path)
    page = index.read_text(encoding="utf-8")
    assert "<td>-</td>" in page and "swerve-figure8-1.3-ff-p-clip" not in page
    assert "mecanum-circle-1.3-ff-p-clip.png" in page
    for png in (tmp_path / "figures").iterdir():
        assert png.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.usefixtures("runs_not_drawn")
def test_pace_figure_and_column_for_runs_with_laps(tmp_path: Path) -> None:
    """Runs that carry a steady lap and the fastest lap they could keep get the lap/target
    column and the pace figure (lap ratio against path error per scenario)."""
    results = _results()
    for run, lap in zip(results["runs"], (6.0, 6.3, 8.0, 8.8), strict=True):
        run["metrics"]["lap_time"] = lap
        run["target_lap"] = 6.0 if run["layout"] == "mecanum" else 8.0
    index = write_report(results, tmp_path / "report")
    pace = tmp_path / "report" / "pace.png"
    assert pace.read_bytes()[:8] == PNG_MAGIC
    page = index.read_text(encoding="utf-8")
    assert 'src="pace.png"' in page
    assert "<td>1.05</td>" in page and "<td>1.1</td>" in page  # 6.3 / 6.0, 8.8 / 8.0


def test_figures_drawn_on_processes_are_the_same_files(
        report: tuple[Path, list[tuple[int, int]]], tmp_path: Path) -> None:
    """workers=2 draws the runs' figures on spawned processes: the same files (PNGs of the
    same size: bytes may differ with the drawing process's matplotlib state) and the same
    progress count; a bad worker count is a ReportError."""
    progress: list[tuple[int, int]] = []
    index = write_report(_results(), tmp_path, lambda i, n: progress.append((i, n)), workers=2)
    ours = sorted((index.parent / "figures").iterdir())
    theirs = sorted((report[0].parent / "figures").iterdir())
    assert [p.name for p in ours] == [p.name for p in theirs]
    for a, b in zip(ours, theirs, strict=True):  # PNG signature, then IHDR width, height
        assert a.read_bytes()[:24] == b.read_bytes()[:24]
        assert a.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [n for _, n in progress] == [n for _, n in report[1]]
    assert sorted(i for i, _ in progress) == [i for i, _ in report[1]]
    with pytest.raises(ReportError, match="workers must be an integer >= 1, got 0"):
        write_report(_results(), tmp_path / "bad", workers=0)


@pytest.mark.usefixtures("runs_not_drawn")
def test_report_takes_a_results_json_and_the_cli_rebuilds_it_in_place(tmp_path: Path) -> None:
    """mpc.plot.report(path) draws a results.json; mpc.plot.report keeps its results.json
    inside the report folder, and `mpc-bench report` rebuilds that folder, not a nested
    report/."""
    import mpc.plot
    from benchmarks.cli import main

    path = tmp_path / "results.json"  # one run: where the files go does not depend on how many
    path.write_text(json.dumps(_single_run()), encoding="utf-8")
    index = mpc.plot.report(path, tmp_path / "mine")
    assert index == tmp_path / "mine" / "index.html" and index.exists()
    assert (tmp_path / "mine" / "results.json").exists()
    assert main(["report", str(tmp_path / "mine" / "results.json"), "--workers", "1"]) == 0
    assert not (tmp_path / "mine" / "report").exists()


# --------------------------------------------------------------------------- the headline's numbers

# A hand-made table: (layout, trajectory, speed, peak ratio) -> controller ->
# (RMS position error [m], RMS heading error [deg])
HAND_MADE = {
    ("mecanum", "circle", "beyond", 1.3): {"mpc-daqp": (0.100, 2.0), "mpc-osqp": (0.102, 3.0),
                                           "ff-p-clip": (0.300, 4.0), "ff-p-desat": (0.250, 5.0)},
    ("mecanum", "figure8", "beyond", 1.3): {"mpc-daqp": (0.200, 1.0), "mpc-osqp": (0.150, 2.0),
                                            "ff-p-clip": (0.500, 6.0), "ff-p-desat": (0.600, 7.0)},
    ("swerve", "circle", "beyond", 1.3): {"mpc-daqp": (0.400, 3.0), "mpc-osqp": (0.410, 4.0),
                                          "ff-p-clip": (0.390, 3.0), "ff-p-desat": (0.900, 9.0)},
    ("swerve", "figure8", "beyond", 1.3): {"mpc-daqp": (0.300, 5.0), "mpc-osqp": (0.310, 6.0),
                                           "ff-p-clip": (0.200, 1.0), "ff-p-desat": (0.800, 2.0)},
    ("mecanum", "circle", "inside", 0.8): {"mpc-daqp": (1e-14, 1e-9), "mpc-osqp": (3e-8, 1e-9),
                                           "ff-p-clip": (0.002, 0.5), "ff-p-desat": (0.004, 0.6)},
}


def _hand_made(scenarios: Collection[tuple[str, str, str, float]] | None = None) -> dict:
    """The hand-made table as a results document (series from the synthetic runs); only
    the ``scenarios`` given (keys of HAND_MADE), or all."""
    rng = np.random.default_rng(3)
    runs = []
    for (layout, trajectory, speed, ratio), rows in HAND_MADE.items():
        if scenarios is not None and (layout, trajectory, speed, ratio) not in scenarios:
            continue
        for controller, (position, heading) in rows.items():
            runs.append({
                "layout": layout, "trajectory": trajectory, "heading": "fixed", "speed": speed,
                "peak_ratio": ratio, "controller": controller,
                "metrics": {"rms_position_error": position,
                            "rms_heading_error": math.radians(heading)},
                "series": _series(rng, trajectory, controller.startswith("ff")),
                "robot": MECANUM if layout == "mecanum" else SWERVE})
    return {"meta": {"settings": {"dt": DT, "skip": 0.0}}, "runs": runs}


def test_headline_compares_mpc_with_the_best_baseline() -> None:
    """Per scenario MPC is its best variant and the baseline the best other controller:
    by hand, beyond the limits MPC 0.100 against 0.250 m (0.4x, lower), 0.150 against
    0.500 (0.3x, lower), 0.400 against 0.390 (within 5 %: a tie, 1.03x), 0.300 against
    0.200 (1.5x, higher); median ratio (0.4 + 1.03) / 2; medians of both sides'
    errors 225 against 320 mm, 2.5 against 3.5 deg. Inside, MPC is below the floor."""
    from mpc.plot.headline import headline

    lead = headline(_hand_made()["runs"])
    comparison = lead.comparison
    assert comparison is not None and lead.focus == "beyond the wheel limits"
    assert (comparison.scenarios, comparison.wins, comparison.ties, comparison.losses) == (
        4, 2, 1, 1)
    assert sorted(comparison.position_ratios) == pytest.approx([0.3, 0.4, 0.4 / 0.39, 1.5])
    assert comparison.medians("position") == pytest.approx((0.225, 0.320))
    assert np.degrees(comparison.medians("heading")) == pytest.approx((2.5, 3.5))
    assert lead.sentences[0] == (
        "Beyond the wheel limits, MPC (the best of its variants in each scenario) has a lower "
        "RMS position error than the best baseline in 2 of 4 scenarios, ties in 1, has a "
        "higher one in 1; a median 0.71\u00d7 (0.3-1.5\u00d7) the best baseline's. Median "
        "RMS position error 225 mm against 320 mm, heading error 2.5 deg against 3.5 deg.")
    assert lead.inside is not None and lead.inside.below_floor == 1
    assert lead.sentences[1] == (
        "Inside the limits, MPC has a lower RMS position error than the best baseline in 1 "
        "of 1 scenario. Median RMS position error < 0.01 mm against 2 mm, heading error "
        "< 0.01 deg against 0.5 deg.")
    # who is lowest, ties counted for each: A daqp = osqp, B osqp, C clip = daqp, D clip
    assert dict(lead.wins) == {"mpc-daqp": 2, "mpc-osqp": 2, "ff-p-clip": 2}
    assert verdict(_hand_made()["runs"]) == (
        "beyond the wheel limits, MPC beats the best baseline in 2 of 4 scenarios (1 tie, "
        "1 loss): a median 0.71\u00d7 its RMS position error")


def test_tie_rule() -> None:
    """Within 5 % of the smaller error, or both below the floor, is a tie."""
    from mpc.plot.headline import POSITION_FLOOR, TIE_TOLERANCE, Ranking, ties

    assert TIE_TOLERANCE == 0.05
    assert ties(1.0, 1.04, POSITION_FLOOR) and ties(1.04, 1.0, POSITION_FLOOR)
    assert not ties(1.0, 1.06, POSITION_FLOOR)
    assert ties(1e-14, 5e-6, POSITION_FLOOR)  # both below 0.01 mm
    assert not ties(1e-14, 2e-5, POSITION_FLOOR)
    assert not ties(math.nan, math.nan, POSITION_FLOOR)
    ranking = Ranking(("m", "c", "fixed", "beyond"), 1.3,
                      (("a", 1.0, 0), ("b", 1.03, 1), ("c", 1.06, 2)))
    assert ranking.winners == ("a", "b") and ranking.winner is None
    assert Ranking(ranking.scenario, 1.3, ranking.entries[::2]).winner == "a"


def test_tied_variants_stay_apart_on_the_dot_chart() -> None:
    """Every controller of a row has its own height (offset markers), and the lowest
    of each row and those tying with it are outlined."""
    from mpc.plot.compare import headline_figure
    from mpc.plot.headline import headline

    runs = _hand_made()["runs"]
    lead = headline(runs)
    figure = headline_figure(lead, runs)
    position = figure.axes[0]
    dots = [line for line in position.get_lines() if np.size(line.get_xdata()) == 1]
    rows: dict[int, list[float]] = {}
    for line in dots:
        y = float(np.ravel(line.get_ydata())[0])
        rows.setdefault(round(y), []).append(y)
    assert len(rows) == 4 and all(len(ys) == len(set(ys)) == 4 for ys in rows.values())
    outlined = [line for line in dots if line.get_markeredgecolor() == "k"]
    assert len(outlined) == sum(len(ranking.winners) for ranking in lead.rankings) == 6


@pytest.mark.usefixtures("runs_not_drawn")
def test_errors_below_the_floor_are_not_ranked(tmp_path: Path) -> None:
    """Inside the limits 1e-14 and 3e-8 m are both "< 0.01" mm, tied best, not ranked.

    The inside scenario and one beyond it (so the headline's focus stays beyond the
    limits): what is checked is per scenario, and the report draws a figure per
    scenario."""
    kept = {("mecanum", "circle", "inside", 0.8), ("mecanum", "circle", "beyond", 1.3)}
    page = write_report(_hand_made(kept), tmp_path).read_text(encoding="utf-8")
    table = _full_table(page)
    assert table.count('<td class="best"><b>&lt; 0.01</b></td>') == 2
    assert "1e-11" not in page and "3e-05" not in page
    section = page[page.index("<h3>mecanum / circle / fixed / inside"):]
    section = section[:section.index("</p>")]
    assert "Below 0.01 mm (not ranked): " in section
    assert section.index("mpc-daqp") < section.index("above it, lowest first")
    assert "A tie" not in section


# --------------------------------------------------------------------------- readable figures


def _visible_tick_labels(axis: Axis) -> list[Text]:
    low, high = sorted(axis.get_view_interval())
    return [tick.label1 for tick in axis.get_major_ticks() + axis.get_minor_ticks()
            if tick.label1.get_visible() and tick.label1.get_text()
            and low * (1 - 1e-9) <= tick.get_loc() <= high * (1 + 1e-9)]


def _overprinted(figure: Figure) -> list[str]:
    """Pairs of tick labels whose boxes overlap, by the renderer's text extents."""
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()  # type: ignore[attr-defined]  # Agg canvas
    found = []
    for ax in figure.axes:
        for axis in (ax.xaxis, ax.yaxis):
            labels = _visible_tick_labels(axis)
            boxes = [label.get_window_extent(renderer) for label in labels]
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    if boxes[i].overlaps(boxes[j]):
                        found.append(f"{labels[i].get_text()!r} / {labels[j].get_text()!r}")
            if axis.get_scale() == "log":
                assert len(labels) >= 2, f"a log axis with {len(labels)} labels"
    return found


def _data_under(legend: Legend | None, axes: list[Axes]) -> list[str]:
    """The axes' lines whose drawn path crosses the legend's box (display space)."""
    assert legend is not None
    box = legend.get_window_extent()
    return [str(line.get_label()) for ax in axes for line in ax.get_lines()
            if line.get_path().transformed(line.get_transform()).intersects_bbox(box,
                                                                                 filled=False)]


def _single_run() -> dict[str, Any]:
    run = dict(_results()["runs"][0])
    run.update(speed="-", heading="-", peak_ratio=None, controller="mpc")
    return {"meta": {"settings": {"dt": DT, "skip": 0.5}}, "runs": [run]}


def _narrow_span() -> dict[str, Any]:
    """Errors within one decade: 40-90 mm beyond the limits."""
    results = _results()
    for run, rms in zip(results["runs"], (0.05, 0.09, 0.04, 0.07), strict=True):
        run["metrics"]["rms_position_error"] = rms
        run["speed"], run["peak_ratio"] = "beyond", 1.3
    return results


@pytest.mark.usefixtures("runs_not_drawn")  # the first run's figure is drawn and read below
@pytest.mark.parametrize("document", [_single_run, _narrow_span])
def test_figures_have_readable_ticks_and_legends_off_the_data(
        document: Callable[[], dict[str, Any]], tmp_path: Path) -> None:
    """A single run and a report whose errors span less than two decades: no tick labels
    overprint; legends sit outside the axes or above the data."""
    from mpc.plot.compare import controllers_of, headline_figure, scenario_figure
    from mpc.plot.headline import headline
    from mpc.plot.results import read_series
    from mpc.plot.run_figure import run_figure

    results = document()
    runs = results["runs"]
    write_report(results, tmp_path)  # the page and the figures beside it draw
    series = [read_series(run, run_id(run), DT) for run in runs]
    lead_figure = headline_figure(headline(runs), runs)
    members = [i for i, run in enumerate(runs) if run["layout"] == runs[0]["layout"]]
    overlay = scenario_figure([runs[i] for i in members], [series[i] for i in members],
                              controllers_of(runs), "title")
    per_run = run_figure(runs[0], series[0])
    for figure in (lead_figure, overlay, per_run):
        assert _overprinted(figure) == []
    for figure in (lead_figure, overlay):  # figure legends: beside or below the axes
        legend_box = figure.legends[0].get_window_extent()
        assert not any(legend_box.overlaps(ax.get_window_extent()) for ax in figure.axes)
    path, errors, wheels, ticks = per_run.axes[:4]
    path_legend = path.get_legend()
    assert path_legend is not None
    assert not path_legend.get_window_extent().overlaps(path.get_window_extent())
    twin = [ax for ax in per_run.axes if ax is not errors and ax.bbox.bounds ==
            errors.bbox.bounds]
    assert _data_under(errors.get_legend(), [errors, *twin]) == []
    assert _data_under(wheels.get_legend(), [wheels]) == []
    assert _data_under(ticks.get_legend(), [ticks]) == []  # the dt line
    tick_legend = ticks.get_legend()
    assert tick_legend is not None
    legend_box = tick_legend.get_window_extent()  # the histogram's bars
    assert not any(legend_box.overlaps(bar.get_window_extent()) for bar in ticks.patches
                   if isinstance(bar, Rectangle) and bar.get_height() > 0)
