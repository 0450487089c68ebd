"""The benchmark's answer in one line: does MPC beat what a user would otherwise write?

In every scenario beyond the wheel limits (peak ratio > 1), the best time-mode MPC
variant's RMS position error is set against the best baseline's (``ff-p-*``); the line
counts the scenarios MPC wins and gives the median of the ratio MPC / baseline.
"""

from __future__ import annotations

import statistics
from collections.abc import Iterable, Mapping
from typing import Any

#: Controllers of MPC in path mode: judged against the optimal lap, not in the verdict.
PATH_MODE = frozenset({"mpc-path", "mpc-path-ipopt"})


def _best(runs: Iterable[Mapping[str, Any]]) -> float | None:
    errors = [float(run["metrics"]["rms_position_error"]) for run in runs]
    return min(errors) if errors else None


def ratios(runs: Iterable[Mapping[str, Any]], beyond: bool = True) -> list[float]:
    """Per scenario (beyond the limits, or inside them), the best time-mode MPC's RMS
    position error over the best baseline's; scenarios lacking either are left out."""
    scenarios: dict[tuple[Any, ...], list[Mapping[str, Any]]] = {}
    for run in runs:
        ratio = run.get("peak_ratio")
        if not isinstance(ratio, (int, float)) or (ratio > 1.0) != beyond:
            continue
        key = tuple(run.get(name) for name in ("layout", "trajectory", "heading", "speed"))
        scenarios.setdefault(key, []).append(run)
    found = []
    for members in scenarios.values():
        mpc = _best(r for r in members if str(r["controller"]).startswith("mpc-")
                    and r["controller"] not in PATH_MODE)
        baseline = _best(r for r in members if str(r["controller"]).startswith("ff-"))
        if mpc is not None and baseline is not None and baseline > 0:
            found.append(mpc / baseline)
    return found


def verdict(runs: Iterable[Mapping[str, Any]]) -> str:
    """One line: in how many scenarios beyond the limits MPC beat the best baseline, and
    the median ratio of their RMS position errors (below 1: MPC's is smaller)."""
    runs = list(runs)
    found = ratios(runs, beyond=True)
    where = "beyond the limits"
    if not found:  # e.g. --speeds inside: the scenarios there are
        found, where = ratios(runs, beyond=False), "inside the limits"
    if not found:
        return "no verdict: no scenario ran both a time-mode MPC and a baseline"
    wins = sum(ratio < 1.0 for ratio in found)
    return (f"MPC beat the best baseline in {wins} of {len(found)} scenario"
            f"{'' if len(found) == 1 else 's'} {where}, median RMS position error "
            f"{statistics.median(found):.2g}x the baseline's")


__all__ = ["ratios", "verdict"]
