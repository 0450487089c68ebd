"""One run's 2x2 figure: (a) path with footprints and the predicted paths, (b) tracking
errors, (c) wheel commands against their limits, (d) tick times.

The time plots (b, c) shade the settling window (the first ``skip`` seconds, left out of
the metrics). Lengths are shown in mm on the error plot and m on the path, angles in deg,
wheel speeds in rad/s, tick times in ms.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure

from .outline import footprint, place
from .results import Run, Series, format_value, metric_value, run_title
from .style import log_axis, new_figure, save, shade_skip, wrap_degrees

N_FOOTPRINTS = 8
N_PLANS = 12  # predicted paths drawn on the path plot (evenly spread over the kept ones)
LOG_SPREAD = 30.0  # the tick-time histogram goes logarithmic beyond this max/min ratio
PLAN_COLOUR = "C1"


def _draw_plans(ax: Axes, data: Series) -> None:
    """The controller's predicted paths (x, y of its plans), a few spread over the run."""
    plans = data.predicted_pose
    if plans is None or len(plans) == 0:
        return
    chosen = np.unique(np.linspace(0, len(plans) - 1, min(N_PLANS, len(plans))).round())
    segments = [plan[np.all(np.isfinite(plan), axis=1), :2] for plan in plans[chosen.astype(int)]]
    segments = [segment for segment in segments if len(segment) > 1]
    if segments:
        label = f"predicted path ({len(segments)} plans)"
        ax.add_collection(LineCollection(segments, colors=PLAN_COLOUR, linewidths=1.2,
                                         alpha=0.8, label=label))


def draw_path(ax: Axes, data: Series, robot: Mapping[str, Any]) -> None:
    """Reference, robot path, footprints with heading arrows, start, predicted paths [m]."""
    ax.set_title("(a) path", loc="left")
    ax.plot(data.reference[:, 0], data.reference[:, 1], "--", color="0.45", label="reference")
    ax.plot(data.pose[:, 0], data.pose[:, 1], color="C0", lw=1.5, label="robot")
    _draw_plans(ax, data)
    if len(data.pose):
        extent = float(np.ptp(np.vstack([data.pose[:, :2], data.reference[:, :2]]), axis=0).max())
        outline = footprint(robot.get("wheel_positions"), max(0.03 * extent, 0.01))
        ticks = np.unique(np.linspace(0, len(data.pose) - 1, N_FOOTPRINTS).round().astype(int))
        poses = data.pose[ticks]
        ax.add_collection(PolyCollection(
            [place(outline, pose) for pose in poses], facecolors=(0.12, 0.47, 0.71, 0.08),
            edgecolors="C0", linewidths=0.8, label="footprint"))
        arrow = 0.8 * float(np.max(np.linalg.norm(outline, axis=1)))
        ax.quiver(poses[:, 0], poses[:, 1], arrow * np.cos(poses[:, 2]),
                  arrow * np.sin(poses[:, 2]), angles="xy", scale_units="xy", scale=1.0,
                  color="C3", width=0.005, label="heading")
        ax.plot(data.pose[0, 0], data.pose[0, 1], "o", color="C2", ms=8, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.4)
    # above the axes, right of the title: inside it would cover footprints or plans
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=3, fontsize="small",
              frameon=False, borderaxespad=0.2, columnspacing=1.0, handlelength=1.6)


def wheel_names(run: Run, count: int) -> list[str]:
    """The run's robot's wheel names (``FL``, ``FR``...; ``robot.wheel_names`` of the run
    record) when it has ``count`` of them; for records without them, named from the wheel
    positions as :attr:`mpc.robots.Robot.wheel_names` does; else ``wheel 1..count``."""
    from mpc.robots.base import quadrant_names

    robot = run.get("robot")
    robot = robot if isinstance(robot, Mapping) else {}
    names = robot.get("wheel_names")
    if (isinstance(names, list) and len(names) == count
            and all(isinstance(name, str) and name for name in names)):
        return list(names)
    try:
        named = quadrant_names(robot.get("wheel_positions", []))
    except (TypeError, ValueError):
        named = None
    if named is not None and len(named) == count:
        return list(named)
    unit = "module" if robot.get("kind") in ("swerve", "caster") else "wheel"
    return [f"{unit} {i}" for i in range(1, count + 1)]


def _draw_errors(ax: Axes, data: Series) -> None:
    ax.set_title("(b) tracking error")
    start = float(data.time[0]) if len(data.time) else 0.0
    shade_skip(ax, start, data.skip)
    lines: list[Artist] = [*ax.patches]
    lines += ax.plot(data.time, 1e3 * data.position_error, color="C0",
                     label="position error, time-indexed [mm]")
    if data.path_error is not None:
        lines += ax.plot(data.time, 1e3 * data.path_error, color="C2", lw=1.0, ls="--",
                         label="path (contouring) error [mm]")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position error [mm]", color="C0")
    ax.grid(True, alpha=0.4)
    twin = ax.twinx()
    heading_deg = wrap_degrees(data.pose[:, 2] - data.reference[:, 2])
    lines += twin.plot(data.time, heading_deg, color="C1", lw=1.0, label="heading error [deg]")
    twin.set_ylabel("heading error [deg]", color="C1")
    if data.fallback.any():
        fallback_times = data.time[data.fallback]
        lines.append(ax.vlines(fallback_times, 0, 1, transform=ax.get_xaxis_transform(),
                               color="C3", alpha=0.3, lw=0.8,
                               label=f"fallback ticks ({len(fallback_times)})"))
    _headroom(ax)  # the legend sits above the traces, not on them
    _headroom(twin)
    ax.legend(lines, [str(line.get_label()) for line in lines], loc="upper right",
              fontsize="small")


def _draw_wheels(ax: Axes, data: Series, names: list[str]) -> None:
    count = len(data.wheel_command)
    time = data.time[:count]
    ax.set_title(f"(c) wheel commands ({_peak_text(data.wheel_ratio, data)})")
    if count:
        shade_skip(ax, float(time[0]), data.skip)
    for wheel in range(data.wheel_command.shape[1]):
        ax.plot(time, data.wheel_command[:, wheel], color=f"C{wheel % 10}", lw=1.0,
                label=names[wheel])
    limits = np.unique(data.wheel_limit[np.isfinite(data.wheel_limit) & (data.wheel_limit > 0)])
    for index, limit in enumerate(limits):
        if index == 0:
            ax.axhspan(-limit, limit, color="0.95", zorder=0,
                       label=f"\u00b1 limit ({limit:g} rad/s)")
        ax.axhline(limit, color="k", ls="--", lw=1.0)
        ax.axhline(-limit, color="k", ls="--", lw=1.0)
    if count == 0:
        ax.text(0.5, 0.5, "no wheel commands", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("commanded wheel speed [rad/s]")
    ax.grid(True, alpha=0.4)
    if ax.get_legend_handles_labels()[0]:
        _headroom(ax)  # above the +limit line and the traces that reach it
        ax.legend(loc="upper right", fontsize="small", ncol=2)


def _draw_steering(ax: Axes, data: Series, names: list[str]) -> None:
    """(e) each steered wheel's turn rate [rad/s] against its limit."""
    rates, limits = data.steer_rate, data.steer_rate_limit
    assert rates is not None and limits is not None
    time = data.time[:len(rates)]
    finite = np.isfinite(limits) & (limits > 0)
    ratio = (np.abs(rates[:, finite]) / limits[finite]).max(axis=1) if finite.any() else (
        np.full(len(rates), np.nan))
    ax.set_title(f"(e) steering rates ({_peak_text(ratio, data)})")
    if len(time):
        shade_skip(ax, float(time[0]), data.skip)
    for wheel in range(rates.shape[1]):
        ax.plot(time, rates[:, wheel], color=f"C{wheel % 10}", lw=1.0, label=names[wheel])
    for index, limit in enumerate(np.unique(limits[finite])):
        label = f"\u00b1 limit ({limit:g} rad/s)" if index == 0 else None
        ax.axhline(limit, color="k", ls="--", lw=1.0, label=label)
        ax.axhline(-limit, color="k", ls="--", lw=1.0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("steering rate [rad/s]")
    ax.grid(True, alpha=0.4)
    if ax.get_legend_handles_labels()[0]:
        _headroom(ax)
        ax.legend(loc="upper right", fontsize="small", ncol=3)


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
        ax.hist(positive, bins=np.geomspace(low, high, 40).tolist(), color="C0",
                label=f"ticks (n={len(tick_ms)})")
        log_axis(ax, "x", min(low, dt_ms) / 1.2, max(high, dt_ms) * 1.2)
    else:
        ax.hist(tick_ms, bins=40, color="C0", label=f"ticks (n={len(tick_ms)})")
    # up to the bars' headroom only: the legend sits above it
    ax.axvline(dt_ms, ymax=1.0 - _LEGEND_ROOM, color="C3", ls="--", label=f"dt = {dt_ms:g} ms")
    solve_p50 = metric_value(run, "solve_time_p50")
    solve_text = "0 (no solver)" if solve_p50 == 0 else f"{format_value(solve_p50, 1e3)} ms"
    ax.plot([], [], " ", label=f"solve time p50 = {solve_text}")
    ax.set_xlabel("tick time [ms]" + (" (log)" if logarithmic else ""))
    ax.set_ylabel("ticks")
    ax.grid(True, alpha=0.4)
    _headroom(ax)  # "best" would still cover a few short bars
    ax.legend(loc="upper right", fontsize="small")


def run_figure(run: Run, data: Series) -> Figure:
    """The 2x2 figure of one run (a run record and its series as arrays), 1200 x 900 px;
    with steered wheels a third row, (e) their steering rates against the limit (1200 x
    1200 px)."""
    steered = data.steer_rate is not None
    figure = new_figure(12.0, 12.0 if steered else 9.0, constrained=False)
    figure.subplots_adjust(left=0.065, right=0.93, bottom=0.05 if steered else 0.065,
                           top=0.915 if steered else 0.89, wspace=0.28,
                           hspace=0.32 if steered else 0.27)
    grid = figure.add_gridspec(3 if steered else 2, 2)
    axes = np.array([[figure.add_subplot(grid[row, column]) for column in range(2)]
                     for row in range(2)])
    robot = run.get("robot")
    draw_path(axes[0, 0], data, robot if isinstance(robot, Mapping) else {})
    _draw_errors(axes[0, 1], data)
    names = wheel_names(run, data.wheel_command.shape[1])
    _draw_wheels(axes[1, 0], data, names)
    _draw_tick_histogram(axes[1, 1], data, run)
    if data.steer_rate is not None:
        _draw_steering(figure.add_subplot(grid[2, :]), data,
                       wheel_names(run, data.steer_rate.shape[1]))
    figure.suptitle(run_title(run), fontsize="large")
    return figure


def write_run_figure(run: Run, data: Series, path: Path) -> None:
    """:func:`run_figure` saved as a PNG at ``path``."""
    save(run_figure(run, data), path)


def _peak_text(ratio: np.ndarray, data: Series) -> str:
    """``"peak 1.00x limit after 2 s"``: the largest of a per-tick ratio (K,) to its limit
    over the ticks the metrics cover."""
    scored = ratio[data.scored[:len(ratio)]] if len(ratio) else ratio
    peak = float(np.nanmax(scored)) if scored.size and np.isfinite(scored).any() else np.nan
    after = f" after {data.skip:g} s" if data.skip > 0 else ""
    shown = f"{peak:.2f}" if np.isfinite(peak) else format_value(peak)
    return f"peak {shown}\u00d7 limit{after}"


#: Of an axes' height, the part kept free above its data for the legend.
_LEGEND_ROOM = 0.35


def _headroom(ax: Axes) -> None:
    """Raise the top of ``ax`` so that its data fill the lower part and the legend
    (upper right) covers none of it."""
    low, high = ax.get_ylim()
    if ax.get_yscale() == "linear" and np.isfinite(low) and np.isfinite(high) and high > low:
        ax.set_ylim(low, high + (high - low) * _LEGEND_ROOM / (1.0 - _LEGEND_ROOM))
