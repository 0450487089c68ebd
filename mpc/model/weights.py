"""Cost weights of the tracking problem, with defaults that work across layouts."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import ControllerError
from mpc.validation import checked_constructor, file_text, is_finite_number, parsed, shown

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _diagonal(name: str, value: ArrayLike) -> FloatArray:
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):  # ragged
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf":  # bools, strings, ragged lists
        raise ControllerError(f"weight {name!r} must be a number or 3 numbers, got {shown(value)}")
    array = raw.astype(float)
    if array.ndim == 0:
        array = np.full(3, float(array))
    if array.shape != (3,):
        raise ControllerError(
            f"weight {name!r} must be a scalar or a vector of shape (3,) for (x, y, theta) "
            f"or (vx, vy, omega), got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)) or np.any(array < 0.0):
        raise ControllerError(f"weight {name!r} must be finite and >= 0, got {array.tolist()}")
    array.setflags(write=False)
    return array


_SCALARS = ("along_track", "module_rate", "progress", "progress_reward", "progress_rate",
            "contour")


@checked_constructor(ControllerError)
@dataclass(frozen=True, eq=False)
class Weights:
    """Diagonal weights of the cost (a scalar applies to all three axes).

    ``J = sum_k |x_k - xref_k|^2_pose - (1 - along_track) min(pose_x, pose_y) (t_k . e_k)^2
    + |u_k - uref_k|^2_twist + |du_k|^2_rate
    + module_rate * sum_i |G_i du_k|^2 + (the same pose terms at N with terminal)``
    with ``du_k = (u_k - u_{k-1}) - (uref_k - uref_{k-1})``, the change of twist beyond
    the reference's own (so a robot on the reference pays no rate cost for following its
    turns; into stage 0 the reference's change is extrapolated from stages 0 and 1; for a
    robot with dynamics ``du_k`` is the change of body acceleration, Coriolis term
    included, and of the reference's own only what friction allows, as its motor rows
    see it: :meth:`~mpc.model.tracking.TrackingModel.cost`) and
    ``G_i`` swerve module ``i``'s ground-velocity map, where ``e_k`` is the position
    error and ``t_k`` the reference's unit direction of travel. With ``along_track < 1``
    falling behind the reference costs less than leaving its path.

    Path mode (``Controller(mode="path")``) measures the pose error against the
    reference at the planned progress ``s_k`` instead of at ``t + k dt`` and adds
    ``contour * sum_k (n_k . e_k)^2 + progress * sum_k (r_max - r_k)^2
    - progress_reward * sum_k s_k + progress_rate * sum_k (r_{k+1} - r_k)^2`` with
    ``r_k = (s_{k+1} - s_k) / dt``: a heavier weight on the error across the path
    (``n_k`` the normal to the direction of travel), a pull of the progress rate
    towards the fastest allowed, a reward for progress and a smoothing of its rate.

    Attributes:
        pose: on (x, y, theta) error [1/m^2, 1/m^2, 1/rad^2].
        twist: on the deviation from the feedforward twist [s^2/m^2, s^2/m^2, s^2/rad^2].
        rate: on the change of twist between stages beyond the reference's own change
            (same units as ``twist``).
        terminal: on the pose error at the end of the horizon.
        along_track: factor in [0, 1] on the position weight along the
            reference's direction of travel (1 = isotropic).
        module_rate: swerve only, on the change of each module's ground
            velocity between stages beyond the reference's own [s^2/m^2]; it keeps
            steering motions smooth enough for a rate-limited steering motor.
        progress: path mode, pull of every stage's progress rate towards the fastest
            allowed [1]: keeps the robot driving at the pace its wheels allow along the
            whole horizon.
        progress_reward: path mode, reward per second of progress at each stage [1/s]:
            holds the progress on the clock where the robot can keep up and makes good a
            lag where the reference slows down. A robot that cannot keep up trails its
            reference point by about ``progress_reward / (2 pose_xy |v_ref|^2)`` s.
        progress_rate: path mode, on the change of the progress rate between stages
            (dimensionless rate, so [1]).
        contour: path mode, added on the position error across the path (normal to the
            reference's direction of travel) [1/m^2]: staying on the path weighs more
            than keeping up with the progress.
    """

    pose: FloatArray = field(default_factory=lambda: np.array([200.0, 200.0, 50.0]))
    twist: FloatArray = field(default_factory=lambda: np.array([1.0, 1.0, 0.1]))
    rate: FloatArray = field(default_factory=lambda: np.array([0.2, 0.2, 0.02]))
    terminal: FloatArray = field(default_factory=lambda: np.array([400.0, 400.0, 100.0]))
    along_track: float = 1.0
    module_rate: float = 1.0
    progress: float = 0.1
    progress_reward: float = 0.2
    progress_rate: float = 0.01
    contour: float = 2000.0

    def __post_init__(self) -> None:
        for item in fields(self):
            if item.name in _SCALARS:
                continue
            object.__setattr__(self, item.name, _diagonal(item.name, getattr(self, item.name)))
        for name in ("module_rate", "progress", "progress_reward", "progress_rate", "contour"):
            value = getattr(self, name)
            if not is_finite_number(value) or value < 0.0:
                raise ControllerError(f"weight {name!r} must be a finite number >= 0, "
                                      f"got {shown(value)}")
            object.__setattr__(self, name, float(value))
        if not (np.any(self.pose > 0.0) or np.any(self.terminal > 0.0)):
            raise ControllerError("weights 'pose' and 'terminal' are all zero: nothing ties the "
                                  "plan to the reference; give one of them a positive entry")
        along = self.along_track
        if not is_finite_number(along) or not 0.0 <= along <= 1.0:
            raise ControllerError(f"weight 'along_track' must be a number in [0, 1], "
                                  f"got {shown(along)}")
        object.__setattr__(self, "along_track", float(along))


def make_weights(weights: Weights | Mapping[str, ArrayLike] | None) -> Weights:
    """Accept Weights, a dict of overrides (unknown names are an error), or None."""
    if weights is None:
        return Weights()
    if isinstance(weights, Weights):
        return weights
    if isinstance(weights, Mapping):
        known = {item.name for item in fields(Weights)}
        unknown = sorted(map(str, set(weights) - known))
        if unknown:
            raise ControllerError(
                f"unknown weight name(s) {unknown}; expected some of {sorted(known)}")
        return Weights(**weights)  # type: ignore[arg-type]
    raise ControllerError(f"weights must be Weights, a dict or None, got {type(weights).__name__}")


def load_weights(path: str | Path) -> Weights:
    """Weights from a TOML file of weight names (any of :class:`Weights`' fields; the others
    keep their defaults), e.g. as ``mpc-bench tune`` writes them::

        pose = [200.0, 200.0, 12.5]     # [1/m^2, 1/m^2, 1/rad^2]
        terminal = [600.0, 600.0, 37.5]
        twist = 0.5                      # a scalar applies to all three axes

    Unknown names, tables and values that are not numbers are a
    :class:`~mpc.errors.ControllerError` naming the file. Pass the result as
    ``Controller(..., weights=load_weights(path))``.
    """
    text = file_text(path, "weights", ControllerError)
    file = Path(path)
    table = parsed(tomllib.loads, text, f"weights file {str(file)!r}", "TOML", ControllerError)
    try:
        return make_weights(table)
    except ControllerError as error:
        raise ControllerError(f"weights file {str(file)!r}: {error}") from None


#: Folder of the tuned weight presets: ``<robot name>.toml`` as ``mpc-bench tune`` wrote it.
_TUNED = Path(__file__).with_name("tuned")


def tuned_layouts() -> tuple[str, ...]:
    """Names of the preset robots that have tuned weights (see :func:`tuned_weights`)."""
    return tuple(sorted(path.stem for path in _TUNED.glob("*.toml")))


def tuned_weights(name: str) -> Weights:
    """The tuned time-mode weights of preset robot ``name`` (e.g. ``robot.name``).

    Tuned with ``mpc-bench tune --objective baseline --speeds beyond`` (the command is
    the first lines of each file in ``mpc/model/tuned/``): they trade position against
    heading error on references 30% beyond the wheel limits, where the defaults leave
    heading error a baseline would not. Inside the limits both track to a fraction of a
    millimetre. Unknown names are a :class:`~mpc.errors.ControllerError` listing
    :func:`tuned_layouts`.
    """
    if not isinstance(name, str) or name not in tuned_layouts():
        raise ControllerError(f"no tuned weights for robot {name!r}; tuned presets: "
                              f"{', '.join(tuned_layouts())}")
    return load_weights(_TUNED / f"{name}.toml")
