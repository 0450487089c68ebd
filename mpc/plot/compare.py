"""Figures across runs: the headline bars, one path overlay per scenario, the summary bars
and the pace scatter. Controllers keep one colour everywhere (order of first appearance).

Lengths on path plots in m, errors in mm, times in s (tick times in ms).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import ScalarFormatter

from .headline import Headline, follows_path
from .results import Run, Series, metric_value, pace_of, scenario_of
from .style import new_figure, save, shade_skip


def controllers_of(runs: Sequence[Run]) -> list[str]:
    """Controller names in order of first appearance (their colour index)."""
    return list(dict.fromkeys(str(run["controller"]) for run in runs))


def colour(controllers: Sequence[str], name: str) -> str:
    """The colour of ``name`` on every figure of a report."""
    return f"C{list(controllers).index(name) % 10}"


# --------------------------------------------------------------------------- headline


def headline_figure(headline: Headline, runs: Sequence[Run]) -> Figure:
    """RMS position error [mm] (log x) of every controller in each scenario in focus: one
    row per scenario, one dot per controller, the winner's dot larger and outlined."""
    controllers = controllers_of(runs)
    count = max(len(headline.rankings), 1)
    figure = new_figure(6.4, min(1.9 + 0.3 * count, 12.0), constrained=True)
    ax = figure.subplots()
    finite: list[float] = []
    for row, ranking in enumerate(headline.rankings):
        for controller, rms, _ in ranking.entries:
            if not (math.isfinite(rms) and rms > 0):
                continue
            best = controller == ranking.winner
            ax.plot(1e3 * rms, row, "o", color=colour(controllers, controller),
                    ms=10 if best else 6, mec="k" if best else "none", mew=1.2, zorder=3)
            finite.append(1e3 * rms)
    ax.set_yticks(np.arange(len(headline.rankings)))
    ax.set_yticklabels([" / ".join(r.scenario[:3])
                        + (f" ({r.peak_ratio:.2f}\u00d7)" if math.isfinite(r.peak_ratio)
                           else f" ({r.scenario[3]})") for r in headline.rankings],
                       fontsize="small")
    ax.set_ylim(len(headline.rankings) - 0.5, -0.5)
    if finite:
        ax.set_xscale("log")
        ax.set_xlim(10.0 ** math.floor(math.log10(min(finite)) - 0.3), 2.0 * max(finite))
    ax.set_xlabel("RMS position error after the settling time [mm] (log)")
    ax.grid(True, alpha=0.4)
    ranked = {entry[0] for ranking in headline.rankings for entry in ranking.entries}
    handles = [Line2D([], [], marker="o", ls="", color=colour(controllers, name), label=name)
               for name in controllers if name in ranked]  # path followers are not ranked
    ax.legend(handles=handles, fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title(f"RMS position error {headline.focus} (winner outlined)", fontsize="medium")
    return figure


# --------------------------------------------------------------------------- scenario overlay


def scenario_figure(runs: Sequence[Run], series: Sequence[Series], controllers: Sequence[str],
                    title: str) -> Figure:
    """Every controller of one scenario on one path plot [m], beside their position errors
    over time [mm] (log; path followers' distance to the path, dashed) with the settling
    window shaded; 1000 x 420 px."""
    figure = new_figure(10.0, 4.2, constrained=True)
    path, errors = figure.subplots(1, 2, width_ratios=[1.0, 1.25])
    if series:
        reference = series[0].reference
        path.plot(reference[:, 0], reference[:, 1], "--", color="0.45", lw=1.2, label="reference")
        shade_skip(errors, float(series[0].time[0]) if len(series[0].time) else 0.0,
                   series[0].skip)
    floor = math.inf
    for run, data in zip(runs, series, strict=True):
        name = str(run["controller"])
        path.plot(data.pose[:, 0], data.pose[:, 1], color=colour(controllers, name), lw=1.3,
                  label=name)
        # a path follower's clock trails the reference's: its distance to the path instead
        distance = data.path_error if follows_path(run) else None
        along = distance is not None
        error = 1e3 * (data.position_error if distance is None else distance)
        positive = error[error > 0]
        if positive.size:
            floor = min(floor, float(positive.min()))
        errors.plot(data.time, error, color=colour(controllers, name), lw=1.1,
                    ls="--" if along else "-", label=name)
    path.set_aspect("equal", adjustable="datalim")
    path.set_xlabel("x [m]")
    path.set_ylabel("y [m]")
    path.grid(True, alpha=0.4)
    path.set_title("path", fontsize="medium")
    path.legend(fontsize="x-small", loc="best")
    if math.isfinite(floor):
        errors.set_yscale("log")
        errors.set_ylim(bottom=max(floor, 1e-4))
    errors.set_xlabel("time [s]")
    errors.set_ylabel("position error, time-indexed [mm] (log);\ndashed: path followers' "
                      "distance to the path")
    errors.grid(True, alpha=0.4)
    errors.set_title("position error", fontsize="medium")
    if errors.patches:
        errors.legend(handles=[errors.patches[0]], fontsize="x-small", loc="lower right")
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
        ax.set_yscale("log")
        high = max(float(finite.max()), level if math.isfinite(level) else 0.0)
        ax.set_ylim(10.0 ** math.floor(math.log10(float(finite.min())) - 0.5), 2.0 * high)
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
    bottom.set_xticklabels([" / ".join(s) for s in scenarios],
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
        for run in chosen:
            error = max(metric_value(run, "max_cross_track_error") * 1e3, 1e-3)
            ax.scatter(pace_of(run), error, color=colour(controllers, str(run["controller"])),
                       s=22, alpha=0.8, zorder=3)
        ax.axvline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_yscale("log")
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
