"""Named layouts of the flat vectors the solvers work on, written in one place.

A :class:`Layout` is an ordered list of named fields, each a block of
``stages x width`` numbers stored stage-major (C order). NumPy sees a field
as a ``(stages, width)`` view of the flat vector; CasADi, which stores
column-major, sees the same numbers as a ``width x stages`` matrix whose
column ``k`` is stage ``k``. Both views come from here, so the decision
vector ``z`` and the parameter vector ``p`` are laid out once.

:func:`tracking_layouts` gives the tracking problem's two layouts:

- ``z = (poses: x_0 .. x_N, twists: u_0 .. u_{N-1})``;
- ``p = (x0, poses_ref: xref_0 .. xref_N, twists_ref: uref_0 .. uref_{N-1},
  directions: t_0 .. t_N, last_twist: u_{-1})`` where ``t_k`` is the
  reference's unit direction of travel.

Robots with steered wheels append their present ``steer_angles`` to ``p``.
Path mode appends ``progress: s_0 .. s_N`` (reference time reached at each
stage [s]) to ``z`` and ``progress_guess: sbar_0 .. sbar_N`` (where the
reference was sampled), ``path_rates`` (d pose_ref / d s at ``sbar_k``),
``path_curvatures`` (d^2 pose_ref / d s^2 there) and ``feedforward_rates``
(the feedforward twist of stage ``k`` per unit progress rate) to ``p``;
``poses_ref`` and ``twists_ref`` are then the reference at ``sbar_k``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray


@dataclass(frozen=True)
class Field:
    """One named block: ``stages`` rows of ``width`` numbers from ``start``.

    ``stages`` is 0 for a plain vector of ``width`` numbers.
    """

    name: str
    start: int
    stages: int
    width: int

    @property
    def size(self) -> int:
        return max(self.stages, 1) * self.width

    @property
    def slice(self) -> slice:
        return slice(self.start, self.start + self.size)

    @property
    def shape(self) -> tuple[int, ...]:
        return (self.stages, self.width) if self.stages else (self.width,)


class Layout:
    """Named fields of a flat vector, in order.

    Args:
        fields: ``(name, shape)`` pairs; ``shape`` is ``(width,)`` for a
            plain vector or ``(stages, width)`` for one row per stage.
    """

    def __init__(self, *fields: tuple[str, tuple[int, ...]]) -> None:
        self.fields: dict[str, Field] = {}
        start = 0
        for name, shape in fields:
            stages, width = (0, shape[0]) if len(shape) == 1 else shape
            item = Field(name, start, stages, width)
            self.fields[name] = item
            start += item.size
        self.size = start

    def __getitem__(self, name: str) -> Field:
        return self.fields[name]

    def view(self, vector: FloatArray, name: str) -> FloatArray:
        """The field as a NumPy view of ``vector``: shape (stages, width) or (width,)."""
        item = self.fields[name]
        return vector[item.slice].reshape(item.shape)

    def symbol(self, vector: ca.SX, name: str) -> ca.SX:
        """The field of a CasADi vector as a ``width x stages`` matrix (a column per stage)."""
        item = self.fields[name]
        block = vector[item.start:item.start + item.size]
        return block if not item.stages else ca.reshape(block, item.width, item.stages)


class TrackingLayouts(NamedTuple):
    """The decision vector's and the parameter vector's layouts."""

    variables: Layout
    parameters: Layout


def tracking_layouts(horizon: int, path: bool = False, steered: int = 0) -> TrackingLayouts:
    """The layouts of ``z`` and ``p`` for a horizon of ``N`` ticks (module docstring);
    ``path`` adds the path-mode fields, ``steered`` wheels their present steer angles."""
    n = horizon
    z_fields: list[tuple[str, tuple[int, ...]]] = [("poses", (n + 1, 3)), ("twists", (n, 3))]
    p_fields: list[tuple[str, tuple[int, ...]]] = [
        ("x0", (3,)), ("poses_ref", (n + 1, 3)), ("twists_ref", (n, 3)),
        ("directions", (n + 1, 2)), ("last_twist", (3,))]
    if steered:
        p_fields.append(("steer_angles", (steered,)))
    if path:
        z_fields.append(("progress", (n + 1,)))
        p_fields += [("progress_guess", (n + 1,)), ("path_rates", (n + 1, 3)),
                     ("path_curvatures", (n + 1, 3)), ("feedforward_rates", (n, 3))]
    return TrackingLayouts(Layout(*z_fields), Layout(*p_fields))


class TickInput:
    """One tick's data for a solver: ``p`` and the guess ``z``, with named views into them.

    The controller writes the views in place each tick (no allocation); the
    solvers read the flat vectors (``parameters``, ``guess``) or the views.
    """

    def __init__(self, layouts: TrackingLayouts) -> None:
        self.layouts = layouts
        p, z = layouts.parameters, layouts.variables
        self.parameters = np.zeros(p.size)
        self.guess = np.zeros(z.size)
        self.pose = p.view(self.parameters, "x0")  # measured pose (3,) [m, m, rad]
        self.poses_ref = p.view(self.parameters, "poses_ref")  # (N+1, 3)
        self.twists_ref = p.view(self.parameters, "twists_ref")  # feedforward (N, 3)
        self.directions = p.view(self.parameters, "directions")  # (N+1, 2), unit or 0
        self.last_twist = p.view(self.parameters, "last_twist")  # last command (3,)
        self.guess_poses = z.view(self.guess, "poses")  # (N+1, 3)
        self.guess_twists = z.view(self.guess, "twists")  # (N, 3)
        # present steer angles of steered wheels [rad] (the last command's), else None
        self.steer_angles = (p.view(self.parameters, "steer_angles")
                             if "steer_angles" in p.fields else None)
        self.path = PathInput(layouts, self) if "progress" in z.fields else None


class PathInput:
    """Path mode's part of a :class:`TickInput`: views, plus the progress bounds [s]."""

    def __init__(self, layouts: TrackingLayouts, tick: TickInput) -> None:
        p, z = layouts.parameters, layouts.variables
        self.progress_guess = p.view(tick.parameters, "progress_guess")  # sbar (N+1,) [s]
        self.path_rates = p.view(tick.parameters, "path_rates")  # (N+1, 3) d pose / d s
        self.path_curvatures = p.view(tick.parameters, "path_curvatures")  # (N+1, 3)
        self.feedforward_rates = p.view(tick.parameters, "feedforward_rates")  # (N, 3)
        self.guess_progress = z.view(tick.guess, "progress")  # (N+1,) [s]
        size = z["progress"].size
        self.lower = np.zeros(size)  # bounds on s_k [s]; s_0 fixed: lower[0] = upper[0]
        self.upper = np.zeros(size)
