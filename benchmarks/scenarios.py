"""The benchmark's scenarios: which robot, which reference, how fast, which controller.

A scenario's speed is given as the reference's peak wheel-speed requirement
as a fraction of the wheel limit (``feasibility(...).peak_ratio``): 0.8 is
comfortably inside the limits, 1.3 is 30% beyond them. The period of the
reference is scaled to hit that ratio exactly (every speed, and the heading
rate of tangent and spinning profiles, scales with 1 / period).
"""

from __future__ import annotations

import argparse
import difflib
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from mpc import Controller
from mpc.control.settings import check_plan_size
from mpc.errors import MpcError
from mpc.model.weights import Weights, tuned_layouts, tuned_weights
from mpc.robots import PRESETS, Robot, load, preset, shipped_presets
from mpc.sim import FeedforwardPController, FeedforwardPSetpointController, TrackingController
from trajectories import (
    Circle,
    FigureEight,
    OutAndBack,
    SpinHeading,
    Trajectory,
    Waypoints,
    feasibility,
)

#: Named speeds: the reference's peak wheel speed / limit.
SPEEDS: dict[str, float] = {"inside": 0.8, "beyond": 1.3}
#: Largest peak ratio a speed may name (a reference 10x beyond the wheel limits).
MAX_SPEED_RATIO = 10.0
TRAJECTORIES: tuple[str, ...] = ("circle", "figure8")
#: Every trajectory the benchmark knows; ``out-and-back`` (2 m out along x, back 0.2 m to
#: the left: every caster swings round at each end) runs on request.
ALL_TRAJECTORIES: tuple[str, ...] = (*TRAJECTORIES, "out-and-back")
#: Layouts run by default: the Swedish, swerve and ball presets. The caster and MPO-700
#: presets run on request (``--layouts caster4,mpo700``): their IPOPT path is 5-40x
#: slower a tick than the others' and would double the default run.
DEFAULT_LAYOUTS: tuple[str, ...] = tuple(name for name in PRESETS
                                         if name not in ("caster4", "mpo700"))
#: Every layout ``--layouts`` takes: every shipped preset (the founding documents' robots,
#: ``jetauto``, ..., on request: the same wheel types as the defaults).
LAYOUTS: tuple[str, ...] = shipped_presets()
#: Every controller the benchmark knows: this project in time mode (the daqp fast path,
#: the same with the robot's tuned weights, the OSQP fast path, the exact IPOPT path) and in
#: path mode, and the baselines a user would otherwise pick (feedforward + P with per-wheel
#: clipping, WPILib-style desaturation, or, for swerve, a Team 254-style setpoint generator).
CONTROLLERS: tuple[str, ...] = ("mpc-daqp", "mpc-tuned", "mpc-osqp", "mpc-ipopt", "mpc-path",
                                "mpc-path-ipopt", "ff-p-clip", "ff-p-desat", "ff-p-setpoint")
#: What runs by default (mpc-osqp and mpc-path-ipopt on request).
DEFAULT_CONTROLLERS: tuple[str, ...] = ("mpc-daqp", "mpc-tuned", "mpc-ipopt", "mpc-path",
                                        "ff-p-clip", "ff-p-desat", "ff-p-setpoint")
#: Controllers that only apply to robots with steered wheels.
STEERED_ONLY: frozenset[str] = frozenset({"ff-p-setpoint"})
HEADINGS: tuple[str, ...] = ("fixed", "tangent", "spin")
DEFAULT_HEADINGS: tuple[str, ...] = ("fixed", "tangent")

#: Size of the shapes [m] and the period used to measure their wheel load [s].
SHAPE_SIZE = 1.0
_PROBE_PERIOD = 10.0


def did_you_mean(word: str, known: Iterable[str]) -> str:
    """`` (did you mean X?)`` for the closest of ``known`` to a mistyped ``word``, or ``""``."""
    close = difflib.get_close_matches(word, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


class Parser(argparse.ArgumentParser):
    """argparse, but a bad option is one line on stderr (no usage dump) and exit code 2, a
    mistyped option or choice gets the closest known one, and no option is matched by a
    prefix (``--control`` is an error, not ``--controllers``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        if isinstance(kwargs.get("description"), str):  # docstring markup is not for a terminal
            kwargs["description"] = kwargs["description"].replace("``", "")
        super().__init__(*args, **kwargs)

    def options(self) -> list[str]:
        """The option strings ``--help`` shows (hidden aliases left out)."""
        return [option for action in self._actions if action.help != argparse.SUPPRESS
                for option in action.option_strings]

    def parse_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                   namespace: argparse.Namespace | None = None) -> argparse.Namespace:
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            hints = "".join(did_you_mean(word.split("=")[0], self.options())
                            for word in extras if word.startswith("--"))
            self.error(f"unrecognized arguments: {' '.join(extras)}{hints}")
        return parsed

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        if action.choices is not None and value not in action.choices:
            choices = ", ".join(map(str, action.choices))
            raise argparse.ArgumentError(
                action, f"invalid choice: {value!r} (choose from {choices})"
                        f"{did_you_mean(str(value), map(str, action.choices))}")

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


class ScenarioError(MpcError):
    """An unknown name or an unusable file among the benchmark's options."""


#: The largest ``--seed`` (Optuna's samplers take 32-bit seeds).
MAX_SEED = 2**32 - 1


def seed(text: str) -> int:
    """A ``--seed`` (argparse type): an integer in [0, 2^32 - 1], as NumPy's and Optuna's
    generators take (one outside failed deep inside them, after the work had begun)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"expected an integer from 0 to {MAX_SEED}, got "
                                         f"{text!r}")
    return value


#: Names the prose uses for a choice, and the choice they stand for.
ALIASES: dict[str, str] = {"figure-eight": "figure8"}


def choose(flag: str, kind: str, requested: str | None, valid: tuple[str, ...] | list[str],
           default: tuple[str, ...] | list[str] | None = None) -> list[str]:
    """Split a comma list given with ``flag`` and check each name (the error names the flag),
    or return the default (every valid name)."""
    if requested is None:
        return list(valid if default is None else default)
    # each name once, in the order given (a name twice would run twice); the prose names
    names = list(dict.fromkeys(ALIASES.get(name.strip(), name.strip())
                               for name in requested.split(",") if name.strip()))
    unknown = [name for name in names if name not in valid]
    if unknown or not names:
        hint = did_you_mean(unknown[0], valid) if len(unknown) == 1 else ""
        raise ScenarioError(
            f"{flag}: unknown {kind} {', '.join(unknown) or repr(requested)}{hint}; valid: "
            f"{', '.join(valid)}"
        )
    return names


def parse_speeds(requested: str | None) -> dict[str, float]:
    """Named speeds (``inside``, ``beyond``) or numbers (peak ratios, e.g. ``0.5,1.5``)."""
    if requested is None:
        return dict(SPEEDS)
    speeds: dict[str, float] = {}
    for item in (part.strip() for part in requested.split(",") if part.strip()):
        if item in SPEEDS:
            speeds[item] = SPEEDS[item]
            continue
        try:
            ratio = float(item)
        except ValueError:
            raise ScenarioError(
                f"--speeds: unknown speed {item!r}{did_you_mean(item, SPEEDS)}; valid: "
                f"{', '.join(SPEEDS)} or a peak ratio like 1.2"
            ) from None
        if not 0 < ratio <= MAX_SPEED_RATIO:
            raise ScenarioError(f"--speeds: a peak ratio must be a number > 0 and at most "
                                f"{MAX_SPEED_RATIO:g}, got {item!r}")
        speeds[f"x{ratio:g}"] = ratio
    if not speeds:
        raise ScenarioError(f"--speeds: no speeds in {requested!r}")
    return speeds


def robots(layouts: list[str], robot_file: str | None) -> dict[str, Robot]:
    """Presets by name, plus a robot from a TOML file (named after its ``name``)."""
    chosen = {name: preset(name) for name in layouts}
    if robot_file is not None:
        robot = load(robot_file)
        if robot.name in chosen:
            raise ScenarioError(
                f"--robot {robot_file!r} names its robot {robot.name!r}, as the preset "
                f"--layouts runs: give it another name (name = \"...\" in the file) or "
                f"leave {robot.name!r} out of --layouts")
        chosen[robot.name] = robot
    return chosen


def _heading(kind: str, period: float) -> object:
    if kind == "fixed":
        return 0.0
    if kind == "tangent":
        return "tangent"
    return SpinHeading(rate=2.0 * math.pi / period)  # one turn per lap


def shape(name: str, heading: str) -> Callable[[float], Trajectory]:
    """The named shape (one of :data:`ALL_TRAJECTORIES`) with ``heading`` as a function of
    its period [s]."""
    def make(period: float) -> Trajectory:
        spec = _heading(heading, period)
        if name == "circle":
            return Circle(SHAPE_SIZE, period, heading=spec)  # type: ignore[arg-type]
        if name == "out-and-back":
            return OutAndBack(2.0 * SHAPE_SIZE, period, width=0.2 * SHAPE_SIZE,
                              heading=spec)  # type: ignore[arg-type]
        return FigureEight(SHAPE_SIZE, period, heading=spec)  # type: ignore[arg-type]

    return make


def reference(name: str, heading: str, robot: Robot, ratio: float) -> Trajectory:
    """The named shape, timed so its peak wheel speed is ``ratio`` times the limit."""
    make = shape(name, heading)
    probe = feasibility(make(_PROBE_PERIOD), robot).peak_ratio
    return make(_PROBE_PERIOD * probe / ratio)


def csv_reference(path: str | Path) -> Trajectory:
    """A waypoint trajectory from a CSV file (columns t,x,y,theta)."""
    return Waypoints.from_csv(path)


@dataclass(frozen=True)
class Settings:
    """Controller settings shared by every run."""

    horizon: int = 20
    dt: float = 0.05
    #: sides of a constant polygon standing in for a swerve module's disks (None: the
    #: fast paths' default, the speed disk linearised around each tick's plan and the
    #: acceleration disk a 16-gon)
    polygon_sides: int | None = None


def controller(name: str, robot: Robot, trajectory: Trajectory,
               settings: Settings) -> TrackingController:
    """A controller by its benchmark name (one of :data:`CONTROLLERS`)."""
    if name in _MPC:
        return mpc_controller(name, robot, trajectory, settings)
    if name == "ff-p-setpoint":
        return FeedforwardPSetpointController(robot, trajectory, settings.dt)
    saturation = "clip" if name == "ff-p-clip" else "desaturate"
    return FeedforwardPController(robot, trajectory, settings.dt, saturation=saturation)


#: The MPC controllers by benchmark name: (solver, mode). ``mpc-tuned`` is ``mpc-daqp`` with
#: the robot's tuned weight preset (:func:`mpc.model.weights.tuned_weights`).
_MPC: dict[str, tuple[str, str]] = {
    "mpc-daqp": ("daqp", "time"), "mpc-tuned": ("daqp", "time"), "mpc-osqp": ("osqp", "time"),
    "mpc-ipopt": ("ipopt", "time"), "mpc-path": ("daqp", "path"),
    "mpc-path-ipopt": ("ipopt", "path"),
}


def mpc_controller(name: str, robot: Robot, trajectory: Trajectory, settings: Settings,
                   weights: Mapping[str, Any] | None = None, delay_ticks: int = 0,
                   command_ramp: bool = False) -> Controller:
    """The MPC controller ``name`` (a key of ``_MPC``); ``weights`` override its own."""
    solver, mode = _MPC[name]
    sides = settings.polygon_sides if robot.kind == "swerve" and solver != "ipopt" else None
    chosen: Weights | Mapping[str, Any] | None = weights
    if chosen is None and name == "mpc-tuned":
        chosen = tuned_weights(robot.name)
    return Controller(robot, trajectory, settings.horizon, settings.dt, solver=solver,
                      weights=chosen, mode=mode, polygon_sides=sides, delay_ticks=delay_ticks,
                      command_ramp=command_ramp)


def check_plan_sizes(robots: Mapping[str, Robot], controllers: list[str],
                     settings: Settings) -> None:
    """Every MPC controller's plan on every robot within the library's bounds
    (:func:`mpc.control.settings.check_plan_size`), before any run; the error names the
    flags that set it."""
    for name in controllers:
        solver = _MPC[name][0] if name in _MPC else "ipopt"
        for robot in robots.values() if solver != "ipopt" else ():
            sides = settings.polygon_sides if robot.kind == "swerve" else None
            try:
                check_plan_size(robot, settings.horizon, solver, sides)
            except MpcError as error:
                flags = "" if sides is None else f" (--polygon-sides {sides})"
                raise ScenarioError(f"--horizon {settings.horizon}{flags}: {name} on robot "
                                    f"{robot.name!r}: {error}") from None


def is_tuned_preset(robot: Robot) -> bool:
    """Whether ``robot`` is a preset with tuned weights, as shipped (by its geometry and
    limits, not only its name: a robot file named ``swerve`` is not the preset)."""
    if robot.name not in tuned_layouts() or robot.dynamics is not None:
        return False
    shipped = preset(robot.name)
    return (np.array_equal(robot.wheel_blocks, shipped.wheel_blocks)
            and np.array_equal(robot.max_wheel_speed, shipped.max_wheel_speed)
            and np.array_equal(np.asarray(robot.max_wheel_accel, dtype=float),
                               np.asarray(shipped.max_wheel_accel, dtype=float)))


def applies(name: str, robot: Robot) -> bool:
    """Whether controller ``name`` can drive ``robot`` (the setpoint generator: swerve, not
    casters, whose steer angles are states; ``mpc-tuned``: robots with a tuned preset)."""
    if name == "mpc-tuned":
        return is_tuned_preset(robot)
    return name not in STEERED_ONLY or (robot.steered and not robot.steer_states)


__all__ = [
    "ALL_TRAJECTORIES", "CONTROLLERS", "DEFAULT_CONTROLLERS", "DEFAULT_HEADINGS", "mpc_controller",
    "shape",
    "DEFAULT_LAYOUTS", "HEADINGS", "LAYOUTS", "PRESETS", "SPEEDS", "TRAJECTORIES", "Parser",
    "ScenarioError", "Settings", "applies", "choose", "controller", "csv_reference",
    "parse_speeds", "reference", "robots",
]
