"""The report's terms: the settings with their units and meaning, and what the words mean.

Plain text and numbers, no matplotlib and no HTML.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .headline import HEADING_FLOOR, POSITION_FLOOR, TIE_TOLERANCE

#: Unit and meaning of each setting a results document may hold in ``meta.settings``.
SETTING_TERMS: dict[str, tuple[str, str]] = {
    "horizon": ("ticks", "prediction horizon N, in control ticks"),
    "dt": ("s", "control tick (the controller's period)"),
    "polygon_sides": ("sides", "polygon standing in for a swerve module's speed disk (QP)"),
    "duration": ("s", "simulated time per run (default: two laps at the target pace)"),
    "plant": ("preset", "the simulated robot: ideal, or with lag, delay, noise, slip"),
    "skip": ("s", "settling time at the start of each run, left out of the metrics"),
    "headings": ("modes", "heading references: fixed, or tangent to the path"),
    "seed": ("integer", "seed of the plant's noise and slip"),
    "ticks": ("ticks", "ticks per run"),
    "controller": ("name", "the controller the runs are shown under"),
    "trajectory_files": ("paths", "reference files run as their own scenarios (--trajectory)"),
}
UNKNOWN_TERM = ("(unit not stated)", "")

_SPEEDS = (
    "Inside and beyond (the speeds of mpc-bench): each scenario's reference is timed so that "
    "its peak wheel speed, on that robot, is a stated multiple of the wheel speed limit: "
    "inside asks 0.8\u00d7 the limit (the wheels can follow it exactly), beyond asks "
    "1.3\u00d7 (no controller can: the question is how gracefully each one falls behind). "
    "The peak wheel ratio in the tables is what the controller actually commanded, peak "
    "|wheel command| / limit, over the same ticks as the errors, so an exact tracker reads "
    "about 0.8 inside and at most 1.0 beyond."
)
_SKIP = (
    "The first skip seconds of every run (the start-up transient, shaded grey on the time "
    "plots) are left out of every error metric and of the peak wheel ratio."
)
_ERRORS = (
    "Position error is time-indexed: the distance from the robot to where the reference is "
    "at that instant, so falling behind on the right path counts. Heading error is the "
    "angle between the robot's heading and the reference's at that instant. Path "
    "(contouring) error is the distance to the nearest point of the reference's path, "
    "wherever along it: a robot late on the path has a small path error and a large "
    "time-indexed error; one that cuts corners has both."
)
_FOLLOWERS = (
    "A path follower (mode=\"path\") lets its clock trail the reference's where the wheels "
    "cannot keep up: its position error is measured against the reference point it tracks, "
    "so it is not ranked on it; its pace (lap time over the fastest possible lap: the "
    "time-optimal lap under the same wheel limits, or the reference's own period where "
    "that is slower) and path error say how it did."
)
_UNITS = "Lengths are in mm, angles in deg, times in ms unless stated."


def _compare_text(ranked: bool, mpc: bool) -> str:
    floor_mm, floor_deg = 1e3 * POSITION_FLOOR, math.degrees(HEADING_FLOOR)
    text = (f"Errors below {floor_mm:g} mm (position) or {floor_deg:g} deg (heading) are "
            f"rounding, not tracking: they are shown as \u201c< {floor_mm:g} mm\u201d")
    if not ranked:
        return text + "."
    text += (f" and tie with each other. Two errors within {TIE_TOLERANCE:.0%} of the "
             "smaller one also tie; in a controller's count of scenarios where it is lowest, "
             "a tie counts for each.")
    if mpc:
        text += (" MPC is the best of its variants (the controllers named mpc-...) in each "
                 "scenario, the baseline the best of the other controllers in it (the "
                 "feedforward + P controllers of mpc-bench); the ratios are MPC's RMS error "
                 "over the baseline's.")
    return text


def terms_paragraphs(speeds: bool, skip: bool, followers: bool, compared: bool,
                     ranked: bool = True) -> list[str]:
    """The terms a report needs, one paragraph each: the speeds (inside and beyond) when
    its runs have them, the settling time when a run has one, the errors, path followers
    when there are any, the floor, and the tie rule when controllers are ``ranked`` (with
    what MPC and the baseline are when ``compared``), the units."""
    errors = f"{_SKIP} {_ERRORS}" if skip else _ERRORS
    parts = [_SPEEDS] if speeds else []
    parts.append(errors)
    if followers:
        parts.append(_FOLLOWERS)
    parts.append(_compare_text(ranked, compared))
    parts.append(_UNITS)
    return parts


#: Every term of a benchmark report in one paragraph (the speeds, settling time, errors,
#: path followers, ties and floors, units).
TERMS_PARAGRAPH = " ".join(terms_paragraphs(True, True, True, True))


def _number(value: object) -> str:
    """Floats to 6 significant digits, None as ``none``, the rest as ``str``."""
    if value is None:
        return "none"
    return f"{value:g}" if isinstance(value, float) else str(value)


def setting_rows(settings: Mapping[str, Any]) -> list[tuple[str, str, str, str]]:
    """``(name, value, unit, meaning)`` for each setting; lists joined by commas."""
    rows = []
    for key, value in settings.items():
        unit, meaning = SETTING_TERMS.get(key, UNKNOWN_TERM)
        shown = (", ".join(map(str, value)) if isinstance(value, (list, tuple))
                 else _number(value))
        rows.append((str(key), shown, unit, meaning))
    return rows


def settings_line(settings: Mapping[str, Any]) -> str:
    """The settings in one line with their units: ``"dt 0.05 s · horizon 20 ticks (1 s) ·
    skip 1 s · plant ideal"``; empty when there are none."""
    parts = []
    for key, shown, unit, _ in setting_rows(settings):
        if key in ("headings", "seed") or (key == "trajectory_files" and not shown):
            continue
        text = f"{key} {'default' if settings[key] is None else shown}"
        if unit in ("s", "ticks", "sides") and shown != "none":
            text += f" {unit}"
        if key == "horizon" and isinstance(settings.get("dt"), (int, float)):
            horizon = settings.get("horizon")
            if isinstance(horizon, (int, float)) and not isinstance(horizon, bool):
                text += f" ({_number(horizon * settings['dt'])} s)"
        parts.append(text)
    return " \u00b7 ".join(parts)
