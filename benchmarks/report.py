"""Tracking reports from saved benchmark results: figures, an HTML page, a Markdown table.

This is the only module of the project that imports matplotlib. It draws on
:class:`matplotlib.figure.Figure` objects rendered by the Agg canvas, so it needs no
display and leaves no global pyplot state behind. It works from the plain dicts and
lists of ``results.json`` (see :func:`load_results`) and never imports a solver.

A report directory holds::

    index.html              self-contained page (inline CSS, no JavaScript)
    summary.md              the summary table in Markdown
    summary.png             controllers compared across scenarios
    figures/<run_id>.png    one 2x2 figure per run

Units: results store SI units (m, rad, s, rad/s); the report shows lengths in mm,
angles in deg and times in ms.
"""

from __future__ import annotations

import html
import json
import math
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

__all__ = ["ReportError", "load_results", "run_id", "validate_results", "write_report"]

REQUIRED_RUN_KEYS = ("layout", "trajectory", "speed", "controller", "metrics", "series")
REQUIRED_SERIES_KEYS = ("time", "pose", "reference")
FIGURE_DPI = 100
N_FOOTPRINTS = 8
LOG_SPREAD = 30.0  # the tick-time histogram goes logarithmic beyond this max/min ratio

Run = Mapping[str, Any]


class ReportError(ValueError):
    """A results file or dict cannot be reported: missing, not JSON or lacking keys."""


# --------------------------------------------------------------------------- loading


def load_results(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read and validate a ``results.json`` written by the benchmark CLI.

    Raises:
        ReportError: the file is missing or unreadable, is not JSON, or lacks
            ``"runs"`` or a required key of a run (the message names it).
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ReportError(f"results file {file} not found") from None
    except OSError as error:
        raise ReportError(f"results file {file} cannot be read: {error}") from error
    try:
        results = json.loads(text)
    except json.JSONDecodeError as error:
        raise ReportError(f"results file {file} is not valid JSON: {error}") from error
    validate_results(results, source=str(file))
    return results  # type: ignore[no-any-return]


def validate_results(results: object, source: str = "results") -> None:
    """Check the structure the report needs; raise :class:`ReportError` naming what lacks."""
    if not isinstance(results, Mapping):
        raise ReportError(f"{source}: expected a JSON object, got {type(results).__name__}")
    if "runs" not in results:
        raise ReportError(f'{source}: lacks the key "runs"')
    runs = results["runs"]
    if not isinstance(runs, list):
        raise ReportError(f'{source}: "runs" should be a list, got {type(runs).__name__}')
    for index, run in enumerate(runs):
        _validate_run(run, f"{source}: run {index}")
    meta = results.get("meta") or {}
    if not isinstance(meta, Mapping):
        raise ReportError(f'{source}: "meta" should be an object, got {type(meta).__name__}')


def _validate_run(run: object, where: str) -> None:
    if not isinstance(run, Mapping):
        raise ReportError(f"{where} should be an object, got {type(run).__name__}")
    missing = [key for key in REQUIRED_RUN_KEYS if key not in run]
    if missing:
        raise ReportError(f"{where} lacks the keys {', '.join(map(repr, missing))}")
    for key in ("metrics", "series"):
        if not isinstance(run[key], Mapping):
            raise ReportError(f"{where}: {key!r} should be an object")
    missing = [key for key in REQUIRED_SERIES_KEYS if key not in run["series"]]
    if missing:
        raise ReportError(f"{where} ({run_id(run)}): series lacks {', '.join(map(repr, missing))}")


def run_id(run: Run) -> str:
    """``"{layout}-{trajectory}-{speed}-{controller}"``, safe as a file name and an HTML id.

    Characters other than letters, digits, ``.``, ``_``, ``+`` and ``-`` become ``_``.
    """
    parts = (run["layout"], run["trajectory"], run["speed"], run["controller"])
    return "-".join(re.sub(r"[^A-Za-z0-9._+-]+", "_", str(part)) for part in parts)


def _unique_run_ids(runs: Sequence[Run]) -> list[str]:
    """Run ids, with ``-2``, ``-3``... appended to repeats so no figure overwrites another."""
    ids: list[str] = []
    taken: set[str] = set()
    for run in runs:
        base = candidate = run_id(run)
        repeat = 1
        while candidate in taken:
            repeat += 1
            candidate = f"{base}-{repeat}"
        taken.add(candidate)
        ids.append(candidate)
    return ids


# --------------------------------------------------------------------------- values


def _metric(run: Run, key: str) -> float:
    """A metric as a float; NaN when missing, null or not a number."""
    value = run["metrics"].get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return math.nan
    return float(value)


def _format_value(value: object, scale: float = 1.0) -> str:
    """Format a number for the tables: ints as is, floats to 3 significant digits.

    ``value * scale`` is shown; infinities as ``inf``, missing values as ``-``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return "-"
    if isinstance(value, int) and scale == 1.0:
        return str(value)
    shown = float(value) * scale
    if math.isnan(shown):
        return "nan"
    if math.isinf(shown):
        return "inf" if shown > 0 else "-inf"
    if shown == 0.0:
        return "0"
    return f"{shown:.0f}" if abs(shown) >= 1000 else f"{shown:.3g}"


def _scenario(run: Run) -> tuple[str, str, str]:
    return str(run["layout"]), str(run["trajectory"]), str(run["speed"])


def _peak_ratio_text(run: Run) -> str:
    ratio = run.get("peak_ratio")
    if isinstance(ratio, (int, float)) and math.isfinite(ratio):
        return f"{ratio:.2f}"
    return "-"


def _run_title(run: Run) -> str:
    """``"mecanum / circle / beyond (peak 1.30x limit) / mpc-osqp"``."""
    layout, trajectory, speed = _scenario(run)
    peak = f"(peak {_peak_ratio_text(run)}\u00d7 limit)"
    return f"{layout} / {trajectory} / {speed} {peak} / {run['controller']}"


def _wrap_degrees(angle: np.ndarray) -> np.ndarray:
    """Wrap angles [rad] into (-180, 180] [deg]."""
    return np.degrees(np.pi - np.mod(np.pi - angle, 2.0 * np.pi))


# --------------------------------------------------------------------------- series


@dataclass(frozen=True)
class _Series:
    """One run's time series as arrays, truncated to a common length K."""

    time: np.ndarray  # (K,) [s]
    pose: np.ndarray  # (K, 3) [m, m, rad]
    reference: np.ndarray  # (K, 3) [m, m, rad]
    wheel_command: np.ndarray  # (K, n) [rad/s]
    wheel_limit: np.ndarray  # (n,) [rad/s]
    tick_time: np.ndarray  # (<=K,) [s]
    fallback: np.ndarray  # (K,) bool, True where the status is not "solved"
    dt: float  # [s]


def _float_array(series: Mapping[str, Any], key: str, columns: int | None, name: str) -> np.ndarray:
    """``series[key]`` as floats: flat if ``columns`` is None, else (K, columns), 0 for any width.

    A missing or null entry is empty; a ragged or non-numeric one a :class:`ReportError`.
    """
    values = series.get(key)
    try:
        array = np.asarray(values if values is not None else [], dtype=float)
    except (TypeError, ValueError) as error:
        raise ReportError(f"run {name}: series {key!r} is not numeric: {error}") from error
    if columns is None:
        return array.reshape(-1)
    if array.size == 0:
        return np.empty((0, columns if columns > 0 else 0))
    if array.ndim != 2 or (columns > 0 and array.shape[1] != columns):
        raise ReportError(
            f"run {name}: series {key!r} should have shape (K, {columns if columns else 'n'}), "
            f"got {array.shape}"
        )
    return array


def _series(run: Run, name: str, default_dt: float) -> _Series:
    series = run["series"]
    time = _float_array(series, "time", None, name)
    pose = _float_array(series, "pose", 3, name)
    reference = _float_array(series, "reference", 3, name)
    count = min(len(time), len(pose), len(reference))
    command = _float_array(series, "wheel_command", 0, name)[:count]
    status = list(series.get("status") or [])[:count]
    fallback = np.array([entry != "solved" for entry in status] + [False] * (count - len(status)),
                        dtype=bool)
    dt = series.get("dt")
    if not isinstance(dt, (int, float)) or not dt > 0:
        dt = float(np.median(np.diff(time))) if len(time) > 1 else default_dt
    return _Series(
        time=time[:count],
        pose=pose[:count],
        reference=reference[:count],
        wheel_command=command,
        wheel_limit=_float_array(series, "wheel_limit", None, name),
        tick_time=_float_array(series, "tick_time", None, name)[:count],
        fallback=fallback,
        dt=float(dt),
    )


# --------------------------------------------------------------------------- run figure


def _new_figure(width: float, height: float, constrained: bool) -> Figure:
    """A figure of ``width`` x ``height`` [inches] on its own Agg canvas (no pyplot).

    Constrained layout places legends and rotated labels well but takes about as long
    as drawing, so the per-run figures (64 of them) use fixed margins instead.
    """
    figure = Figure(figsize=(width, height), dpi=FIGURE_DPI,
                    layout="constrained" if constrained else None)
    FigureCanvasAgg(figure)
    return figure


def _save(figure: Figure, path: Path) -> None:
    """Write a PNG. Nothing else refers to the figure (no pyplot), so it is freed on return."""
    figure.savefig(path, dpi=FIGURE_DPI)


def _convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, (m, 2)."""
    unique = sorted({(float(x), float(y)) for x, y in points})
    if len(unique) < 3:
        return np.array(unique).reshape(-1, 2)

    def chain(ordered: list[tuple[float, float]]) -> list[tuple[float, float]]:
        hull: list[tuple[float, float]] = []
        for p in ordered:
            while len(hull) >= 2:
                (ox, oy), (ax, ay) = hull[-2], hull[-1]
                if (ax - ox) * (p[1] - oy) - (ay - oy) * (p[0] - ox) > 0:
                    break
                hull.pop()
            hull.append(p)
        return hull[:-1]

    return np.array(chain(unique) + chain(unique[::-1]))


def _footprint(wheel_positions: object, fallback_half_size: float) -> np.ndarray:
    """Body-frame outline around the wheels [m], (m, 2): hull padded by 15% of the radius.

    Degenerate layouts (fewer than three non-collinear wheels) get a padded bounding
    box; a robot without wheel positions a square of ``fallback_half_size``.
    """
    try:
        points = np.asarray(wheel_positions, dtype=float).reshape(-1, 2)
    except (TypeError, ValueError):
        points = np.empty((0, 2))
    points = points[np.all(np.isfinite(points), axis=1)]
    if len(points) == 0:
        s = fallback_half_size
        return np.array([[s, s], [-s, s], [-s, -s], [s, -s]])
    pad = max(0.15 * float(np.max(np.linalg.norm(points, axis=1))), 1e-3)
    hull = _convex_hull(points)
    if len(hull) < 3:
        (x0, y0), (x1, y1) = points.min(axis=0) - pad, points.max(axis=0) + pad
        return np.array([[x1, y1], [x0, y1], [x0, y0], [x1, y0]])
    outward = hull - hull.mean(axis=0)
    norms = np.linalg.norm(outward, axis=1, keepdims=True)
    return hull + pad * outward / np.where(norms > 0, norms, 1.0)


def _place(outline: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Body-frame outline moved to the world pose ``(x, y, theta)`` [m, m, rad]."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return outline @ np.array([[c, s], [-s, c]]) + pose[:2]


def _draw_path(ax: Axes, data: _Series, robot: Mapping[str, Any]) -> None:
    ax.set_title("(a) path")
    ax.plot(data.reference[:, 0], data.reference[:, 1], "--", color="0.45", label="reference")
    ax.plot(data.pose[:, 0], data.pose[:, 1], color="C0", lw=1.5, label="robot")
    if len(data.pose):
        extent = float(np.ptp(np.vstack([data.pose[:, :2], data.reference[:, :2]]), axis=0).max())
        outline = _footprint(robot.get("wheel_positions"), max(0.03 * extent, 0.01))
        ticks = np.unique(np.linspace(0, len(data.pose) - 1, N_FOOTPRINTS).round().astype(int))
        poses = data.pose[ticks]
        ax.add_collection(
            PolyCollection(
                [_place(outline, pose) for pose in poses],
                facecolors=(0.12, 0.47, 0.71, 0.08),
                edgecolors="C0",
                linewidths=0.8,
                label="footprint",
            )
        )
        arrow = 0.8 * float(np.max(np.linalg.norm(outline, axis=1)))
        ax.quiver(poses[:, 0], poses[:, 1],
                  arrow * np.cos(poses[:, 2]), arrow * np.sin(poses[:, 2]),
                  angles="xy", scale_units="xy", scale=1.0, color="C3", width=0.005,
                  label="heading")
        ax.plot(data.pose[0, 0], data.pose[0, 1], "o", color="C2", ms=8, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.4)
    ax.legend(loc="best", fontsize="small")


def _draw_errors(ax: Axes, data: _Series) -> None:
    ax.set_title("(b) tracking error")
    difference = data.pose - data.reference
    position_mm = 1e3 * np.hypot(difference[:, 0], difference[:, 1])
    heading_deg = _wrap_degrees(difference[:, 2])
    lines: list[Artist] = [*ax.plot(data.time, position_mm, color="C0",
                                     label="position error [mm]")]
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position error [mm]", color="C0")
    ax.grid(True, alpha=0.4)
    twin = ax.twinx()
    lines += twin.plot(data.time, heading_deg, color="C1", lw=1.0, label="heading error [deg]")
    twin.set_ylabel("heading error [deg]", color="C1")
    if data.fallback.any():
        fallback_times = data.time[data.fallback]
        lines.append(ax.vlines(fallback_times, 0, 1, transform=ax.get_xaxis_transform(),
                               color="C3", alpha=0.3, lw=0.8,
                               label=f"fallback ticks ({len(fallback_times)})"))
    ax.legend(lines, [str(line.get_label()) for line in lines], loc="upper right",
              fontsize="small")


def _draw_wheels(ax: Axes, data: _Series) -> None:
    ax.set_title("(c) wheel commands")
    count = len(data.wheel_command)
    time = data.time[:count]
    for wheel in range(data.wheel_command.shape[1]):
        ax.plot(time, data.wheel_command[:, wheel], color=f"C{wheel % 10}", lw=1.0,
                label=f"wheel {wheel}")
    limits = np.unique(data.wheel_limit[np.isfinite(data.wheel_limit) & (data.wheel_limit > 0)])
    for index, limit in enumerate(limits):
        if index == 0:
            ax.axhspan(-limit, limit, color="0.9", zorder=0,
                       label=f"\u00b1 limit ({limit:g} rad/s)")
        ax.axhline(limit, color="k", ls="--", lw=1.0)
        ax.axhline(-limit, color="k", ls="--", lw=1.0)
    if count == 0:
        ax.text(0.5, 0.5, "no wheel commands", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("commanded wheel speed [rad/s]")
    ax.grid(True, alpha=0.4)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize="small", ncol=2)


def _draw_tick_histogram(ax: Axes, data: _Series, run: Run) -> None:
    ax.set_title("(d) tick time")
    tick_ms = 1e3 * data.tick_time[np.isfinite(data.tick_time)]
    dt_ms = 1e3 * data.dt
    positive = tick_ms[tick_ms > 0]
    spread = np.append(positive, dt_ms)
    logarithmic = len(positive) > 0 and spread.max() / spread.min() > LOG_SPREAD
    if len(tick_ms) == 0:
        ax.text(0.5, 0.5, "no tick times", ha="center", va="center", transform=ax.transAxes)
    elif logarithmic:
        low, high = positive.min(), positive.max()
        if high <= low * 1.01:
            low, high = low / 1.1, high * 1.1
        ax.hist(positive, bins=np.geomspace(low, high, 40).tolist(), color="C0",
                label=f"ticks (n={len(tick_ms)})")
        ax.set_xscale("log")
    else:
        ax.hist(tick_ms, bins=40, color="C0", label=f"ticks (n={len(tick_ms)})")
    ax.axvline(dt_ms, color="C3", ls="--", label=f"dt = {dt_ms:g} ms")
    solve_p50 = _metric(run, "solve_time_p50")
    solve_text = "0 (no solver)" if solve_p50 == 0 else f"{_format_value(solve_p50, 1e3)} ms"
    ax.plot([], [], " ", label=f"solve time p50 = {solve_text}")
    ax.set_xlabel("tick time [ms]" + (" (log)" if logarithmic else ""))
    ax.set_ylabel("ticks")
    ax.grid(True, alpha=0.4)
    ax.legend(loc="best", fontsize="small")


def _write_run_figure(run: Run, data: _Series, path: Path) -> None:
    figure = _new_figure(12.0, 9.0, constrained=False)
    figure.subplots_adjust(left=0.065, right=0.94, bottom=0.065, top=0.925, wspace=0.28,
                           hspace=0.27)
    axes = figure.subplots(2, 2)
    robot = run.get("robot")
    robot = robot if isinstance(robot, Mapping) else {}
    _draw_path(axes[0, 0], data, robot)
    _draw_errors(axes[0, 1], data)
    _draw_wheels(axes[1, 0], data)
    _draw_tick_histogram(axes[1, 1], data, run)
    figure.suptitle(_run_title(run), fontsize="large")
    _save(figure, path)


# --------------------------------------------------------------------------- summary figure


def _scenarios_and_controllers(runs: Sequence[Run]) -> tuple[list[tuple[str, str, str]], list[str]]:
    """Scenarios and controllers in order of first appearance."""
    scenarios = list(dict.fromkeys(_scenario(run) for run in runs))
    controllers = list(dict.fromkeys(str(run["controller"]) for run in runs))
    return scenarios, controllers


def _metric_grid(runs: Sequence[Run], key: str, scale: float) -> np.ndarray:
    """``grid[s, c]`` = metric of the first run of scenario s and controller c (NaN if none)."""
    scenarios, controllers = _scenarios_and_controllers(runs)
    grid = np.full((len(scenarios), len(controllers)), np.nan)
    for run in reversed(runs):
        row, column = scenarios.index(_scenario(run)), controllers.index(str(run["controller"]))
        grid[row, column] = _metric(run, key) * scale
    return grid


def _grouped_bars(ax: Axes, grid: np.ndarray, controllers: Sequence[str], log: bool,
                  line: tuple[float, str]) -> None:
    """One bar per controller in each scenario group, and a dashed horizontal ``line``.

    ``grid[s, c]`` holds the values (NaN: no run). Infinite values are marked "inf";
    a log axis leaves out values <= 0.
    """
    shown = np.where(np.isfinite(grid) & ((grid > 0) | (not log)), grid, np.nan)
    width = 0.8 / max(len(controllers), 1)
    positions = np.arange(grid.shape[0], dtype=float)
    for column, controller in enumerate(controllers):
        offsets = positions + (column - (len(controllers) - 1) / 2) * width
        ax.bar(offsets, shown[:, column], width, color=f"C{column % 10}", label=controller)
        for x in offsets[np.isposinf(grid[:, column])]:
            ax.annotate("inf", (x, 0.98), xycoords=("data", "axes fraction"), ha="center",
                        va="top", rotation=90, color=f"C{column % 10}", fontsize="small")
    level, label = line
    if math.isfinite(level):
        ax.axhline(level, color="C3", ls="--", lw=1.0, label=label)
    finite = shown[np.isfinite(shown)]
    if log and len(finite):
        # bars start at 0, which a log axis cannot show: start them a decade below the least
        ax.set_yscale("log")
        high = max(float(finite.max()), level if math.isfinite(level) else 0.0)
        ax.set_ylim(10.0 ** math.floor(math.log10(float(finite.min())) - 0.5), 2.0 * high)
    ax.grid(True, axis="y", alpha=0.4)
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))


def _write_summary_figure(runs: Sequence[Run], dt: float, path: Path) -> None:
    scenarios, controllers = _scenarios_and_controllers(runs)
    width = min(max(8.0, 2.0 + 0.25 * len(scenarios) * max(len(controllers), 1)), 32.0)
    figure = _new_figure(width, 12.0, constrained=True)
    top, middle, bottom = figure.subplots(3, 1, sharex=True)
    no_line = (math.nan, "")
    _grouped_bars(top, _metric_grid(runs, "rms_position_error", 1e3), controllers, True, no_line)
    top.set_ylabel("RMS position error [mm]")
    top.set_title("RMS position error (log)")
    _grouped_bars(middle, _metric_grid(runs, "max_wheel_speed_ratio", 1.0), controllers, False,
                  (1.0, "limit"))
    middle.set_ylabel("max wheel speed / limit [-]")
    middle.set_title("Peak wheel speed as a fraction of the limit")
    _grouped_bars(bottom, _metric_grid(runs, "tick_time_p50", 1e3), controllers, True,
                  (1e3 * dt, f"dt = {1e3 * dt:g} ms"))
    bottom.set_ylabel("tick time p50 [ms]")
    bottom.set_title("Median tick time (log)")
    bottom.set_xticks(np.arange(len(scenarios)))
    bottom.set_xticklabels([" / ".join(s) for s in scenarios], rotation=30 if len(scenarios) > 3
                           else 0, ha="right" if len(scenarios) > 3 else "center")
    bottom.set_xlabel("scenario (layout / trajectory / speed)")
    figure.suptitle("Controllers across scenarios", fontsize="large")
    _save(figure, path)


# --------------------------------------------------------------------------- tables


@dataclass(frozen=True)
class _Column:
    """A metric column: header with unit, metric key, scale from SI to the shown unit."""

    title: str
    metric: str
    scale: float = 1.0


_METRIC_COLUMNS = (
    _Column("RMS pos. err. [mm]", "rms_position_error", 1e3),
    _Column("max pos. err. [mm]", "max_position_error", 1e3),
    _Column("RMS heading err. [deg]", "rms_heading_error", 180.0 / math.pi),
    _Column("max cross-track [mm]", "max_cross_track_error", 1e3),
    _Column("max wheel ratio", "max_wheel_speed_ratio"),
    _Column("limit viol.", "limit_violations"),
    _Column("accel viol.", "accel_violations"),
    _Column("failures", "failures"),
    _Column("tick p50 [ms]", "tick_time_p50", 1e3),
    _Column("tick p99 [ms]", "tick_time_p99", 1e3),
    _Column("deadline misses", "deadline_misses"),
)
TABLE_HEADERS = ("layout", "trajectory", "speed", "peak ratio", "controller") + tuple(
    column.title for column in _METRIC_COLUMNS
)
_RMS_CELL = TABLE_HEADERS.index("RMS pos. err. [mm]")
_CONTROLLER_CELL = TABLE_HEADERS.index("controller")


def _failures_text(metrics: Mapping[str, Any]) -> str:
    """``"3 (previous_plan: 3)"``; just the count when there is no breakdown."""
    count = _format_value(metrics.get("failures"))
    by_status = metrics.get("failures_by_status")
    if not isinstance(by_status, Mapping) or not by_status:
        return count
    details = ", ".join(f"{status}: {_format_value(n)}" for status, n in by_status.items())
    return f"{count} ({details})"


def _row_cells(run: Run) -> list[str]:
    """The plain-text cells of one run's table row, in the order of TABLE_HEADERS."""
    cells = [*_scenario(run), _peak_ratio_text(run), str(run["controller"])]
    for column in _METRIC_COLUMNS:
        if column.metric == "failures":
            cells.append(_failures_text(run["metrics"]))
        else:
            cells.append(_format_value(run["metrics"].get(column.metric), column.scale))
    return cells


_Row = tuple[str, list[str], bool]  # run id, plain-text cells, has the best RMS of its scenario


def _grouped_rows(runs: Sequence[Run], ids: Sequence[str]) -> list[list[_Row]]:
    """Rows grouped by scenario: ``(run id, cells, has the best RMS of its scenario)``."""
    groups: dict[tuple[str, str, str], list[int]] = {}
    for index, run in enumerate(runs):
        groups.setdefault(_scenario(run), []).append(index)
    table = []
    for members in groups.values():
        rms = [_metric(runs[i], "rms_position_error") for i in members]
        finite = [value for value in rms if math.isfinite(value)]
        best = min(finite) if finite else math.nan
        table.append([(ids[i], _row_cells(runs[i]), value == best)
                      for i, value in zip(members, rms, strict=True)])
    return table


def _markdown_table(groups: Sequence[Sequence[_Row]]) -> str:
    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |"

    lines = [line(TABLE_HEADERS), line(["---"] * len(TABLE_HEADERS))]
    for group in groups:
        for _, cells, best in group:
            shown = list(cells)
            if best:
                shown[_RMS_CELL] = f"**{shown[_RMS_CELL]}**"
            lines.append(line(shown))
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- HTML

_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1300px; color: #222; }
h1, h2, h3 { font-weight: 600; }
table { border-collapse: collapse; font-size: 0.88em; margin-bottom: 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: right; }
th { background: #f0f0f0; position: sticky; top: 0; }
td.text { text-align: left; }
tbody.scenario { border-top: 3px solid #888; }
tbody.scenario tr:nth-child(even) { background: #fafafa; }
td.best { font-weight: bold; background: #e8f5e9; }
table.meta td, table.meta th { text-align: left; }
img { max-width: 100%; height: auto; border: 1px solid #ddd; }
section.run { margin-top: 2em; }
div.wide { overflow-x: auto; }
code { background: #f4f4f4; padding: 0 0.2em; }
""".strip()


def _e(value: object) -> str:
    return html.escape(str(value))


def _key_value_table(caption: str, mapping: object) -> str:
    if not isinstance(mapping, Mapping) or not mapping:
        return ""
    rows = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in mapping.items())
    return f'<table class="meta"><caption>{_e(caption)}</caption>{rows}</table>'


def _html_meta(meta: Mapping[str, Any]) -> str:
    parts = [
        f"<p>Command: <code>{_e(meta.get('command', '-'))}</code><br>"
        f"Created: {_e(meta.get('created', '-'))}</p>",
        _key_value_table("machine", meta.get("machine")),
        _key_value_table("settings", meta.get("settings")),
    ]
    return "\n".join(part for part in parts if part)


def _html_table(groups: Sequence[Sequence[_Row]]) -> str:
    text_cells = set(range(_CONTROLLER_CELL + 1)) - {TABLE_HEADERS.index("peak ratio")}
    head = "".join(f"<th>{_e(title)}</th>" for title in TABLE_HEADERS)
    bodies = []
    for group in groups:
        rows = []
        for rid, cells, best in group:
            html_cells = []
            for index, cell in enumerate(cells):
                content = _e(cell)
                if index == _CONTROLLER_CELL:
                    content = f'<a href="#{_e(rid)}">{content}</a>'
                classes = ["text"] if index in text_cells else []
                if index == _RMS_CELL and best:
                    classes.append("best")
                    content = f"<b>{content}</b>"
                attribute = f' class="{" ".join(classes)}"' if classes else ""
                html_cells.append(f"<td{attribute}>{content}</td>")
            rows.append(f'<tr id="row-{_e(rid)}">{"".join(html_cells)}</tr>')
        bodies.append(f'<tbody class="scenario">{"".join(rows)}</tbody>')
    return (f'<div class="wide"><table class="summary"><thead><tr>{head}</tr></thead>'
            f'{"".join(bodies)}</table></div>')


def _html_run_section(run: Run, rid: str) -> str:
    metrics = run["metrics"]
    details = (
        f"failures: {_e(_failures_text(metrics))}; solve time p50 / p99: "
        f"{_e(_format_value(metrics.get('solve_time_p50'), 1e3))} / "
        f"{_e(_format_value(metrics.get('solve_time_p99'), 1e3))} ms; tick max: "
        f"{_e(_format_value(metrics.get('tick_time_max'), 1e3))} ms"
    )
    return (
        f'<section class="run" id="{_e(rid)}"><h3>{_e(_run_title(run))}</h3>'
        f"<p>{details} &middot; <a href=\"#row-{_e(rid)}\">back to the table</a></p>"
        f'<img src="figures/{_e(rid)}.png" loading="lazy" alt="{_e(_run_title(run))}" '
        f'width="1200" height="900"></section>'
    )


def _html_page(results: Mapping[str, Any], ids: Sequence[str], table: str) -> str:
    runs = results["runs"]
    sections = "\n".join(_html_run_section(run, rid) for run, rid in zip(runs, ids, strict=True))
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>holonomic-mpc tracking report</title>
<style>
{_CSS}
</style>
</head>
<body>
<h1>Tracking benchmark report</h1>
<h2>Benchmark</h2>
{_html_meta(results.get("meta") or {})}
<h2>Summary</h2>
<p>{len(runs)} runs; rows grouped by scenario; the best RMS position error of each scenario
in bold. Click a controller for its figure.</p>
{table}
<img src="summary.png" alt="summary: controllers across scenarios">
<h2>Runs</h2>
{sections}
</body>
</html>
"""


# --------------------------------------------------------------------------- entry point


def _settings_dt(results: Mapping[str, Any]) -> float:
    """The controller period from ``meta.settings.dt`` [s]; NaN when absent."""
    settings = (results.get("meta") or {}).get("settings") or {}
    dt = settings.get("dt") if isinstance(settings, Mapping) else None
    return float(dt) if isinstance(dt, (int, float)) and dt > 0 else math.nan


def write_report(
    results: Mapping[str, Any],
    out_dir: Path,
    on_figure: Callable[[int, int], None] | None = None,
) -> Path:
    """Write figures, ``summary.md`` and ``index.html`` into ``out_dir``; return the page's path.

    ``out_dir`` and ``out_dir/figures`` are created. Each run's figure is named
    ``figures/<run_id>.png`` (repeated ids get ``-2``, ``-3``...). ``on_figure(i, total)``
    is called after each written figure, ``i`` from 1 to ``total`` = runs + 1 (the
    summary figure is the last).

    Raises:
        ReportError: ``results`` lacks ``"runs"`` or a required key of a run, or a
            series has the wrong shape.
    """
    validate_results(results)
    out_dir = Path(out_dir)
    figures = out_dir / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    runs: list[Run] = list(results["runs"])
    ids = _unique_run_ids(runs)
    dt = _settings_dt(results)
    total = len(runs) + 1
    for index, (run, rid) in enumerate(zip(runs, ids, strict=True), start=1):
        data = _series(run, rid, default_dt=dt if math.isfinite(dt) else 0.05)
        _write_run_figure(run, data, figures / f"{rid}.png")
        if on_figure is not None:
            on_figure(index, total)
    _write_summary_figure(runs, dt, out_dir / "summary.png")
    if on_figure is not None:
        on_figure(total, total)
    groups = _grouped_rows(runs, ids)
    (out_dir / "summary.md").write_text(_markdown_table(groups), encoding="utf-8")
    index_path = out_dir / "index.html"
    index_path.write_text(_html_page(results, ids, _html_table(groups)), encoding="utf-8")
    return index_path
