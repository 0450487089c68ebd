"""Report figures: one 2x2 figure per run and the summary figure across scenarios.

Draws on :class:`matplotlib.figure.Figure` objects rendered by the Agg canvas, so it
needs no display and leaves no global pyplot state behind. Lengths are shown in mm,
angles in deg and times in ms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .results import Run, Series, format_value, metric_value, pace_of, run_title, scenario_of

FIGURE_DPI = 100
N_FOOTPRINTS = 8
LOG_SPREAD = 30.0  # the tick-time histogram goes logarithmic beyond this max/min ratio


def _wrap_degrees(angle: np.ndarray) -> np.ndarray:
    """Wrap angles [rad] into (-180, 180] [deg]."""
    return np.degrees(np.pi - np.mod(np.pi - angle, 2.0 * np.pi))


# --------------------------------------------------------------------------- run figure


def _new_figure(width: float, height: float, constrained: bool) -> Figure:
    """A figure of ``width`` x ``height`` [inches] on its own Agg canvas (no pyplot).

    Constrained layout places legends and rotated labels well but takes about as long
    as drawing, so the per-run figures (64 of them) use fixed margins instead.
    """
    figure = Figure(
        figsize=(width, height), dpi=FIGURE_DPI, layout="constrained" if constrained else None
    )
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


def _draw_path(ax: Axes, data: Series, robot: Mapping[str, Any]) -> None:
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
        ax.quiver(
            poses[:, 0],
            poses[:, 1],
            arrow * np.cos(poses[:, 2]),
            arrow * np.sin(poses[:, 2]),
            angles="xy",
            scale_units="xy",
            scale=1.0,
            color="C3",
            width=0.005,
            label="heading",
        )
        ax.plot(data.pose[0, 0], data.pose[0, 1], "o", color="C2", ms=8, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.4)
    ax.legend(loc="best", fontsize="small")


def _draw_errors(ax: Axes, data: Series) -> None:
    ax.set_title("(b) tracking error")
    difference = data.pose - data.reference
    position_mm = 1e3 * np.hypot(difference[:, 0], difference[:, 1])
    heading_deg = _wrap_degrees(difference[:, 2])
    lines: list[Artist] = [
        *ax.plot(data.time, position_mm, color="C0", label="position error [mm]")
    ]
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position error [mm]", color="C0")
    ax.grid(True, alpha=0.4)
    twin = ax.twinx()
    lines += twin.plot(data.time, heading_deg, color="C1", lw=1.0, label="heading error [deg]")
    twin.set_ylabel("heading error [deg]", color="C1")
    if data.fallback.any():
        fallback_times = data.time[data.fallback]
        lines.append(
            ax.vlines(
                fallback_times,
                0,
                1,
                transform=ax.get_xaxis_transform(),
                color="C3",
                alpha=0.3,
                lw=0.8,
                label=f"fallback ticks ({len(fallback_times)})",
            )
        )
    ax.legend(lines, [str(line.get_label()) for line in lines], loc="upper right", fontsize="small")


def _draw_wheels(ax: Axes, data: Series) -> None:
    ax.set_title("(c) wheel commands")
    count = len(data.wheel_command)
    time = data.time[:count]
    for wheel in range(data.wheel_command.shape[1]):
        ax.plot(
            time,
            data.wheel_command[:, wheel],
            color=f"C{wheel % 10}",
            lw=1.0,
            label=f"wheel {wheel}",
        )
    limits = np.unique(data.wheel_limit[np.isfinite(data.wheel_limit) & (data.wheel_limit > 0)])
    for index, limit in enumerate(limits):
        if index == 0:
            ax.axhspan(
                -limit, limit, color="0.9", zorder=0, label=f"\u00b1 limit ({limit:g} rad/s)"
            )
        ax.axhline(limit, color="k", ls="--", lw=1.0)
        ax.axhline(-limit, color="k", ls="--", lw=1.0)
    if count == 0:
        ax.text(0.5, 0.5, "no wheel commands", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("commanded wheel speed [rad/s]")
    ax.grid(True, alpha=0.4)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize="small", ncol=2)


def _draw_tick_histogram(ax: Axes, data: Series, run: Run) -> None:
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
        ax.hist(
            positive,
            bins=np.geomspace(low, high, 40).tolist(),
            color="C0",
            label=f"ticks (n={len(tick_ms)})",
        )
        ax.set_xscale("log")
    else:
        ax.hist(tick_ms, bins=40, color="C0", label=f"ticks (n={len(tick_ms)})")
    ax.axvline(dt_ms, color="C3", ls="--", label=f"dt = {dt_ms:g} ms")
    solve_p50 = metric_value(run, "solve_time_p50")
    solve_text = "0 (no solver)" if solve_p50 == 0 else f"{format_value(solve_p50, 1e3)} ms"
    ax.plot([], [], " ", label=f"solve time p50 = {solve_text}")
    ax.set_xlabel("tick time [ms]" + (" (log)" if logarithmic else ""))
    ax.set_ylabel("ticks")
    ax.grid(True, alpha=0.4)
    ax.legend(loc="best", fontsize="small")


def write_run_figure(run: Run, data: Series, path: Path) -> None:
    figure = _new_figure(12.0, 9.0, constrained=False)
    figure.subplots_adjust(
        left=0.065, right=0.94, bottom=0.065, top=0.925, wspace=0.28, hspace=0.27
    )
    axes = figure.subplots(2, 2)
    robot = run.get("robot")
    robot = robot if isinstance(robot, Mapping) else {}
    _draw_path(axes[0, 0], data, robot)
    _draw_errors(axes[0, 1], data)
    _draw_wheels(axes[1, 0], data)
    _draw_tick_histogram(axes[1, 1], data, run)
    figure.suptitle(run_title(run), fontsize="large")
    _save(figure, path)


# --------------------------------------------------------------------------- summary figure


def _scenarios_and_controllers(
        runs: Sequence[Run]) -> tuple[list[tuple[str, str, str, str]], list[str]]:
    """Scenarios and controllers in order of first appearance."""
    scenarios = list(dict.fromkeys(scenario_of(run) for run in runs))
    controllers = list(dict.fromkeys(str(run["controller"]) for run in runs))
    return scenarios, controllers


def _metric_grid(runs: Sequence[Run], key: str, scale: float) -> np.ndarray:
    """``grid[s, c]`` = metric of the first run of scenario s and controller c (NaN if none)."""
    scenarios, controllers = _scenarios_and_controllers(runs)
    grid = np.full((len(scenarios), len(controllers)), np.nan)
    for run in reversed(runs):
        row, column = scenarios.index(scenario_of(run)), controllers.index(str(run["controller"]))
        grid[row, column] = metric_value(run, key) * scale
    return grid


def _grouped_bars(
    ax: Axes, grid: np.ndarray, controllers: Sequence[str], log: bool, line: tuple[float, str]
) -> None:
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
            ax.annotate(
                "inf",
                (x, 0.98),
                xycoords=("data", "axes fraction"),
                ha="center",
                va="top",
                rotation=90,
                color=f"C{column % 10}",
                fontsize="small",
            )
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


def write_summary_figure(runs: Sequence[Run], dt: float, path: Path) -> None:
    scenarios, controllers = _scenarios_and_controllers(runs)
    width = min(max(8.0, 2.0 + 0.25 * len(scenarios) * max(len(controllers), 1)), 32.0)
    figure = _new_figure(width, 12.0, constrained=True)
    top, middle, bottom = figure.subplots(3, 1, sharex=True)
    no_line = (math.nan, "")
    _grouped_bars(top, _metric_grid(runs, "rms_position_error", 1e3), controllers, True, no_line)
    top.set_ylabel("RMS position error [mm]")
    top.set_title("RMS position error (log)")
    _grouped_bars(
        middle, _metric_grid(runs, "max_wheel_speed_ratio", 1.0), controllers, False, (1.0, "limit")
    )
    middle.set_ylabel("max wheel speed / limit [-]")
    middle.set_title("Peak wheel speed as a fraction of the limit")
    _grouped_bars(
        bottom,
        _metric_grid(runs, "tick_time_p50", 1e3),
        controllers,
        True,
        (1e3 * dt, f"dt = {1e3 * dt:g} ms"),
    )
    bottom.set_ylabel("tick time p50 [ms]")
    bottom.set_title("Median tick time (log)")
    bottom.set_xticks(np.arange(len(scenarios)))
    bottom.set_xticklabels(
        [" / ".join(s) for s in scenarios],
        rotation=30 if len(scenarios) > 3 else 0,
        ha="right" if len(scenarios) > 3 else "center",
    )
    bottom.set_xlabel("scenario (layout / trajectory / heading / speed)")
    figure.suptitle("Controllers across scenarios", fontsize="large")
    _save(figure, path)


# --------------------------------------------------------------------------- pace figure


def write_pace_figure(runs: Sequence[Run], path: Path) -> bool:
    """Lap time against path error, one panel per scenario with a lap to time: who is
    fastest on the path. x: steady lap / the fastest lap the run could keep (1 = the
    time-optimal lap, or the reference's own period where that is slower); y: the largest
    distance from the path after the settling time. Returns False if no run has a lap."""
    timed = [run for run in runs if math.isfinite(pace_of(run))]
    if not timed:
        return False
    scenarios, controllers = _scenarios_and_controllers(timed)
    columns = min(4, len(scenarios))
    rows = math.ceil(len(scenarios) / columns)
    figure = _new_figure(3.2 * columns + 2.0, 2.8 * rows + 0.8, constrained=True)
    axes = np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()
    for ax, scenario in zip(axes, scenarios, strict=False):
        for run in timed:
            if scenario_of(run) != scenario:
                continue
            index = controllers.index(str(run["controller"]))
            error = max(metric_value(run, "max_cross_track_error") * 1e3, 1e-3)
            ax.scatter(pace_of(run), error, color=f"C{index % 10}", s=40, zorder=3,
                       label=str(run["controller"]))
        ax.axvline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_yscale("log")
        ax.set_title(" / ".join(scenario), fontsize="small")
        ax.grid(True, alpha=0.4)
    for ax in axes[len(scenarios):]:
        ax.set_visible(False)
    for ax in axes[::columns]:
        ax.set_ylabel("max path error [mm]")
    for ax in axes[-columns:]:
        ax.set_xlabel("lap / fastest possible lap")
    handles = [Line2D([], [], marker="o", ls="", color=f"C{i % 10}", label=name)
               for i, name in enumerate(controllers)]
    figure.legend(handles=handles, loc="outside lower center", ncols=min(len(controllers), 6))
    figure.suptitle("Pace and path error: left of 1 is faster than the path allows "
                    "(it cuts corners), high is off the path", fontsize="medium")
    _save(figure, path)
    return True
