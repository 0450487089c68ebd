"""Choreo ``.traj`` files (schema version 3): the trajectory, its robot and its events.

Choreo (SleipnirGroup) plans time-optimal swerve trajectories and saves them as JSON.
:func:`read_choreo` parses the JSON directly (no robot framework) into a
:class:`ChoreoTrajectory` carrying the swerve robot it was planned for.

Field mapping (field frame = our world frame, REP-103; SI units throughout):

==========================================  =============================================
``.traj`` field                             here
==========================================  =============================================
``version``                                 must be 3
``name``                                    :attr:`ChoreoTrajectory.name` (default: stem)
``trajectory.sampleType``                   must be ``"Swerve"``
``trajectory.samples[k].t``                 sample time [s], strictly increasing
``.x, .y, .heading``                        pose (x, y, theta) [m, m, rad]
``.vx, .vy, .omega``                        world velocity (xdot, ydot, thetadot) [m/s, rad/s]
``.ax, .ay, .alpha``                        world acceleration [m/s^2, rad/s^2]
``.fx, .fy`` (optional)                     module forces [N], field frame, Choreo order
                                            FL, BL, BR, FR -> ``module_forces`` (k, 4, 2) in
                                            ours FL, FR, RL, RR (``CHOREO_TO_OURS``)
``trajectory.config.frontLeft{x, y}``       FL module [m]; FR = (x, -y) by symmetry
``trajectory.config.backLeft{x, y}``        RL module [m]; RR = (x, -y)
``.radius``                                 wheel radius [m]
``.vmax`` / ``.gearing``                    wheel speed limit [rad/s] (vmax: motor [rad/s])
``.tmax, .mass, .inertia, .cof``            motor torque [N m], [kg], [kg m^2], friction
``events[i].name, .from.targetTimestamp``   :class:`ChoreoEvent` (time = target + offset)
==========================================  =============================================

``snapshot``, ``params``, ``trajectory.waypoints``, ``splits``, ``forcesAvailable``,
``bumper`` and ``differentialTrackWidth`` are not needed and not read.

Interpolation: :class:`~trajectories.sampled.SampledTrajectory` (quintic Hermite through
position, velocity and acceleration of every sample; see there for how it compares with
Choreo's own constant-acceleration intervals).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from mpc.errors import MpcError
from mpc.validation import file_text, parsed

from ._validation import FloatArray
from .errors import TrajectoryError
from .heading import HeadingSpec
from .sampled import SampledTrajectory

if TYPE_CHECKING:
    from mpc.robots import SwerveRobot

#: The ``.traj`` schema version this reader accepts.
CHOREO_VERSION = 3
#: Our module i is Choreo's module ``CHOREO_TO_OURS[i]`` (Choreo FL, BL, BR, FR; ours FL,
#: FR, RL, RR).
CHOREO_TO_OURS = (0, 3, 1, 2)
#: [rad/s] steering rate of :func:`choreo_robot` unless given (Choreo does not model
#: steering; this is the project's swerve preset).
DEFAULT_MAX_STEER_RATE = 12.0
GRAVITY = 9.8  # [m/s^2] as Choreo's optimiser uses it
_SAMPLE_FIELDS = ("t", "x", "y", "heading", "vx", "vy", "omega", "ax", "ay", "alpha")
_CONFIG_FIELDS = ("mass", "inertia", "gearing", "radius", "vmax", "tmax", "cof")


@dataclass(frozen=True)
class ChoreoEvent:
    """An event marker: ``name`` and its ``time`` [s] (None if Choreo gave no timestamp)."""

    name: str
    time: float | None


@dataclass(frozen=True)
class ChoreoConfig:
    """The robot a Choreo trajectory was planned for (``trajectory.config``), SI units."""

    front_left: tuple[float, float]  # [m] front-left module (x, y), body frame
    back_left: tuple[float, float]  # [m] back-left module
    mass: float  # [kg]
    inertia: float  # [kg m^2] about the vertical axis
    gearing: float  # motor turns per wheel turn
    radius: float  # [m] wheel radius
    vmax: float  # [rad/s] motor free speed
    tmax: float  # [N m] motor torque limit
    cof: float  # wheel-carpet coefficient of friction

    @property
    def module_positions(self) -> FloatArray:
        """(4, 2) [m] in our order FL, FR, RL, RR (right side mirrored, as Choreo does)."""
        (fx, fy), (bx, by) = self.front_left, self.back_left
        return np.array([[fx, fy], [fx, -fy], [bx, by], [bx, -by]])

    @property
    def max_wheel_speed(self) -> float:
        """[rad/s] wheel speed limit: vmax / gearing."""
        return self.vmax / self.gearing

    @property
    def max_module_force(self) -> float:
        """[N] Choreo's per-module force limit: min(tmax gearing / radius, cof mass g / 4)."""
        return min(self.tmax * self.gearing / self.radius, self.cof * self.mass * GRAVITY / 4)

    @property
    def max_wheel_accel(self) -> float:
        """[rad/s^2] 4 max_module_force / (mass radius): the rate at which every module's
        velocity changes when the chassis translates with all four modules at Choreo's
        force limit. Not a bound Choreo's samples obey in our sense: a spinning trajectory
        turns the modules' body-frame velocities with no drive force (the steering does
        it), so :func:`choreo_robot` uses it only when asked."""
        return 4.0 * self.max_module_force / (self.mass * self.radius)


def choreo_robot(config: ChoreoConfig, *, max_steer_rate: float = DEFAULT_MAX_STEER_RATE,
                 max_wheel_accel: float | None = None, name: str = "choreo") -> SwerveRobot:
    """The swerve robot of a Choreo config: modules FL, FR, RL, RR from ``module_positions``,
    wheel radius ``radius`` [m], wheel speed limit vmax / gearing [rad/s], steering rate
    ``max_steer_rate`` [rad/s], acceleration limit ``max_wheel_accel`` [rad/s^2] or None
    (none by default; ``config.max_wheel_accel`` is Choreo's translational bound)."""
    from mpc.robots import swerve  # lazily: keeps ``import trajectories`` free of CasADi

    return swerve(module_positions=config.module_positions, wheel_radius=config.radius,
                  max_wheel_speed=config.max_wheel_speed, max_steer_rate=max_steer_rate,
                  max_wheel_accel=max_wheel_accel, name=name)


class ChoreoTrajectory(SampledTrajectory):
    """A Choreo trajectory (quintic Hermite through its samples) with its file's extras:
    ``name``, ``config`` (:class:`ChoreoConfig`), ``robot`` (from :func:`choreo_robot`),
    ``events`` and ``module_forces`` ((n, 4, 2) [N], field frame, order FL, FR, RL, RR, or
    None). Built by :func:`read_choreo`."""

    def __init__(self, times: npt.ArrayLike, poses: npt.ArrayLike, velocities: npt.ArrayLike,
                 accelerations: npt.ArrayLike, *, name: str, config: ChoreoConfig,
                 robot: SwerveRobot, events: tuple[ChoreoEvent, ...] = (),
                 module_forces: FloatArray | None = None,
                 heading: HeadingSpec | None = None) -> None:
        self.name, self.config, self.robot, self.events = name, config, robot, events
        if module_forces is not None:
            module_forces.flags.writeable = False
        self.module_forces = module_forces
        super().__init__(times, poses, velocities, accelerations, heading)


def read_choreo(path: str | os.PathLike[str], *, max_steer_rate: float = DEFAULT_MAX_STEER_RATE,
                max_wheel_accel: float | None = None,
                heading: HeadingSpec | None = None) -> ChoreoTrajectory:
    """The trajectory in a Choreo ``.traj`` file (version 3, swerve) and its robot.

    ``max_steer_rate`` and ``max_wheel_accel`` go to :func:`choreo_robot`; ``heading``
    None keeps Choreo's heading. Every problem with the file raises a one-line
    :class:`TrajectoryError` naming the file and the field, e.g. ``choreo file 'a.traj':
    trajectory.samples[3].vx: expected a number, got "fast"``.
    """
    file = _File(Path(path))
    document = file.load()
    version = file.get(document, "version", "")
    if isinstance(version, bool) or version != CHOREO_VERSION:
        raise file.error("version", f"expected {CHOREO_VERSION} (Choreo .traj schema "
                                    f"{CHOREO_VERSION}), got {_json(version)}")
    name = document.get("name") or file.path.stem
    if not isinstance(name, str):
        raise file.error("name", f"expected a string, got {_json(name)}")
    body = file.get(document, "trajectory", "")
    kind = file.get(body, "sampleType", "trajectory")
    if kind != "Swerve":
        raise file.error("trajectory.sampleType", f'expected "Swerve", got {_json(kind)} '
                         "(differential and other drives are not read)")
    config = file.config(file.get(body, "config", "trajectory"))
    table, forces = file.samples(file.get(body, "samples", "trajectory"))
    try:
        robot = choreo_robot(config, max_steer_rate=max_steer_rate,
                             max_wheel_accel=max_wheel_accel, name=name)
    except MpcError as error:  # e.g. modules on one line: not a usable swerve base
        raise file.error("trajectory.config", str(error)) from None
    events = file.events(document.get("events", []))
    try:
        return ChoreoTrajectory(table[:, 0], table[:, 1:4], table[:, 4:7], table[:, 7:10],
                                name=name, config=config, robot=robot, events=events,
                                module_forces=forces, heading=heading)
    except TrajectoryError as error:  # samples that overflow or lie beyond the bounds
        raise file.error("trajectory.samples", str(error)) from None


def _json(value: Any) -> str:
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class _File:
    """One ``.traj`` being read: every error names the file and the field."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def error(self, where: str, text: str) -> TrajectoryError:
        return TrajectoryError(f"choreo file {str(self.path)!r}: {where}: {text}")

    def load(self) -> dict[str, Any]:
        text = file_text(self.path, "choreo", TrajectoryError)
        document = parsed(json.loads, text, f"choreo file {str(self.path)!r}", "JSON",
                          TrajectoryError)
        if not isinstance(document, dict):
            raise self.error("(top level)", f"expected an object, got {_json(document)}")
        return document

    def get(self, parent: Any, key: str, where: str) -> Any:
        field = f"{where}.{key}" if where else key
        if not isinstance(parent, dict):
            raise self.error(where, f"expected an object, got {_json(parent)}")
        if key not in parent or parent[key] is None:
            raise self.error(field, "missing")
        return parent[key]

    def number(self, parent: Any, key: str, where: str, positive: bool = False) -> float:
        return self.check(self.get(parent, key, where), f"{where}.{key}" if where else key,
                          positive)

    def check(self, value: Any, field: str, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(field, f"expected a number, got {_json(value)}")
        if isinstance(value, int) and not -1e300 < value < 1e300:  # JSON integers are unbounded
            raise self.error(field, f"expected a finite number{' > 0' if positive else ''}, "
                                    f"got an integer of {len(str(abs(value)))} digits")
        if not math.isfinite(value) or (positive and value <= 0):
            raise self.error(field, f"expected a finite number{' > 0' if positive else ''}, "
                                    f"got {_json(value)}")
        return float(value)

    def config(self, raw: Any) -> ChoreoConfig:
        where = "trajectory.config"
        corners = [(self.number(self.get(raw, side, where), "x", f"{where}.{side}"),
                    self.number(self.get(raw, side, where), "y", f"{where}.{side}"))
                   for side in ("frontLeft", "backLeft")]
        values = [self.number(raw, key, where, positive=True) for key in _CONFIG_FIELDS]
        return ChoreoConfig(corners[0], corners[1], *values)

    def samples(self, raw: Any) -> tuple[FloatArray, FloatArray | None]:
        """(n, 10) columns of ``_SAMPLE_FIELDS`` and module forces (n, 4, 2) or None."""
        if not isinstance(raw, list) or len(raw) < 2:
            got = f"{len(raw)} samples" if isinstance(raw, list) else _json(raw)
            raise self.error("trajectory.samples", f"expected a list of at least 2 samples, "
                             f"got {got} (generate the trajectory in Choreo first)")
        with_forces = isinstance(raw[0], dict) and "fx" in raw[0]
        table = np.empty((len(raw), len(_SAMPLE_FIELDS)))
        forces = np.empty((len(raw), 4, 2)) if with_forces else None
        for k, sample in enumerate(raw):
            where = f"trajectory.samples[{k}]"
            table[k] = [self.number(sample, key, where) for key in _SAMPLE_FIELDS]
            if k and table[k, 0] <= table[k - 1, 0]:
                raise self.error(f"{where}.t", f"expected a time after {float(table[k - 1, 0])!r} "
                                 f"(samples[{k - 1}].t), got {float(table[k, 0])!r}")
            if forces is not None:
                for column, key in enumerate(("fx", "fy")):
                    forces[k, :, column] = self.four(sample, key, where)
        return table, None if forces is None else forces[:, list(CHOREO_TO_OURS)]

    def four(self, sample: Any, key: str, where: str) -> list[float]:
        values = self.get(sample, key, where)
        if not isinstance(values, list) or len(values) != 4:
            raise self.error(f"{where}.{key}", f"expected 4 numbers (FL, BL, BR, FR), "
                                               f"got {_json(values)}")
        return [self.check(value, f"{where}.{key}[{i}]") for i, value in enumerate(values)]

    def events(self, raw: Any) -> tuple[ChoreoEvent, ...]:
        if not isinstance(raw, list):
            raise self.error("events", f"expected a list, got {_json(raw)}")
        events = []
        for i, item in enumerate(raw):
            where = f"events[{i}]"
            name = self.get(item, "name", where)
            if not isinstance(name, str):
                raise self.error(f"{where}.name", f"expected a string, got {_json(name)}")
            origin = self.get(item, "from", where)
            time = None
            if isinstance(origin, dict) and origin.get("targetTimestamp") is not None:
                time = self.number(origin, "targetTimestamp", f"{where}.from")
                if isinstance(origin.get("offset"), dict):
                    time += self.number(origin["offset"], "val", f"{where}.from.offset")
            events.append(ChoreoEvent(name, time))
        return tuple(events)
