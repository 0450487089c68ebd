"""What won where: per scenario, the controller with the lowest RMS position error.

The report opens with this (beyond the wheel limits where the results have such
scenarios: that is where controllers differ). Only controllers that keep the reference's
clock are ranked on that time-indexed error: a path follower (``mode="path"``, a run that
lags) is measured against the reference point it tracks, so its position error is not
comparable; the headline states its pace and path error instead. Plain data, no
matplotlib.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

from .results import Run, metric_value, pace_of, scenario_of

Scenario = tuple[str, str, str, str]  # layout, trajectory, heading, speed


@dataclass(frozen=True)
class Ranking:
    """One scenario's controllers from the lowest RMS position error [m] up (NaN last).

    Attributes:
        scenario: (layout, trajectory, heading, speed).
        peak_ratio: the reference's peak wheel speed / limit (NaN: unknown).
        entries: (controller, RMS position error [m], run index), best first.
    """

    scenario: Scenario
    peak_ratio: float
    entries: tuple[tuple[str, float, int], ...]

    @property
    def beyond(self) -> bool:
        """The reference asks more than the wheel limits (peak ratio > 1, or labelled so)."""
        if math.isfinite(self.peak_ratio):
            return self.peak_ratio > 1.0
        return self.scenario[3] == "beyond"

    @property
    def winner(self) -> str | None:
        """The controller with the lowest finite RMS position error, None if none has one."""
        if not self.entries or not math.isfinite(self.entries[0][1]):
            return None
        return self.entries[0][0]


def _peak_ratio(run: Run) -> float:
    value = run.get("peak_ratio")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return math.nan
    return float(value)


#: A run whose clock trailed the reference's by more than this [s] is a path follower.
LAG_TOLERANCE = 1e-6


def follows_path(run: Run) -> bool:
    """Whether the run trailed the reference's clock (a path follower: ``max_lag`` above
    :data:`LAG_TOLERANCE`; a path follower that kept up is ranked like the others)."""
    lag = run.get("metrics", {}).get("max_lag")
    return (isinstance(lag, (int, float)) and not isinstance(lag, bool)
            and lag > LAG_TOLERANCE)


def _is_beyond(run: Run) -> bool:
    ratio = _peak_ratio(run)
    return ratio > 1.0 if math.isfinite(ratio) else str(run.get("speed")) == "beyond"


def rankings(runs: Sequence[Run]) -> list[Ranking]:
    """Every scenario's ranking of the controllers that keep the reference's clock, in
    order of first appearance."""
    groups: dict[Scenario, list[int]] = {}
    for index, run in enumerate(runs):
        if not follows_path(run):
            groups.setdefault(scenario_of(run), []).append(index)
    out = []
    for scenario, members in groups.items():
        entries = [(str(runs[i]["controller"]), metric_value(runs[i], "rms_position_error"), i)
                   for i in members]
        entries.sort(key=lambda entry: (not math.isfinite(entry[1]), entry[1]))
        out.append(Ranking(scenario, _peak_ratio(runs[members[0]]), tuple(entries)))
    return out


@dataclass(frozen=True)
class Headline:
    """The report's opening: which scenarios it speaks of and who won them.

    Attributes:
        focus: ``"beyond the wheel limits"`` or ``"across all scenarios"``.
        rankings: the scenarios in focus.
        wins: per controller, the scenarios in focus where it has the lowest RMS
            position error, most first.
        followers: per path follower in those scenarios, (controller, lowest and highest
            lap / fastest possible lap, largest path error [m]).
    """

    focus: str
    rankings: tuple[Ranking, ...]
    wins: tuple[tuple[str, int], ...]
    followers: tuple[tuple[str, float, float, float], ...] = ()

    @property
    def sentence(self) -> str:
        """``"Beyond the wheel limits, mpc-path has the lowest RMS position error in 3 of
        4 scenarios; mpc-daqp in 1."``"""
        total = len(self.rankings)
        lead = self.focus[0].upper() + self.focus[1:]
        if not self.wins:
            if self.followers:
                return (f"{lead}, no controller that keeps the reference's clock to rank. "
                        f"Following the path: {self._paths()}.")
            return f"No controller has a finite RMS position error {self.focus}."
        parts = [f"{name} in {count}" for name, count in self.wins[1:]]
        first, count = self.wins[0]
        tail = f"; {', '.join(parts)}" if parts else ""
        noun = "scenario" if total == 1 else "scenarios"
        text = (f"{lead}, {first} has the lowest RMS position error in {count} of {total} "
                f"{noun}{tail}")
        if not self.followers:
            return text + "."
        return (f"{text} (keeping the reference's clock). Following the path instead: "
                f"{self._paths()}.")

    def _paths(self) -> str:
        parts = []
        for name, low, high, error in self.followers:
            pace = (f"at {low:.2f}-{high:.2f}\u00d7 the fastest possible lap, "
                    if math.isfinite(low) else "")
            parts.append(f"{name} {pace}at most {error * 1e3:.3g} mm off the path")
        return "; ".join(parts)


def headline(runs: Sequence[Run]) -> Headline:
    """The scenarios beyond the wheel limits if there are any, else all, and their winners."""
    every = rankings(runs)
    beyond = any(_is_beyond(run) for run in runs)
    chosen = [ranking for ranking in every if ranking.beyond] if beyond else every
    focus = "beyond the wheel limits" if beyond else "across all scenarios"
    wins = Counter(ranking.winner for ranking in chosen if ranking.winner is not None)
    order = {name: index for index, name in enumerate(dict.fromkeys(
        str(run["controller"]) for run in runs))}
    ordered = sorted(wins.items(), key=lambda item: (-item[1], order[item[0]]))
    focused = [run for run in runs if _is_beyond(run) or not beyond]
    return Headline(focus, tuple(chosen), tuple(ordered), _followers(focused))


def _followers(runs: Sequence[Run]) -> tuple[tuple[str, float, float, float], ...]:
    """Per path follower among ``runs``: (name, lowest and highest pace (NaN if no run has
    a lap to time), largest path error [m] (NaN if none is finite))."""
    paces: dict[str, list[float]] = {}
    errors: dict[str, list[float]] = {}
    for run in runs:
        if follows_path(run):
            name = str(run["controller"])
            paces.setdefault(name, [])
            if math.isfinite(pace := pace_of(run)):
                paces[name].append(pace)
            error = metric_value(run, "max_cross_track_error")
            errors.setdefault(name, []).extend([error] if math.isfinite(error) else [])
    return tuple((name, min(paces[name], default=math.nan), max(paces[name], default=math.nan),
                  max(errors[name], default=math.nan)) for name in paces)
