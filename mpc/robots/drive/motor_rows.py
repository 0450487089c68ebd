"""The motor rows of a robot: its voltage, current and traction rows as one table, before
the change time and the plan the solver starts from enter (the math is in
:mod:`mpc.robots.drive.motor_limits`, which refills them each tick).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mpc.arrays import BoolArray, FloatArray
from mpc.robots.drive.force_map import ForceMap, apothem

#: Sides of the polygon standing in for a 2-D contact's traction disk in the QP, turned
#: each tick so that one edge faces the force the plan it starts from asks of the contact.
#: That edge is the disk's tangent there (the disk linearised: a converged plan may use
#: the whole traction along its force), the others midway between the inscribed and the
#: circumscribed polygon. It tracked closer than every edge midway; a constant polygon
#: took fewer daqp iterations but slipped and broke current limits on swerve
#: (docs/design/traction-sides.md). 16 sides since the traction sweep (fewer slips, the
#: same errors: docs/guide/traction.md). The clamp keeps the command sent within the disk.
TRACTION_SIDES = 16

#: How a row's direction is chosen each tick (:attr:`MotorRows.direction`): fixed, a steered
#: wheel's drive direction, a 2-D contact's planned force.
FIXED, DRIVE, FORCE = 0, 1, 2

#: The fields of :class:`MotorRows`, in order.
_FIELDS = ("s_now", "s_before", "q", "g", "bound", "voltage", "kind", "index", "end",
           "direction", "angle")


@dataclass(frozen=True, eq=False)
class MotorRows:
    """The motor rows of one stage, before the change time and the plan's values enter::

        value = d . (s_now u_k + s_before u_{k-1} + q (u_k - u_{k-1}) / dt + g coriolis)

    each matrix (m, 2, 3), ``d`` a unit 2-vector per row and stage, with ``|value| <=
    bound`` (m,) (``bound`` scaled by ``V_bus / E`` on the ``voltage`` rows). Rows are in
    fractions of the battery voltage ``E``, of the torque limit and of the traction limit.
    ``kind`` (m,): 0 voltage, 1 current, 2 traction; ``index`` (m,) the wheel (or contact);
    ``end`` (m,) whether the row holds at the end of the change (the Coriolis term of
    ``u_k``) or at its start (``u_{k-1}``'s): the voltage at the end, at the start, current
    and traction at both. ``direction`` (m,): how ``d`` is chosen: fixed (``(1, 0)``: a
    wheel's own signed row, a Swedish wheel's traction along its rollers), a steered
    wheel's drive direction (its velocity in the plan the solver starts from), or a 2-D
    contact's traction polygon turned to its planned force (``angle`` (m,): the edge's
    angle from that force).
    """

    s_now: FloatArray
    s_before: FloatArray
    q: FloatArray
    g: FloatArray
    bound: FloatArray
    voltage: BoolArray
    kind: FloatArray
    index: npt.NDArray[np.intp]
    end: BoolArray
    direction: npt.NDArray[np.intp]
    angle: FloatArray

    @property
    def rows(self) -> int:
        return int(self.bound.size)

    @functools.cached_property
    def moving(self) -> bool:
        """Whether some row's direction changes with the plan (steered wheels, balls)."""
        return bool(np.any(self.direction != FIXED))


class _RowTable:
    """Rows gathered block by block, then stacked into :class:`MotorRows`."""

    def __init__(self) -> None:
        self.parts: dict[str, list[FloatArray]] = {key: [] for key in _FIELDS}

    def add(self, s_now: FloatArray, s_before: FloatArray, q: FloatArray, g: FloatArray,
            bound: float | FloatArray, voltage: bool, kind: int, index: npt.NDArray[np.intp],
            direction: int, angle: FloatArray, ends: tuple[bool, ...] = (True, False)
            ) -> None:
        """One block of rows (matrices (r, d, 3)), once for each of ``ends``."""
        parts = self.parts
        rows = q.shape[0]
        for end in ends:
            for key, value in (("s_now", s_now), ("s_before", s_before), ("q", q),
                               ("g", g)):
                parts[key].append(_pad(value))
            parts["bound"].append(np.full(rows, bound))
            parts["voltage"].append(np.full(rows, voltage))
            parts["kind"].append(np.full(rows, float(kind)))
            parts["index"].append(index.astype(float))
            parts["end"].append(np.full(rows, end))
            parts["direction"].append(np.full(rows, float(direction)))
            parts["angle"].append(angle)

    def rows(self) -> MotorRows:
        """The table, the rows whose direction moves with the plan last."""
        stacked = {key: np.concatenate(value) for key, value in self.parts.items()}
        order = np.argsort(stacked["direction"] != FIXED, kind="stable")  # moving rows last
        stacked = {key: value[order] for key, value in stacked.items()}
        return MotorRows(s_now=stacked["s_now"], s_before=stacked["s_before"], q=stacked["q"],
                         g=stacked["g"], bound=stacked["bound"],
                         voltage=stacked["voltage"].astype(bool), kind=stacked["kind"],
                         index=stacked["index"].astype(np.intp),
                         end=stacked["end"].astype(bool),
                         direction=stacked["direction"].astype(np.intp), angle=stacked["angle"])


def _pad(matrices: FloatArray) -> FloatArray:
    """(r, d, 3) -> (r, 2, 3)."""
    out = np.zeros((matrices.shape[0], 2, 3))
    out[:, :matrices.shape[1]] = matrices
    return out


def motor_rows(forces: ForceMap) -> MotorRows:
    """The motor rows of a robot (:class:`MotorRows`): per wheel the voltage at both ends
    and the torque at both ends of each change (along the drive direction for steered
    wheels), per contact its traction at both ends (a :data:`TRACTION_SIDES`-gon turned to
    the planned force for 2-D contacts)."""
    dyn = forces.dynamics
    blocks = forces.robot.wheel_blocks  # (n, d, 3)
    n, d = blocks.shape[:2]
    keep, volts_kept = 1.0 - dyn.headroom, 1.0 - dyn.voltage_headroom
    volt = dyn.battery_voltage
    table = _RowTable()
    wheel = np.arange(n)
    steer = DRIVE if d == 2 else FIXED
    zero = np.zeros_like(blocks)
    r_over = forces.resistance / (forces.kt * volt)
    speed = blocks / (forces.kv * volt)
    for end in (True, False):
        table.add(speed if end else zero, zero if end else speed, r_over * forces.drive_map,
                  r_over * forces.effort_map, volts_kept, True, 0, wheel, steer, np.zeros(n),
                  (end,))
    limit = forces.torque_limit
    table.add(zero, zero, forces.drive_map / limit, forces.effort_map / limit, keep, False, 1,
              wheel, steer, np.zeros(n))
    _add_traction_rows(table, forces, keep)
    return table.rows()


def _add_traction_rows(table: _RowTable, forces: ForceMap, keep: float) -> None:
    """Each contact's traction at both ends of a change: its one direction's row exactly, or
    a :data:`TRACTION_SIDES`-gon for a 2-D contact (turned each tick to its planned force,
    the edge facing it tangent to the disk)."""
    traction = forces.friction_limits
    if traction is None:
        return
    for c in range(forces.n_contacts):
        direction = forces.contact_directions[c]
        contact = forces.contact_maps[c] / traction[c]  # (2, 3)
        if np.any(direction):  # one direction: its row, exactly
            row = (direction @ contact)[None, None, :]
            table.add(np.zeros_like(row), np.zeros_like(row), row, row, keep, False, 2,
                      np.array([c]), FIXED, np.zeros(1))
            continue
        sides = TRACTION_SIDES
        angles = 2.0 * math.pi * np.arange(sides // 2) / sides
        many = np.repeat(contact[None], sides // 2, axis=0)
        # the edge facing the planned force tangent to the disk (exact at a converged plan),
        # the others midway between the inscribed and the circumscribed polygon
        bound = keep * np.where(angles == 0.0, 1.0, apothem(sides))
        table.add(np.zeros_like(many), np.zeros_like(many), many, many, bound,
                  False, 2, np.full(sides // 2, c), FORCE, angles)
