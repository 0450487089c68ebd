"""Timed waypoints joined by clamped cubic splines, optionally read from a CSV file."""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.interpolate import CubicSpline

from mpc.validation import MAX_COORDINATE, MAX_TIME, file_text, real_array, within

from ._validation import FloatArray, first_overflow
from .base import Trajectory
from .errors import TrajectoryError
from .heading import HeadingDerivatives, HeadingProfile, HeadingSpec
from .path import PathDerivatives

_CSV_COLUMNS = ("t", "x", "y", "theta")


class _CubicPieces:
    """A scipy CubicSpline and its first three derivatives, evaluated together.

    Same polynomials as ``spline.derivative(k)``, k = 0..3, rearranged so that
    one interval search and one Horner pass give all four (this runs on the
    control path: the four separate spline calls cost several times more).
    """

    def __init__(self, spline: CubicSpline) -> None:
        breaks = np.asarray(spline.x, dtype=np.float64)
        coefficients = np.asarray(spline.c, dtype=np.float64)  # (4, pieces, m), c[k] * tau^(3-k)
        pieces, width = coefficients.shape[1], coefficients.shape[2]
        # powers[piece, p, d, :] multiplies tau^p in the d-th derivative
        powers = np.zeros((pieces, 4, 4, width))
        for k in range(4):
            degree = 3 - k
            for order in range(degree + 1):
                factor = math.factorial(degree) // math.factorial(degree - order)
                powers[:, degree - order, order, :] += factor * coefficients[k]
        self._width = width
        self._starts = breaks[:-1]
        self._interior = breaks[1:-1]
        self._powers = powers.reshape(pieces, 4, 4 * width)

    def first_overflow(self) -> int | None:
        """Index of the first piece with a non-finite coefficient, None if all are finite."""
        return first_overflow(self._powers)

    def evaluate(self, t: FloatArray) -> FloatArray:
        """Values and derivatives 0..3 at times t: shape t.shape + (4, m).

        Times outside the breakpoints use the first or last polynomial.
        """
        index = np.searchsorted(self._interior, t, side="right")
        tau = (t - self._starts[index])[..., np.newaxis]
        powers = self._powers.take(index, axis=0)
        flat = powers[..., 3, :] * tau
        flat += powers[..., 2, :]
        flat *= tau
        flat += powers[..., 1, :]
        flat *= tau
        flat += powers[..., 0, :]
        return flat.reshape(np.shape(t) + (4, self._width))


@dataclass(frozen=True, repr=False)
class _WaypointThetaHeading(HeadingProfile):
    """theta from a clamped cubic spline through the waypoints' (unwrapped) theta column."""

    pieces: _CubicPieces

    def evaluate(self, t: FloatArray, path: PathDerivatives) -> HeadingDerivatives:
        """Spline value, first and second derivative."""
        derivatives = self.pieces.evaluate(t)
        return HeadingDerivatives(
            derivatives[..., 0, 0], derivatives[..., 1, 0], derivatives[..., 2, 0]
        )

    def __repr__(self) -> str:
        return "WaypointThetaHeading()"


class Waypoints(Trajectory):
    """Timed waypoints (t_i, x_i, y_i, theta_i) joined by clamped cubic splines.

    x(t) and y(t) are SciPy ``CubicSpline``s with ``bc_type="clamped"`` (zero
    velocity at the first and last waypoint); velocities, accelerations and
    jerks are the spline's exact derivatives. With ``heading=None`` theta is
    the same kind of spline through the theta column after ``np.unwrap``
    (so 3.1 then -3.1 rad turns by 0.08 rad, not -6.2); any other ``heading``
    (see :func:`make_heading`) overrides the theta column. Outside
    [times[0], times[-1]] the end pose is held with zero velocity and
    acceleration. Not periodic.

    Args:
        times: shape (n,), strictly increasing, n >= 2 [s].
        poses: shape (n, 3), rows (x, y, theta) [m, m, rad].
        heading: None (interpolate theta) or a heading spec.
    """

    def __init__(
        self,
        times: npt.ArrayLike,
        poses: npt.ArrayLike,
        heading: HeadingSpec | None = None,
    ) -> None:
        self._times = _validated_times(times)
        count = self._times.size
        self._poses = _validated_poses(poses, count)
        self._path_pieces = _spline(self._times, self._poses[:, :2])
        profile: HeadingSpec
        if heading is None:
            theta = np.unwrap(self._poses[:, 2])[:, np.newaxis]
            profile = _WaypointThetaHeading(_spline(self._times, theta))
        else:
            profile = heading
        super().__init__(profile)

    @classmethod
    def from_csv(
        cls, path: str | os.PathLike[str], heading: HeadingSpec | None = None
    ) -> Waypoints:
        """Waypoints from a CSV file with a header row naming columns t, x, y and theta.

        Columns may come in any order (names are matched ignoring case and
        surrounding spaces); other columns are ignored; theta is optional
        (default 0). Units: s, m, m, rad. Blank lines are skipped.
        """
        times, poses = read_waypoint_csv(path)
        try:
            return cls(times, poses, heading=heading)
        except TrajectoryError as error:
            raise TrajectoryError(f"waypoint file {str(Path(path))!r}: {error}") from None

    def to_csv(self, path: str | os.PathLike[str]) -> None:
        """Write the waypoints as CSV with header t,x,y,theta (floats round-trip exactly)."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(_CSV_COLUMNS)
        for time, pose in zip(self._times.tolist(), self._poses.tolist(), strict=True):
            writer.writerow([repr(time)] + [repr(value) for value in pose])
        Path(path).write_text(buffer.getvalue(), encoding="utf-8")

    @property
    def times(self) -> FloatArray:
        """Waypoint times [s], shape (n,), read-only."""
        return self._times

    @property
    def poses(self) -> FloatArray:
        """Waypoint poses (x, y, theta) [m, m, rad] as given, shape (n, 3), read-only."""
        return self._poses

    @property
    def start_time(self) -> float:
        """Time of the first waypoint [s]."""
        return float(self._times[0])

    @property
    def end_time(self) -> float:
        """Time of the last waypoint [s]; the last pose is held afterwards."""
        return float(self._times[-1])

    def _path(self, t: FloatArray) -> PathDerivatives:
        derivatives = self._path_pieces.evaluate(t)
        return PathDerivatives(
            derivatives[..., 0, :],
            derivatives[..., 1, :],
            derivatives[..., 2, :],
            derivatives[..., 3, :],
        )

    def __repr__(self) -> str:
        return (
            f"Waypoints(<{self._times.size} waypoints, t in [{self.start_time!r}, "
            f"{self.end_time!r}] s>, heading={self.heading!r})"
        )


def _spline(times: FloatArray, values: FloatArray) -> _CubicPieces:
    """The clamped cubic spline through ``values`` at ``times`` (axis 0), or TrajectoryError
    naming the first interval whose polynomial overflows (waypoints too close in time for
    the distance between them)."""
    try:
        with np.errstate(all="ignore"):  # overflow is checked below
            pieces: _CubicPieces | None = _CubicPieces(
                CubicSpline(times, values, bc_type="clamped", axis=0))
    except ValueError:  # SciPy refuses slopes that overflow
        pieces = None
    bad = 0 if pieces is None else pieces.first_overflow()
    if bad is not None:
        raise TrajectoryError(
            "waypoint times are too close together for the distance between their poses: "
            f"the spline overflows double precision near times[{bad}]={float(times[bad])!r}")
    return pieces  # type: ignore[return-value]


def _validated_times(times: npt.ArrayLike) -> FloatArray:
    values = real_array("waypoint times", times, "a 1-D array of finite numbers [s]",
                        TrajectoryError)
    if values.ndim != 1 or values.size < 2:
        raise TrajectoryError(
            f"waypoint times must be a 1-D array of at least 2 times [s], got shape {values.shape}"
        )
    within("waypoint times", values, MAX_TIME, "[s]", TrajectoryError)
    steps = np.diff(values)
    if not (steps > 0.0).all():
        k = int(np.flatnonzero(steps <= 0.0)[0]) + 1
        raise TrajectoryError(
            "waypoint times must be strictly increasing, got "
            f"times[{k}]={float(values[k])!r} after times[{k - 1}]={float(values[k - 1])!r}"
        )
    values.flags.writeable = False
    return values


def _validated_poses(poses: npt.ArrayLike, count: int) -> FloatArray:
    values = real_array("waypoint poses", poses, f"an array of shape ({count}, 3) (x, y, theta)",
                        TrajectoryError)
    if values.shape != (count, 3):
        raise TrajectoryError(
            f"waypoint poses must have shape ({count}, 3) (x, y, theta) to match {count} "
            f"times, got shape {values.shape}"
        )
    within("waypoint poses", values, MAX_COORDINATE, "(m, m, rad)", TrajectoryError)
    values.flags.writeable = False
    return values


def read_waypoint_csv(path: str | os.PathLike[str]) -> tuple[FloatArray, FloatArray]:
    """Times (n,) [s] and poses (n, 3) [m, m, rad] from a waypoint CSV file.

    See :meth:`Waypoints.from_csv` for the format. Raises :class:`TrajectoryError`
    for a missing or unreadable file, missing columns, short rows, non-numeric
    or non-finite values, fewer than 2 rows or non-increasing times, naming
    the line.
    """
    text = file_text(path, "waypoint", TrajectoryError)  # refuses a path that is not one
    file = Path(path)
    reader = csv.reader(io.StringIO(text))
    try:
        return _parse_waypoints(file, reader)
    except csv.Error as error:  # e.g. a field over the csv module's size limit
        raise TrajectoryError(f"waypoint file {str(file)!r}, line {reader.line_num}: "
                              f"unreadable CSV: {error}") from None


def _parse_waypoints(file: Path, reader: Any) -> tuple[FloatArray, FloatArray]:
    """Times and poses from the rows of a waypoint CSV (see :func:`read_waypoint_csv`)."""
    header: list[str] | None = None
    for row in reader:
        if any(field.strip() for field in row):
            header = [field.strip().lower() for field in row]
            break
    if header is None:
        raise TrajectoryError(
            f"waypoint file {str(file)!r} is empty, expected a header row with columns "
            "t, x, y and optionally theta"
        )
    for name in _CSV_COLUMNS:
        if header.count(name) > 1:
            raise TrajectoryError(
                f"waypoint file {str(file)!r} has column {name!r} more than once: header {header}"
            )
    missing = [name for name in _CSV_COLUMNS[:3] if name not in header]
    if missing:
        raise TrajectoryError(
            f"waypoint file {str(file)!r} is missing column(s) {', '.join(missing)}: "
            f"expected a header with t, x, y and optionally theta, got {header}"
        )
    used = [name for name in _CSV_COLUMNS if name in header]
    indices = [header.index(name) for name in used]
    needed_fields = max(indices) + 1

    rows: list[list[float]] = []
    lines: list[int] = []
    for row in reader:
        if not any(field.strip() for field in row):
            continue
        line = reader.line_num
        if len(row) < needed_fields:
            raise TrajectoryError(
                f"waypoint file {str(file)!r}, line {line}: expected at least {needed_fields} "
                f"fields for columns {used}, got {len(row)}"
            )
        values = []
        for name, index in zip(used, indices, strict=True):
            field = row[index].strip()
            try:
                value = float(field)
            except ValueError:
                raise TrajectoryError(
                    f"waypoint file {str(file)!r}, line {line}, column {name!r}: "
                    f"expected a number, got {field!r}"
                ) from None
            if not math.isfinite(value):
                raise TrajectoryError(
                    f"waypoint file {str(file)!r}, line {line}, column {name!r}: "
                    f"expected a finite number, got {field!r}"
                )
            values.append(value)
        if rows and values[0] <= rows[-1][0]:
            raise TrajectoryError(
                f"waypoint file {str(file)!r}: times must be strictly increasing, but line "
                f"{line} has t={values[0]!r} after t={rows[-1][0]!r} on line {lines[-1]}"
            )
        rows.append(values)
        lines.append(line)
    if len(rows) < 2:
        raise TrajectoryError(
            f"waypoint file {str(file)!r} needs at least 2 waypoint rows, got {len(rows)}"
        )
    table = np.array(rows, dtype=np.float64)
    poses = np.zeros((len(rows), 3))
    for column, name in enumerate(used[1:]):
        poses[:, _CSV_COLUMNS.index(name) - 1] = table[:, column + 1]
    return table[:, 0], poses
