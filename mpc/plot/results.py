"""Runs as the figures and the report read them: loading, validation, values, series.

Works on the plain dicts and lists of ``results.json`` and of :func:`~mpc.plot.run_record`
(SI units: m, rad, s, rad/s); imports neither matplotlib nor a solver.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mpc.errors import ReportError
from mpc.validation import file_text, parsed
from mpc.validation import shown as _shown

REQUIRED_RUN_KEYS = ("layout", "trajectory", "speed", "controller", "metrics", "series")
REQUIRED_SERIES_KEYS = ("time", "pose", "reference")

Run = Mapping[str, Any]


# --------------------------------------------------------------------------- loading


def load_results(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read and validate a ``results.json`` (written by ``mpc-bench`` or
    :func:`~mpc.plot.report`).

    Raises:
        ReportError: the file is missing or unreadable, is not JSON, or lacks
            ``"runs"`` or a required key of a run (the message names it).
    """
    text = file_text(path, "results", ReportError)
    file = Path(path)
    results = parsed(json.loads, text, f"results file {str(file)!r}", "JSON", ReportError)
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
    """``"{layout}-{trajectory}-{heading}-{speed}-{controller}"`` (no heading part for runs
    without one), safe as a file name and an HTML id.

    Characters other than letters, digits, ``.``, ``_``, ``+`` and ``-`` become ``_``.
    """
    heading = (run["heading"],) if "heading" in run else ()
    return safe_name((run["layout"], run["trajectory"], *heading, run["speed"],
                      run["controller"]))


def safe_name(parts: Sequence[object]) -> str:
    """``parts`` joined by ``-``, each with characters other than letters, digits, ``.``,
    ``_``, ``+`` and ``-`` replaced by ``_`` (a file name and an HTML id)."""
    return "-".join(re.sub(r"[^A-Za-z0-9._+-]+", "_", str(part)) for part in parts)


def unique_run_ids(runs: Sequence[Run]) -> list[str]:
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


def metric_value(run: Run, key: str) -> float:
    """A metric as a float; NaN when missing, null or not a number."""
    value = run["metrics"].get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return math.nan
    return float(value)


def counted(number: int, noun: str) -> str:
    """``"1 scenario"``, ``"2 scenarios"``."""
    return f"{number} {noun}" + ("" if number == 1 else "s")


def format_value(value: object, scale: float = 1.0) -> str:
    """Format a number for the tables: ints as is, floats to 3 significant digits.

    ``value * scale`` is shown; infinities as ``inf``, missing values (and NaN: a lap time
    with no lap, say) as ``-``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return "-"
    if isinstance(value, int) and scale == 1.0:
        return str(value)
    shown = float(value) * scale
    if math.isnan(shown):
        return "-"
    if math.isinf(shown):
        return "inf" if shown > 0 else "-inf"
    if shown == 0.0:
        return "0"
    return f"{shown:.0f}" if abs(shown) >= 1000 else f"{shown:.3g}"


def scenario_of(run: Run) -> tuple[str, str, str, str]:
    """(layout, trajectory, heading, speed); runs without a heading count as fixed."""
    return (str(run["layout"]), str(run["trajectory"]), str(run.get("heading", "fixed")),
            str(run["speed"]))


def pace_of(run: Run) -> float:
    """Steady lap time / the fastest lap the run could keep (``target_lap``); NaN if unknown."""
    lap, target = run["metrics"].get("lap_time"), run.get("target_lap")
    if isinstance(lap, bool) or not isinstance(lap, (int, float)):
        return math.nan
    if isinstance(target, bool) or not isinstance(target, (int, float)) or not target > 0:
        return math.nan
    return float(lap) / float(target)


def peak_ratio_text(run: Run) -> str:
    """The reference's peak wheel speed / limit (``peak_ratio``) as ``"1.30"``, else ``-``."""
    ratio = run.get("peak_ratio")
    if isinstance(ratio, (int, float)) and math.isfinite(ratio):
        return f"{ratio:.2f}"
    return "-"


def scenario_title(scenario: Sequence[str], peak_ratio: str = "-") -> str:
    """``"mecanum / circle / fixed / beyond (reference asks 1.30x the wheel limit)"``; labels
    ``-`` (none given) left out."""
    asks = "" if peak_ratio == "-" else f" (reference asks {peak_ratio}\u00d7 the wheel limit)"
    return " / ".join(label for label in scenario if label not in ("-", "")) + asks


def run_title(run: Run) -> str:
    """``"mecanum / circle / fixed / beyond (reference asks 1.30x the wheel limit) / mpc"``."""
    return f"{scenario_title(scenario_of(run), peak_ratio_text(run))} / {run['controller']}"


# --------------------------------------------------------------------------- series


@dataclass(frozen=True)
class Series:
    """One run's time series as arrays, truncated to a common length K."""

    time: np.ndarray  # (K,) [s]
    pose: np.ndarray  # (K, 3) [m, m, rad]
    reference: np.ndarray  # (K, 3) [m, m, rad]
    wheel_command: np.ndarray  # (K, n) [rad/s]
    wheel_limit: np.ndarray  # (n,) [rad/s]
    tick_time: np.ndarray  # (<=K,) [s]
    fallback: np.ndarray  # (K,) bool, True where the status is not "solved"
    dt: float  # [s]
    skip: float = 0.0  # [s] settling time left out of the metrics (shaded)
    path_error: np.ndarray | None = None  # (K,) [m] distance to the reference's path
    predicted_tick: np.ndarray | None = None  # (M,) ticks whose plan was kept
    predicted_pose: np.ndarray | None = None  # (M, P, 3) [m, m, rad] those plans
    steer_rate: np.ndarray | None = None  # (K, n) [rad/s] steered wheels' turn rates
    steer_rate_limit: np.ndarray | None = None  # (n,) [rad/s] their limits

    @property
    def position_error(self) -> np.ndarray:
        """Distance to the time-indexed reference (K,) [m]."""
        return np.hypot(*(self.pose[:, :2] - self.reference[:, :2]).T)

    @property
    def scored(self) -> np.ndarray:
        """Ticks the metrics cover (K,) bool: from ``time[0] + skip`` on."""
        if len(self.time) == 0:
            return np.zeros(0, dtype=bool)
        return self.time >= self.time[0] + self.skip - 1e-12  # type: ignore[no-any-return]

    @property
    def wheel_ratio(self) -> np.ndarray:
        """Peak over the wheels of |command| / limit per tick (K,) (inf: a wheel with a
        zero limit asked to turn; NaN: no wheels)."""
        if self.wheel_command.size == 0 or self.wheel_limit.size != self.wheel_command.shape[1]:
            return np.full(len(self.wheel_command), np.nan)
        magnitude, limit = np.abs(self.wheel_command), self.wheel_limit
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(limit > 0, magnitude / np.where(limit > 0, limit, 1.0),
                             np.where(magnitude > 1e-12, np.inf, 0.0))
        return ratio.max(axis=1)  # type: ignore[no-any-return]


#: Largest magnitude of a value in a run's series: far past any pose, wheel speed or time a
#: run records (poses are bounded at 1e9 m), far from overflow when drawn.
_MAX_SERIES_VALUE = 1e12


def _float_array(series: Mapping[str, Any], key: str, columns: int | None, name: str) -> np.ndarray:
    """``series[key]`` as floats: flat if ``columns`` is None, else (K, columns), 0 for any width.

    A missing or null entry is empty; a ragged or non-numeric one a :class:`ReportError`.
    """
    values = series.get(key)
    try:
        array = np.asarray(values if values is not None else [], dtype=float)
    except (TypeError, ValueError) as error:
        raise ReportError(f"run {name}: series {key!r} is not numeric: {error}") from error
    bad = ~(np.abs(array) <= _MAX_SERIES_VALUE) & ~np.isnan(array)
    if key == "wheel_limit":  # an unlimited wheel is infinite by design
        bad &= ~np.isinf(array)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ReportError(
            f"run {name}: series {key!r} holds {float(array[index])!r} at index "
            f"{list(index)}; expected values within +-{_MAX_SERIES_VALUE:g} (a run records "
            "no larger)")
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


def run_skip(run: Run, default: float = 0.0) -> float:
    """The run's settling time [s]: its ``skip``, else ``default`` (the settings')."""
    value = run.get("skip")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0:
        return default
    return float(value)


def settings_value(results: Mapping[str, Any], key: str) -> float:
    """A number from ``meta.settings`` (e.g. ``dt`` [s], ``skip`` [s]); NaN when absent."""
    settings = (results.get("meta") or {}).get("settings") or {}
    value = settings.get(key) if isinstance(settings, Mapping) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return math.nan
    return float(value)


def read_series(run: Run, name: str, default_dt: float, default_skip: float = 0.0) -> Series:
    """A run's series as arrays (``name`` labels its errors); ``default_dt`` [s] and
    ``default_skip`` [s] where the run does not say."""
    series = run["series"]
    time = _float_array(series, "time", None, name)
    pose = _float_array(series, "pose", 3, name)
    reference = _float_array(series, "reference", 3, name)
    count = min(len(time), len(pose), len(reference))
    command = _float_array(series, "wheel_command", 0, name)[:count]
    raw_status = series.get("status") or []
    if not isinstance(raw_status, list) or not all(isinstance(entry, str)
                                                   for entry in raw_status):
        raise ReportError(f"run {name}: series 'status' should be a list of strings "
                          f"(one per tick), got {_shown(raw_status)}")
    status = raw_status[:count]
    fallback = np.array(
        [entry != "solved" for entry in status] + [False] * (count - len(status)), dtype=bool
    )
    dt = series.get("dt")
    if not isinstance(dt, (int, float)) or not dt > 0:
        dt = float(np.median(np.diff(time))) if len(time) > 1 else default_dt
    path_error = _float_array(series, "path_error", None, name)[:count]
    predicted = series.get("predicted")
    ticks = plans = None
    if isinstance(predicted, Mapping):
        ticks = _float_array(predicted, "tick", None, name).astype(int)
        try:
            plans = np.asarray(predicted.get("pose") or [], dtype=float)
        except (TypeError, ValueError) as error:
            raise ReportError(f"run {name}: series 'predicted' is not numeric: {error}") from None
        if plans.ndim != 3 or plans.shape[2] != 3 or len(plans) != len(ticks):
            raise ReportError(f"run {name}: series 'predicted' should hold ticks (M,) and "
                              f"poses (M, P, 3), got {ticks.shape} and {plans.shape}")
        keep = (ticks >= 0) & (ticks < count)
        ticks, plans = ticks[keep], plans[keep]
    steer_rate = _float_array(series, "steer_rate", 0, name)[:count]
    steer_limit = _float_array(series, "steer_rate_limit", None, name)
    steered = (len(steer_rate) == count and count > 0 and steer_rate.shape[1] > 0
               and steer_limit.size == steer_rate.shape[1])
    return Series(
        time=time[:count],
        pose=pose[:count],
        reference=reference[:count],
        wheel_command=command,
        wheel_limit=_float_array(series, "wheel_limit", None, name),
        tick_time=_float_array(series, "tick_time", None, name)[:count],
        fallback=fallback,
        dt=float(dt),
        skip=run_skip(run, default_skip),
        path_error=path_error if len(path_error) == count and count else None,
        predicted_tick=ticks,
        predicted_pose=plans,
        steer_rate=steer_rate if steered else None,
        steer_rate_limit=steer_limit if steered else None,
    )
