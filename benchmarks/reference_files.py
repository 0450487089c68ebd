"""References from files for ``mpc-bench --trajectory FILE``: Choreo ``.traj`` and CSV.

A Choreo file (:func:`trajectories.read_choreo`) runs on the swerve robot it was planned
for (modules, wheel radius, vmax / gearing from its ``config``); a CSV of waypoints
(columns t, x, y, theta) has no robot and runs on every chosen layout. Either runs as
given (speed ``as-given``), named after the file (``path/to/auto.traj`` -> ``auto``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from benchmarks.runner import Scenario
from benchmarks.scenarios import ScenarioError
from mpc.robots import Robot
from trajectories import Trajectory, Waypoints, read_choreo

#: The file kinds ``--trajectory`` reads, by extension.
SUFFIXES: tuple[str, ...] = (".traj", ".csv")


@dataclass(frozen=True)
class ReferenceFile:
    """A reference read from ``path``: its scenario ``name`` (the file's stem), the
    ``trajectory``, the ``robot`` it was planned for (None: runs on the chosen layouts)
    and its ``kind`` (``"choreo"`` or ``"csv"``, the scenario's heading label)."""

    path: Path
    name: str
    trajectory: Trajectory
    robot: Robot | None
    kind: str


def read_reference(path: str | os.PathLike[str]) -> ReferenceFile:
    """The reference in a Choreo ``.traj`` or waypoint ``.csv`` file; every problem with
    the file is a one-line error naming the file (and, for Choreo, the field)."""
    file = Path(path)
    suffix = file.suffix.lower()
    if suffix == ".traj":
        choreo = read_choreo(file)
        return ReferenceFile(file, file.stem, choreo, choreo.robot, "choreo")
    if suffix == ".csv":
        return ReferenceFile(file, file.stem, Waypoints.from_csv(file), None, "csv")
    raise ScenarioError(f"trajectory file {str(file)!r}: expected a Choreo .traj or a waypoint "
                        f".csv (t,x,y,theta), got {'no extension' if not suffix else suffix}")


def file_scenarios(files: list[ReferenceFile], robots: dict[str, Robot]) -> list[Scenario]:
    """One scenario per file on its own robot, or per file and robot of ``robots`` for a
    file without one; names must be unique (they name the report's figures)."""
    seen: dict[str, Path] = {}
    for file in files:
        if file.name in seen:
            raise ScenarioError(f"trajectory files {str(seen[file.name])!r} and "
                                f"{str(file.path)!r} have one name, {file.name!r}: rename one")
        seen[file.name] = file.path
    scenarios: list[Scenario] = []
    for file in files:
        targets = robots if file.robot is None else {file.robot.name: file.robot}
        scenarios.extend(Scenario(layout, robot, file.name, file.trajectory, "as-given",
                                  file.kind) for layout, robot in targets.items())
    return scenarios


__all__ = ["SUFFIXES", "ReferenceFile", "file_scenarios", "read_reference"]
