"""A run as plain data: what the figures and the report page read, and ``results.json`` holds.

:func:`run_record` packs a :class:`~mpc.sim.SimResult` (from
:func:`~mpc.sim.simulate` or from a loop of your own through :class:`~mpc.sim.Recorder`)
into a JSON-ready dict; ``mpc-bench`` packs its runs with the same function, so a user's
run and the benchmark's draw the same figures. Keys (SI units: m, rad, s, rad/s):

- labels: ``layout``, ``trajectory``, ``heading``, ``speed`` (a scenario is these four),
  ``controller``; ``peak_ratio`` (the reference's peak wheel speed / limit), ``period``
  [s] (None: not periodic), ``skip`` [s] (the settling time left out of the metrics);
- ``metrics``: :meth:`SimResult.metrics` over the ticks after ``skip``;
- ``series``: ``time`` (K,), ``pose`` and ``reference`` (K, 3), ``wheel_command`` (K, n),
  ``wheel_limit`` (n,), ``tick_time`` and ``solve_time`` (K,), ``status`` (K,), ``lag``
  (K,), ``path_error`` (K,) [m] (distance to the reference's path), ``dt``; steered
  wheels' ``steer_angle``, ``steer_rate``, ``steer_rate_limit``; ``predicted``: the kept
  plans, ``{"tick": (M,), "pose": (M, P, 3)}``;
- ``robot``: ``name``, ``kind``, ``wheel_positions`` (the outline drawn on the path),
  ``wheel_names`` (``FL``, ``FR``...: the wheels' labels).

Imports neither matplotlib nor a solver.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from mpc.robots.base import Robot
    from mpc.sim.result import SimResult


def _list(array: Any, decimals: int = 7) -> list[Any]:
    """A rounded, JSON-ready list (NaN stays NaN: JSON writes it as NaN)."""
    return np.round(np.asarray(array, dtype=float), decimals).tolist()  # type: ignore[no-any-return]


def robot_info(robot: Robot) -> dict[str, Any]:
    """Name, kind, wheel positions [m] (the outline in the path plots) and wheel names of a
    robot (:attr:`~mpc.robots.Robot.wheel_names`, the figures' labels)."""
    return {"name": robot.name, "kind": robot.kind,
            "wheel_positions": np.asarray(robot.wheel_positions).round(6).tolist(),
            "wheel_names": list(robot.wheel_names)}


def reference_peak_ratio(result: SimResult) -> float | None:
    """The reference's peak wheel speed / limit over the run for the result's robot
    (:func:`trajectories.feasibility`), None without a robot or where it cannot be had."""
    if result.robot is None:
        return None
    from mpc.errors import MpcError
    from trajectories import feasibility

    try:
        ratio = float(feasibility(result.trajectory, result.robot).peak_ratio)
    except (MpcError, ArithmeticError):
        return None
    return ratio if math.isfinite(ratio) else None


def series(result: SimResult) -> dict[str, Any]:
    """A result's time series as plain data (see the module's docstring)."""
    out: dict[str, Any] = {
        "time": _list(result.time), "pose": _list(result.pose),
        "reference": _list(result.reference), "wheel_command": _list(result.wheel_command),
        "wheel_limit": _list(result.wheel_limit), "tick_time": _list(result.tick_time, 8),
        "solve_time": _list(result.solve_time, 8), "status": list(result.status),
        "lag": _list(result.time - result.reference_time), "dt": result.dt,
        "path_error": _list(result.cross_track_error(), 6),
    }
    rates, limit = result.steer_rates(), result.steer_rate_limit
    if rates is not None and limit is not None and result.steer_command is not None:
        out.update(steer_angle=_list(result.steer_command), steer_rate=_list(rates),
                   steer_rate_limit=_list(limit))
    if result.predicted_ticks is not None and result.predicted_poses is not None:
        out["predicted"] = {"tick": [int(k) for k in result.predicted_ticks],
                            "pose": _list(result.predicted_poses, 6)}
    return out


def run_record(result: SimResult, *, skip: float = 0.0, controller: str = "mpc",
               layout: str | None = None, trajectory: str | None = None,
               heading: str = "-", speed: str = "-",
               metrics: Mapping[str, Any] | None = None, **extra: Any) -> dict[str, Any]:
    """One run as plain data (JSON-ready), the unit of figures, reports and ``results.json``.

    Args:
        result: the run, from :func:`~mpc.sim.simulate` or :meth:`Recorder.result`.
        skip: settling time [s] left out of the metrics (shaded on the time plots).
        controller: the name it is shown under (runs of one scenario are compared).
        layout, trajectory, heading, speed: the scenario's labels; default the robot's
            name, the reference's name (its class for the built-in shapes), "-", "-".
        metrics: already computed ``result.metrics(skip)`` (computed if None).
        extra: more keys of the record (e.g. ``peak_ratio``, ``target_lap``); they
            override the computed ones.
    """
    from mpc.errors import ReportError
    from mpc.sim.result import SimResult
    from mpc.validation import non_negative, shown

    if not isinstance(result, SimResult):
        raise ReportError(f"run_record takes a SimResult, got {shown(result)}")
    skip = non_negative("skip [s]", skip, ReportError)
    for key, label in (("controller", controller), ("layout", layout),
                       ("trajectory", trajectory), ("heading", heading), ("speed", speed)):
        if not (isinstance(label, str) or label is None and key in ("layout", "trajectory")):
            raise ReportError(f"{key} must be a string (the name the run is shown under), "
                              f"got {shown(label)}")
    reference = result.trajectory
    name = getattr(reference, "name", None)
    record: dict[str, Any] = {
        "layout": layout or (result.robot.name if result.robot is not None else "robot"),
        "trajectory": trajectory or (name if isinstance(name, str) and name
                                     else type(reference).__name__.lower()),
        "heading": heading,
        "speed": speed,
        "controller": controller,
        "period": reference.period,
        "skip": float(skip),
    }
    if "peak_ratio" not in extra:
        ratio = reference_peak_ratio(result)
        record["peak_ratio"] = None if ratio is None else round(ratio, 4)
    record["metrics"] = dict(metrics) if metrics is not None else result.metrics(skip=skip)
    record["series"] = series(result)
    if result.robot is not None:
        record["robot"] = robot_info(result.robot)
    record.update(extra)
    return record


__all__ = ["reference_peak_ratio", "robot_info", "run_record", "series"]
