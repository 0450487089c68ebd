"""The full table: one row per run, grouped by scenario, in Markdown (and cells for HTML).

Errors and peak ratios cover the ticks after the settling time; counts cover every tick.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .headline import HEADING_FLOOR, POSITION_FLOOR, follows_path, ties
from .results import Run, format_value, metric_value, pace_of, peak_ratio_text, scenario_of

# --------------------------------------------------------------------------- tables


@dataclass(frozen=True)
class _Column:
    """A metric column: header with unit, metric key, scale from SI to the shown unit."""

    title: str
    metric: str
    scale: float = 1.0
    floor: float = 0.0  # [SI] values below it read "< floor" (rounding, not tracking)


_METRIC_COLUMNS = (
    _Column("RMS pos. err. [mm]", "rms_position_error", 1e3, POSITION_FLOOR),
    _Column("max pos. err. [mm]", "max_position_error", 1e3, POSITION_FLOOR),
    _Column("RMS heading err. [deg]", "rms_heading_error", 180.0 / math.pi, HEADING_FLOOR),
    _Column("max path err. [mm]", "max_cross_track_error", 1e3, POSITION_FLOOR),
    _Column("lap / target", "pace"),
    _Column("max lag [s]", "max_lag"),
    _Column("peak wheel / limit", "max_wheel_speed_ratio"),
    _Column("limit viol. [ticks]", "limit_violations"),
    _Column("accel viol. [ticks]", "accel_violations"),
    _Column("peak steer rate / limit", "max_steer_rate_ratio"),
    _Column("steer viol. [ticks]", "steer_violations"),
    _Column("failures [ticks]", "failures"),
    _Column("tick p50 [ms]", "tick_time_p50", 1e3),
    _Column("tick p99 [ms]", "tick_time_p99", 1e3),
    _Column("deadline misses [ticks]", "deadline_misses"),
)
TABLE_HEADERS = ("layout", "trajectory", "heading", "speed", "reference peak / limit",
                 "controller") + tuple(
    column.title for column in _METRIC_COLUMNS
)
RMS_CELL = TABLE_HEADERS.index("RMS pos. err. [mm]")
CONTROLLER_CELL = TABLE_HEADERS.index("controller")


def failures_text(metrics: Mapping[str, Any]) -> str:
    """``"3 (previous_plan: 3)"``; just the count when there is no breakdown."""
    count = format_value(metrics.get("failures"))
    by_status = metrics.get("failures_by_status")
    if not isinstance(by_status, Mapping) or not by_status:
        return count
    details = ", ".join(f"{status}: {format_value(n)}" for status, n in by_status.items())
    return f"{count} ({details})"


def _row_cells(run: Run) -> list[str]:
    """The plain-text cells of one run's table row, in the order of TABLE_HEADERS."""
    cells = [*scenario_of(run), peak_ratio_text(run), str(run["controller"])]
    for column in _METRIC_COLUMNS:
        if column.metric == "failures":
            cells.append(failures_text(run["metrics"]))
        elif column.metric == "pace":
            cells.append(format_value(pace_of(run)))
        elif 0 <= metric_value(run, column.metric) < column.floor:
            cells.append(f"< {column.floor * column.scale:.2g}")
        else:
            cells.append(format_value(run["metrics"].get(column.metric), column.scale))
    return cells


Row = tuple[str, list[str], bool]  # run id, plain-text cells, ties the best RMS of its scenario


def grouped_rows(runs: Sequence[Run], ids: Sequence[str]) -> list[list[Row]]:
    """Rows grouped by scenario: ``(run id, cells, ties the best RMS of its scenario)``
    (:func:`~mpc.plot.headline.ties`: within the tolerance, or both below the floor)."""
    groups: dict[tuple[str, str, str, str], list[int]] = {}
    for index, run in enumerate(runs):
        groups.setdefault(scenario_of(run), []).append(index)
    table = []
    for members in groups.values():
        rms = [metric_value(runs[i], "rms_position_error") for i in members]
        # path followers' position error is against the point they track: not ranked
        finite = [value for i, value in zip(members, rms, strict=True)
                  if math.isfinite(value) and not follows_path(runs[i])]
        best = min(finite) if finite else math.nan
        table.append(
            [
                (ids[i], _row_cells(runs[i]),
                 ties(best, value, POSITION_FLOOR) and not follows_path(runs[i]))
                for i, value in zip(members, rms, strict=True)
            ]
        )
    return table


def markdown_table(groups: Sequence[Sequence[Row]]) -> str:
    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |"

    lines = [line(TABLE_HEADERS), line(["---"] * len(TABLE_HEADERS))]
    for group in groups:
        for _, cells, best in group:
            shown = list(cells)
            if best:
                shown[RMS_CELL] = f"**{shown[RMS_CELL]}**"
            lines.append(line(shown))
    return "\n".join(lines) + "\n"
