"""What won where: MPC against the best baseline per scenario, and the controllers' ranks.

The report opens with this (beyond the wheel limits where the results have such
scenarios: that is where controllers differ). MPC is the best of its variants (the
controllers named ``mpc`` or ``mpc-...``) in each scenario, the baseline the best of the
others. Only controllers that keep the reference's clock are ranked on the time-indexed
position error: a path follower (``mode="path"``, a run that lags) is measured against the
reference point it tracks, so its position error is not comparable; the headline states
its pace and path error instead.

Two errors tie when both are below the floor (:data:`POSITION_FLOOR`,
:data:`HEADING_FLOOR`: rounding, not tracking) or differ by at most
:data:`TIE_TOLERANCE` of the smaller. Plain data, no matplotlib.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .results import Run, counted, metric_value, pace_of, scenario_of

Scenario = tuple[str, str, str, str]  # layout, trajectory, heading, speed

#: Errors below this are reported as "< 0.01 mm" and not ranked [m].
POSITION_FLOOR = 1e-5
#: Heading errors below this are reported as "< 0.01 deg" and not ranked [rad].
HEADING_FLOOR = math.radians(0.01)
#: Two errors within this fraction of the smaller one tie.
TIE_TOLERANCE = 0.05


def ties(a: float, b: float, floor: float) -> bool:
    """Whether errors ``a`` and ``b`` (same unit as ``floor``) tie: both below ``floor``, or
    within :data:`TIE_TOLERANCE` of the smaller; NaN ties nothing."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return False
    if a < floor and b < floor:
        return True
    return abs(a - b) <= TIE_TOLERANCE * min(a, b)


def is_mpc(controller: str) -> bool:
    """Whether a controller name is an MPC variant (``mpc`` or ``mpc-...``)."""
    return controller == "mpc" or controller.startswith("mpc-")


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
    def winners(self) -> tuple[str, ...]:
        """The controllers that tie with the lowest finite RMS position error (:func:`ties`;
        every one below the floor), best first; empty if none has a finite error."""
        if not self.entries or not math.isfinite(self.entries[0][1]):
            return ()
        best = self.entries[0][1]
        return tuple(name for name, rms, _ in self.entries if ties(best, rms, POSITION_FLOOR))

    @property
    def winner(self) -> str | None:
        """The sole winner, None on a tie or when no error is finite."""
        return self.winners[0] if len(self.winners) == 1 else None


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


def is_beyond(run: Run) -> bool:
    """The run's reference asks more than the wheel limits (peak ratio > 1, or labelled)."""
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
class Comparison:
    """MPC (the best of its variants per scenario) against the best baseline, over the
    scenarios where both have a finite RMS position error.

    Attributes:
        scenarios: how many scenarios are compared.
        wins, ties, losses: scenarios where MPC's RMS position error is lower, ties
            (:func:`ties`), is higher.
        position_ratios: per scenario, MPC's RMS position error / the best baseline's
            (scenarios where either is below the floor are left out: a ratio of rounding).
        position: per scenario, (MPC's, the best baseline's) RMS position error [m].
        heading: per scenario, (MPC's, the best baseline's) RMS heading error [rad], each
            the best of its side (NaN where a side has none).
    """

    scenarios: int
    wins: int
    ties: int
    losses: int
    position_ratios: tuple[float, ...]
    position: tuple[tuple[float, float], ...]
    heading: tuple[tuple[float, float], ...]

    @property
    def below_floor(self) -> int:
        """Scenarios where MPC's RMS position error is below :data:`POSITION_FLOOR`."""
        return sum(ours < POSITION_FLOOR for ours, _ in self.position)

    def medians(self, metric: str) -> tuple[float, float]:
        """(MPC's, the best baseline's) median of ``metric`` (``"position"`` [m] or
        ``"heading"`` [rad]) over the scenarios; NaN where none is finite."""
        pairs = self.position if metric == "position" else self.heading
        return (median([ours for ours, _ in pairs]), median([theirs for _, theirs in pairs]))


def median(values: Sequence[float]) -> float:
    """The median of the finite ``values``, NaN if none."""
    finite = [value for value in values if math.isfinite(value)]
    return float(np.median(finite)) if finite else math.nan


def _best(runs: Sequence[Run], members: Sequence[int], key: str) -> float:
    values = [metric_value(runs[i], key) for i in members]
    finite = [value for value in values if math.isfinite(value)]
    return min(finite) if finite else math.nan


def compare(runs: Sequence[Run], chosen: Sequence[Ranking]) -> Comparison | None:
    """MPC against the best baseline in the ``chosen`` scenarios; None when the runs lack
    either side (no MPC variant, or nothing else)."""
    wins = ties_ = losses = 0
    ratios: list[float] = []
    position: list[tuple[float, float]] = []
    heading: list[tuple[float, float]] = []
    for ranking in chosen:
        indices = [index for _, _, index in ranking.entries]
        mpc = [i for i in indices if is_mpc(str(runs[i]["controller"]))]
        others = [i for i in indices if not is_mpc(str(runs[i]["controller"]))]
        ours, theirs = (_best(runs, mpc, "rms_position_error"),
                        _best(runs, others, "rms_position_error"))
        if not (math.isfinite(ours) and math.isfinite(theirs)):
            continue
        if ties(ours, theirs, POSITION_FLOOR):
            ties_ += 1
        elif ours < theirs:
            wins += 1
        else:
            losses += 1
        if min(ours, theirs) >= POSITION_FLOOR:
            ratios.append(ours / theirs)
        position.append((ours, theirs))
        heading.append((_best(runs, mpc, "rms_heading_error"),
                        _best(runs, others, "rms_heading_error")))
    if not position:
        return None
    return Comparison(len(position), wins, ties_, losses, tuple(ratios), tuple(position),
                      tuple(heading))


@dataclass(frozen=True)
class Headline:
    """The report's opening: which scenarios it speaks of, MPC against the baselines there,
    and who won them.

    Attributes:
        focus: ``"beyond the wheel limits"`` or ``"across all scenarios"``.
        rankings: the scenarios in focus.
        wins: per controller, the scenarios in focus where it has the lowest RMS
            position error alone or tied (:attr:`Ranking.winners`), most first.
        followers: per path follower in those scenarios, (controller, lowest and highest
            lap / fastest possible lap, largest path error [m]).
        comparison: MPC against the best baseline in focus (None: not both in the runs).
        inside: the same inside the limits when the focus is beyond them, else None.
        single: the run when there is only one (the headline then describes it).
    """

    focus: str
    rankings: tuple[Ranking, ...]
    wins: tuple[tuple[str, int], ...]
    followers: tuple[tuple[str, float, float, float], ...] = ()
    comparison: Comparison | None = None
    inside: Comparison | None = None
    single: Run | None = None

    @property
    def sentence(self) -> str:
        """The headline in words (:attr:`sentences` joined)."""
        return " ".join(self.sentences)

    @property
    def sentences(self) -> tuple[str, ...]:
        """The headline in words, the answer first: MPC against the best baseline in focus
        (wins, median ratio and errors); then inside the limits; then path mode against the
        optimal lap. Without a baseline to compare, who won where; for a single run, its
        errors."""
        if self.single is not None:
            return (_single_sentence(self.single),)
        lead = self.focus[0].upper() + self.focus[1:]
        paths = (f"In path mode: {self._paths()}.",) if self.followers else ()
        if self.comparison is not None:
            inside = () if self.inside is None else (
                f"Inside the limits, {_comparison_text(self.inside, inside=True)}",)
            return (f"{lead}, {_comparison_text(self.comparison)}", *inside, *paths)
        if not self.wins:
            if self.followers:
                return (f"{lead}, no controller that keeps the reference's clock to rank. "
                        f"Following the path: {self._paths()}.",)
            return (f"No controller has a finite RMS position error {self.focus}.",)
        return (f"{lead}, {self._wins_text()}", *paths)

    @property
    def verdict(self) -> str:
        """The headline in one short line (a terminal's last): ``"beyond the wheel limits,
        MPC beats the best baseline in 18 of 20 scenarios (2 ties, 0 losses): a median
        0.53x its RMS position error"``; without a baseline, the first sentence."""
        comparison = self.comparison
        if comparison is None or self.single is not None:
            return self.sentences[0]
        text = (f"{self.focus}, MPC beats the best baseline in {comparison.wins} of "
                f"{counted(comparison.scenarios, 'scenario')} ({comparison.ties} "
                f"{'tie' if comparison.ties == 1 else 'ties'}, {comparison.losses} "
                f"{'loss' if comparison.losses == 1 else 'losses'})")
        if comparison.position_ratios:
            text += (f": a median {median(comparison.position_ratios):.2g}\u00d7 its RMS "
                     "position error")
        return text

    def _wins_text(self) -> str:
        total = len(self.rankings)
        tied = sum(len(ranking.winners) > 1 for ranking in self.rankings)
        first, count = self.wins[0]
        if total == 1:
            names = self.rankings[0].winners
            text = (f"{' and '.join(names)} tie for the lowest RMS position error"
                    if len(names) > 1 else f"{first} has the lowest RMS position error")
        else:
            parts = [f"{name} in {n}" for name, n in self.wins[1:]]
            tail = f"; {', '.join(parts)}" if parts else ""
            text = (f"{first} has the lowest RMS position error in {count} of {total} "
                    f"scenarios{tail}")
            if tied:
                text += (f" ({tied} {'a tie' if tied == 1 else 'ties'}, counted for each: "
                         f"within {TIE_TOLERANCE:.0%} or below {1e3 * POSITION_FLOOR:g} mm)")
        return text + ("" if not self.followers else " (keeping the reference's clock)") + "."

    def _paths(self) -> str:
        parts = []
        for name, low, high, error in self.followers:
            lap = ("the time-optimal lap" if self.focus.startswith("beyond")
                   else "the fastest possible lap")
            pace = f"at {low:.2f}-{high:.2f}\u00d7 {lap}, " if math.isfinite(low) else ""
            parts.append(f"{name} {pace}at most {error * 1e3:.3g} mm off the path")
        return "; ".join(parts)


def _ratio_text(values: Sequence[float]) -> str:
    """``"a median 0.31\u00d7 (0.20-0.52\u00d7)"``: the median and range of ratios."""
    finite = [value for value in values if math.isfinite(value)]
    if len(finite) == 1:
        return f"{finite[0]:.2g}\u00d7"
    return f"a median {median(finite):.2g}\u00d7 ({min(finite):.2g}-{max(finite):.2g}\u00d7)"


def _medians_text(comparison: Comparison, metric: str) -> str:
    """``"1.2 deg (MPC) against 3.4 deg"``: the medians of both sides, floors shown."""
    floor, scale, unit = ((POSITION_FLOOR, 1e3, "mm") if metric == "position"
                          else (HEADING_FLOOR, 180.0 / math.pi, "deg"))
    ours, theirs = comparison.medians(metric)
    return f"{floored(ours, floor, scale, unit)} against {floored(theirs, floor, scale, unit)}"


def _comparison_text(comparison: Comparison, inside: bool = False) -> str:
    n = comparison.scenarios
    scenario = "scenario" if n == 1 else "scenarios"
    text = ("MPC" if inside else "MPC (the best of its variants in each scenario)") + (
        f" has a lower RMS position error than the best baseline in {comparison.wins} of "
        f"{n} {scenario}")
    if comparison.ties:
        text += f", ties in {comparison.ties}"
    if comparison.losses:
        text += f", has a higher one in {comparison.losses}"
    if comparison.position_ratios and not inside:
        text += f"; {_ratio_text(comparison.position_ratios)} the best baseline's"
    text += f". Median RMS position error {_medians_text(comparison, 'position')}"
    if any(math.isfinite(ours) for ours, _ in comparison.heading):
        text += f", heading error {_medians_text(comparison, 'heading')}"
    return text + "."


def _single_sentence(run: Run) -> str:
    """One run's errors after its settling time, for a report of that run alone."""
    parts = [f"{run['controller']} on {' / '.join(_labels(run))}:"]
    position = metric_value(run, "rms_position_error")
    heading = metric_value(run, "rms_heading_error")
    parts.append(f"RMS position error {floored(position, POSITION_FLOOR, 1e3, 'mm')}")
    if math.isfinite(heading):
        parts[-1] += (f", RMS heading error "
                      f"{floored(heading, HEADING_FLOOR, 180.0 / math.pi, 'deg')}")
    skip = run.get("skip")
    if isinstance(skip, (int, float)) and not isinstance(skip, bool) and skip > 0:
        parts[-1] += f" after the {skip:g} s settling time"
    ratio = metric_value(run, "max_wheel_speed_ratio")
    text = " ".join(parts)
    if math.isfinite(ratio):
        text += f"; peak wheel command {ratio:.2f}\u00d7 its limit"
    return text + "."


def _labels(run: Run) -> list[str]:
    """The run's scenario labels that say something (``-`` and the default heading left out)."""
    return [label for label in scenario_of(run) if label not in ("-", "")]


def floored(value: float, floor: float, scale: float, unit: str) -> str:
    """``"< 0.01 mm"`` below the floor, else the value scaled to 3 significant digits with
    its unit (``-`` when not finite)."""
    if not math.isfinite(value):
        return "-"
    if value < floor:
        return f"< {floor * scale:.2g} {unit}"
    shown = value * scale
    return f"{shown:.0f} {unit}" if abs(shown) >= 1000 else f"{shown:.3g} {unit}"


def headline(runs: Sequence[Run]) -> Headline:
    """The scenarios beyond the wheel limits if there are any, else all: MPC against the
    best baseline there (and inside the limits), and their winners."""
    every = rankings(runs)
    beyond = any(is_beyond(run) for run in runs)
    chosen = [ranking for ranking in every if ranking.beyond] if beyond else every
    focus = "beyond the wheel limits" if beyond else "across all scenarios"
    wins = Counter(name for ranking in chosen for name in ranking.winners)
    order = {name: index for index, name in enumerate(dict.fromkeys(
        str(run["controller"]) for run in runs))}
    ordered = sorted(wins.items(), key=lambda item: (-item[1], order[item[0]]))
    focused = [run for run in runs if is_beyond(run) or not beyond]
    inside = [ranking for ranking in every if not ranking.beyond] if beyond else []
    return Headline(focus, tuple(chosen), tuple(ordered), _followers(focused),
                    compare(runs, chosen), compare(runs, inside) if inside else None,
                    runs[0] if len(runs) == 1 else None)


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
