"""Figures across runs: the headline dots, one path overlay per scenario, the summary bars
and the pace scatter. Controllers keep one colour everywhere (order of first appearance).

Lengths on path plots in m, errors in mm, times in s (tick times in ms).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import ScalarFormatter

from .headline import (
    HEADING_FLOOR,
    POSITION_FLOOR,
    TIE_TOLERANCE,
    Headline,
    follows_path,
    is_mpc,
    ties,
)
from .results import Run, Series, metric_value, pace_of, scenario_of, scenario_title
from .style import log_axis, new_figure, save, shade_skip


def controllers_of(runs: Sequence[Run]) -> list[str]:
    """Controller names in order of first appearance (their colour index)."""
    return list(dict.fromkeys(str(run["controller"]) for run in runs))


def colour(controllers: Sequence[str], name: str) -> str:
    """The colour of ``name`` on every figure of a report."""
    return f"C{list(controllers).index(name) % 10}"


# --------------------------------------------------------------------------- headline

#: Shade of the band below the error floor on log plots.
FLOOR_COLOUR = "0.88"
#: Of a row's height, the span the controllers' offset markers share.
_ROW_SPREAD = 0.64


def _offsets(names: Sequence[str]) -> dict[str, float]:
    """Each ranked controller's vertical offset within a row: MPC variants first (above the
    row's centre), then the baselines, so that tied dots stay apart."""
    ordered = sorted(names, key=lambda name: not is_mpc(name))
    if len(ordered) < 2:
        return dict.fromkeys(ordered, 0.0)
    step = _ROW_SPREAD / (len(ordered) - 1)
    return {name: -_ROW_SPREAD / 2 + step * i for i, name in enumerate(ordered)}


def _dot_panel(ax: Axes, rows: Sequence[Sequence[tuple[str, float]]], offsets: dict[str, float],
               controllers: Sequence[str], floor: float) -> bool:
    """One dot per (controller, value [unit]) in each row at the controller's offset, log x;
    the lowest of each row and those tying with it (:func:`ties`) outlined; values below
    ``floor`` (same unit) drawn at it as ``<`` on a shaded band; returns whether any is."""
    shown: list[float] = []
    below = False
    for row, values in enumerate(rows):
        finite = [value for _, value in values if math.isfinite(value) and value >= 0]
        best = min(finite, default=math.nan)
        for name, value in values:
            if not (math.isfinite(value) and value >= 0):
                continue
            lowest = len(offsets) > 1 and ties(best, value, floor)  # one controller: no rank
            under = value < floor
            below |= under
            shown.append(max(value, floor))
            ax.plot(max(value, floor), row + offsets[name], "<" if under else
                    ("o" if is_mpc(name) else "s"), color=colour(controllers, name),
                    ms=8 if lowest else (7 if under else 5.5), mec="k" if lowest else "none",
                    mew=1.1, zorder=3)
    ax.set_yticks(np.arange(len(rows)))
    ax.set_ylim(len(rows) - 0.5, -0.5)
    for row in range(len(rows) - 1):
        ax.axhline(row + 0.5, color="0.85", lw=0.6)
    if shown:
        low, high = min(shown) / 1.8, max(shown) * 1.8
        log_axis(ax, "x", low, high)
        if below:
            ax.axvspan(low, floor, color=FLOOR_COLOUR, zorder=0)
    ax.grid(True, axis="x", alpha=0.4)
    return below


def headline_figure(headline: Headline, runs: Sequence[Run]) -> Figure:
    """RMS position error [mm] and RMS heading error [deg] side by side (log x) of every
    ranked controller in each scenario in focus: one row per scenario, each controller at
    its own height within the row (MPC variants above, baselines below), the lowest of each
    row outlined (ties within the tolerance too); values below the floor drawn at it as
    ``<``. The legend is below the panels, on no data."""
    controllers = controllers_of(runs)
    rankings = headline.rankings
    ranked = list(dict.fromkeys(entry[0] for ranking in rankings for entry in ranking.entries))
    offsets = _offsets(ranked)
    count = max(len(rankings), 1)
    figure = new_figure(8.4, min(2.1 + 0.27 * count, 14.0), constrained=True)
    position, heading = figure.subplots(1, 2, sharey=True)
    rows_position = [[(name, 1e3 * rms) for name, rms, _ in r.entries] for r in rankings]
    rows_heading = [[(name, math.degrees(metric_value(runs[i], "rms_heading_error")))
                     for name, _, i in r.entries] for r in rankings]
    below = _dot_panel(position, rows_position, offsets, controllers, 1e3 * POSITION_FLOOR)
    below |= _dot_panel(heading, rows_heading, offsets, controllers,
                        math.degrees(HEADING_FLOOR))
    position.set_yticklabels([" / ".join(label for label in r.scenario[:3] if label != "-")
                              + (f" ({r.peak_ratio:.2f}\u00d7)" if math.isfinite(r.peak_ratio)
                                 else "") for r in rankings], fontsize="small")
    heading.tick_params(labelleft=False)
    position.set_xlabel("RMS position error [mm] (log)")
    heading.set_xlabel("RMS heading error [deg] (log)")
    position.set_title("position error", fontsize="medium")
    heading.set_title("heading error", fontsize="medium")
    handles: list[Artist] = [Line2D([], [], marker="o" if is_mpc(name) else "s", ls="",
                                    color=colour(controllers, name), label=name)
                             for name in ranked]
    if len(ranked) > 1:
        handles.append(Line2D([], [], marker="o", ls="", color="w", mec="k", ms=8,
                              label=f"lowest (ties within {TIE_TOLERANCE:.0%} too)"))
    if below:
        handles.append(Patch(color=FLOOR_COLOUR, label=f"below the floor ({1e3 * POSITION_FLOOR:g}"
                             f" mm, {math.degrees(HEADING_FLOOR):g} deg): drawn at it as <"))
    figure.legend(handles=handles, loc="outside lower center", fontsize="small",
                  ncols=min(len(handles), 4))
    focus = headline.focus if headline.single is None else "after the settling time"
    figure.suptitle(f"RMS errors {focus}: a row per scenario, a dot per controller",
                    fontsize="medium")
    return figure


# --------------------------------------------------------------------------- scenario overlay


def scenario_figure(runs: Sequence[Run], series: Sequence[Series], controllers: Sequence[str],
                    title: str) -> Figure:
    """Every controller of one scenario on one path plot [m], beside their position errors
    over time [mm] (log; path followers' distance to the path, dashed) with the settling
    window shaded and errors below the floor drawn on it; the legend below the plots;
    1000 x 460 px."""
    figure = new_figure(10.0, 4.6, constrained=True)
    path, errors = figure.subplots(1, 2, width_ratios=[1.0, 1.25])
    if series:
        reference = series[0].reference
        path.plot(reference[:, 0], reference[:, 1], "--", color="0.45", lw=1.2, label="reference")
        shade_skip(errors, float(series[0].time[0]) if len(series[0].time) else 0.0,
                   series[0].skip)
    floor = 1e3 * POSITION_FLOOR
    peak = 0.0
    below = False
    for run, data in zip(runs, series, strict=True):
        name = str(run["controller"])
        path.plot(data.pose[:, 0], data.pose[:, 1], color=colour(controllers, name), lw=1.3,
                  label=name)
        # a path follower's clock trails the reference's: its distance to the path instead
        distance = data.path_error if follows_path(run) else None
        along = distance is not None
        error = 1e3 * (data.position_error if distance is None else distance)
        finite = error[np.isfinite(error)]
        if finite.size:
            peak = max(peak, float(finite.max()))
            below |= bool((finite < floor).any())
        errors.plot(data.time, np.maximum(error, floor), color=colour(controllers, name),
                    lw=1.1, ls="--" if along else "-")
    path.set_aspect("equal", adjustable="datalim")
    path.set_xlabel("x [m]")
    path.set_ylabel("y [m]")
    path.grid(True, alpha=0.4)
    path.set_title("path", fontsize="medium")
    if peak > 0:
        low = floor / 2.0 if below else min(floor, peak) / 2.0
        log_axis(errors, "y", low, max(peak, floor) * 2.0)
        if below:
            errors.axhspan(low, floor, color=FLOOR_COLOUR, zorder=0.6,
                           label=f"below {floor:g} mm (floor): drawn on it")
    errors.set_xlabel("time [s]")
    errors.set_ylabel("position error, time-indexed [mm] (log);\ndashed: path followers' "
                      "distance to the path")
    errors.grid(True, alpha=0.4)
    errors.set_title("position error", fontsize="medium")
    handles, labels = path.get_legend_handles_labels()
    extra = errors.get_legend_handles_labels()
    figure.legend(handles + extra[0], labels + extra[1], loc="outside lower center",
                  fontsize="small", ncols=min(len(handles) + len(extra[0]), 6))
    figure.suptitle(title, fontsize="medium")
    return figure


# --------------------------------------------------------------------------- summary


def _metric_grid(runs: Sequence[Run], key: str, scale: float) -> np.ndarray:
    """``grid[s, c]`` = metric of the first run of scenario s and controller c (NaN if none)."""
    scenarios = list(dict.fromkeys(scenario_of(run) for run in runs))
    controllers = controllers_of(runs)
    grid = np.full((len(scenarios), len(controllers)), np.nan)
    for run in reversed(runs):
        row, column = scenarios.index(scenario_of(run)), controllers.index(str(run["controller"]))
        grid[row, column] = metric_value(run, key) * scale
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
        high = max(float(finite.max()), level if math.isfinite(level) else 0.0)
        log_axis(ax, "y", 10.0 ** math.floor(math.log10(float(finite.min())) - 0.5), 2.0 * high)
    ax.grid(True, axis="y", alpha=0.4)
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))


def summary_figure(runs: Sequence[Run], dt: float) -> Figure:
    """Per scenario and controller: RMS position error, peak wheel speed / limit (after the
    settling time) and median tick time, as grouped bars; ``dt`` [s] is marked."""
    scenarios = list(dict.fromkeys(scenario_of(run) for run in runs))
    controllers = controllers_of(runs)
    width = min(max(8.0, 2.0 + 0.25 * len(scenarios) * max(len(controllers), 1)), 32.0)
    figure = new_figure(width, 12.0, constrained=True)
    top, middle, bottom = figure.subplots(3, 1, sharex=True)
    no_line = (math.nan, "")
    _grouped_bars(top, _metric_grid(runs, "rms_position_error", 1e3), controllers, True, no_line)
    top.set_ylabel("RMS position error [mm]")
    top.set_title("RMS position error after the settling time (log)")
    _grouped_bars(middle, _metric_grid(runs, "max_wheel_speed_ratio", 1.0), controllers, False,
                  (1.0, "limit"))
    middle.set_ylabel("peak |wheel command| / limit [-]")
    middle.set_title("Peak wheel speed as a fraction of the limit, after the settling time")
    _grouped_bars(bottom, _metric_grid(runs, "tick_time_p50", 1e3), controllers, True,
                  (1e3 * dt, f"dt = {1e3 * dt:g} ms"))
    bottom.set_ylabel("tick time p50 [ms]")
    bottom.set_title("Median tick time (log)")
    bottom.set_xticks(np.arange(len(scenarios)))
    bottom.set_xticklabels([scenario_title(s) for s in scenarios],
                           rotation=30 if len(scenarios) > 3 else 0,
                           ha="right" if len(scenarios) > 3 else "center")
    bottom.set_xlabel("scenario (layout / trajectory / heading / speed)")
    figure.suptitle("Controllers across scenarios", fontsize="large")
    return figure


def write_summary_figure(runs: Sequence[Run], dt: float, path: Path) -> None:
    save(summary_figure(runs, dt), path)


# --------------------------------------------------------------------------- pace


def write_pace_figure(runs: Sequence[Run], path: Path) -> bool:
    """Lap time against path error, every scenario with a lap to time, one panel per speed:
    who is fastest on the path. x: steady lap / the fastest lap the run could keep (1 = the
    time-optimal lap, or the reference's own period where that is slower); y: the largest
    distance from the path after the settling time [mm]. Returns False if no run has a lap."""
    timed = [run for run in runs if math.isfinite(pace_of(run))]
    if not timed:
        return False
    speeds = list(dict.fromkeys(str(run["speed"]) for run in timed))
    controllers = controllers_of(runs)
    figure = new_figure(5.2 * len(speeds) + 0.6, 4.4, constrained=True)
    axes = np.atleast_1d(figure.subplots(1, len(speeds), squeeze=False)).ravel()
    for ax, speed in zip(axes, speeds, strict=True):
        chosen = [run for run in timed if str(run["speed"]) == speed]
        floor = 1e3 * POSITION_FLOOR
        shown = []
        for run in chosen:
            error = max(metric_value(run, "max_cross_track_error") * 1e3, floor)
            shown.append(error)
            ax.scatter(pace_of(run), error, color=colour(controllers, str(run["controller"])),
                       s=22, alpha=0.8, zorder=3)
        ax.axvline(1.0, color="0.5", lw=0.8, ls="--")
        finite = [value for value in shown if math.isfinite(value)]
        if finite:
            log_axis(ax, "y", min(finite) / 2.0, max(finite) * 2.0)
        paces = [pace_of(run) for run in chosen]
        ax.set_xlim(min(min(paces), 0.98) - 0.01, max(max(paces), 1.02) + 0.01)  # >= 2 % wide
        ax.xaxis.set_major_formatter(ScalarFormatter(useOffset=False))
        scenarios = len({scenario_of(run) for run in chosen})
        ax.set_title(f"{speed}: {scenarios} scenario{'s' if scenarios != 1 else ''}",
                     fontsize="medium")
        ax.set_xlabel("lap / fastest possible lap")
        ax.grid(True, alpha=0.4)
    axes[0].set_ylabel("max path error after settling [mm]")
    handles = [Line2D([], [], marker="o", ls="", color=colour(controllers, name), label=name)
               for name in controllers]
    figure.legend(handles=handles, loc="outside lower center", ncols=min(len(controllers), 7))
    figure.suptitle("Pace and path error of every run\nleft of 1: faster than the path allows "
                    "(it cuts corners); high: off the path", fontsize="medium")
    save(figure, path)
    return True
