"""The first command within the motor limits: the clamp's step fraction and the
feedforward a command carries (:mod:`mpc.robots.drive.motor_limits` has the plan's rows)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mpc.arrays import FloatArray
from mpc.robots.base import Robot
from mpc.robots.drive.dynamics import bus_voltage
from mpc.robots.drive.force_map import AT_REST, ForceMap, force_map

#: The share of each headroom (``headroom``, ``voltage_headroom``) the final clamp keeps for
#: the first command (the plan keeps it all): the rest absorbs the plan's linearisation
#: (Coriolis term, sag) so that the clamp does not cut a plan for its second-order terms.
CLAMP_HEADROOM = 0.5


@dataclass(frozen=True, eq=False)
class _StepRows:
    """The first step's linear rows ``start = a @ last + b @ turn`` and
    ``slope = c @ step + e @ step / dt`` (the voltage at the end and the start of the step,
    the torque, one-direction traction), for wheels that do not steer; in units of their
    bounds except the voltage rows (V)."""

    a: FloatArray
    b: FloatArray
    c: FloatArray
    e: FloatArray
    wheels: int
    disks: bool  # some contact's force is a 2-D vector (a ball): a disk, not a row
    at_end: npt.NDArray[np.intp]  # the rows that hold at the step's end
    at_start: npt.NDArray[np.intp]  # and at its start


_STEP_ROWS: dict[int, tuple[ForceMap, _StepRows]] = {}


def _step_rows(forces: ForceMap) -> _StepRows:
    cached = _STEP_ROWS.get(id(forces))
    if cached is not None and cached[0] is forces:
        return cached[1]
    keep = 1.0 - CLAMP_HEADROOM * forces.dynamics.headroom
    w, effort, drive = forces.flat_blocks, forces.flat_effort, forces.flat_drive
    r_kt = forces.resistance / forces.kt
    zero = np.zeros_like(w)
    limit = keep * forces.torque_limit
    a = [w / forces.kv, w / forces.kv, zero]
    b = [r_kt * effort, r_kt * effort, effort / limit]
    c = [w / forces.kv, zero, zero]
    e = [r_kt * drive, r_kt * drive, drive / limit]
    traction = forces.friction_limits
    if traction is not None:
        for index in np.flatnonzero(np.any(forces.contact_directions != 0.0, axis=1)):
            row = forces.contact_directions[index] @ forces.contact_maps[index]
            row = (row / (keep * traction[index]))[None, :]
            a.append(np.zeros_like(row))
            b.append(row)
            c.append(np.zeros_like(row))
            e.append(row)
    disks = traction is not None and not np.all(np.any(forces.contact_directions != 0.0,
                                                         axis=1))
    n = w.shape[0]
    total = sum(part.shape[0] for part in a)
    rows = _StepRows(np.vstack(a), np.vstack(b), np.vstack(c), np.vstack(e), wheels=n,
                     disks=bool(disks), at_end=np.r_[0:n, 2 * n:total],
                     at_start=np.r_[n:total])
    _STEP_ROWS[id(forces)] = (forces, rows)
    return rows


def motor_step_fraction(robot: Robot, last: FloatArray, target: FloatArray, dt: float,
                        steer_angles: FloatArray | None) -> float:
    """The largest ``f`` in [0, 1] such that the step ``last -> last + f (target - last)``
    over ``dt`` keeps every wheel within its battery voltage and current limit and every
    contact within traction (headroom included), the present wheel speeds being
    ``last``'s; 1 without dynamics. As the QP's rows, the limits hold at both ends of the
    step, each with its own Coriolis term: ``last``'s at the start, at the end the chord
    from ``last``'s (at ``f = 0``) to ``target``'s (it moves with the twist, so call again
    with the twist this returns, as the clamp does). Steered wheels drive along
    ``target``'s module directions (the steer angles where at rest); the bus voltage is
    the one under the whole step's power. A limit ``last`` itself breaks only stops the
    step from going further into it."""
    if robot.dynamics is None:
        return 1.0
    forces = force_map(robot)
    if robot.wheel_dim == 2:
        return _steered_step_fraction(forces, last, target, dt, steer_angles)
    dyn = forces.dynamics
    rows = _step_rows(forces)
    step = target - last
    turn_end = np.array([-target[2] * target[1], target[2] * target[0], 0.0])
    turn_start = np.array([-last[2] * last[1], last[2] * last[0], 0.0])
    # At f = 0 the step is the present state (last's Coriolis term at both ends); the
    # end's Coriolis term runs to target's along the step (its chord).
    start = rows.a @ last + rows.b @ turn_start
    slope = rows.c @ step + rows.e @ (step / dt)
    slope_end = slope + rows.b @ (turn_end - turn_start)
    n = rows.wheels
    keep = 1.0 - CLAMP_HEADROOM * dyn.headroom
    torque_scale = keep * forces.torque_limit  # the torque rows are in its units
    fraction = _sag_fraction(
        forces, volts=(start[:2 * n], np.concatenate([slope_end[:n], slope[n:2 * n]])),
        others=(np.concatenate([start[2 * n:], start[2 * n:]]),
                np.concatenate([slope_end[2 * n:], slope[2 * n:]])),
        power=(start[:n], slope_end[:n], torque_scale * start[2 * n:3 * n],
               torque_scale * slope_end[2 * n:3 * n]))
    if rows.disks:
        fraction = _traction_fraction(forces, fraction, step, turn_start, turn_end, dt, keep)
    return max(0.0, fraction * (1.0 - 1e-12))


def _steered_step_fraction(forces: ForceMap, last: FloatArray, target: FloatArray, dt: float,
                           steer_angles: FloatArray | None) -> float:
    """:func:`motor_step_fraction` for steered wheels (drive components along their
    directions, traction disks)."""
    dyn = forces.dynamics
    keep = 1.0 - CLAMP_HEADROOM * dyn.headroom
    step = target - last
    turn_end = np.array([-target[2] * target[1], target[2] * target[0], 0.0])
    turn_start = np.array([-last[2] * last[1], last[2] * last[0], 0.0])
    n = forces.robot.n_wheels
    values = np.empty((6, 2 * n))
    values[0] = forces.flat_blocks @ last
    values[1] = forces.flat_blocks @ step
    values[2] = forces.flat_effort @ turn_end
    values[3] = forces.flat_effort @ turn_start
    values[4] = forces.flat_drive @ step
    values[5] = values[0] + values[1]  # the target's wheel velocities: the directions
    pairs = values.reshape(6, n, 2)
    speed = np.hypot(pairs[5, :, 0], pairs[5, :, 1])
    moving = speed > AT_REST
    angles = np.zeros(n) if steer_angles is None else steer_angles
    cos = np.where(moving, pairs[5, :, 0] / np.where(moving, speed, 1.0), np.cos(angles))
    sin = np.where(moving, pairs[5, :, 1] / np.where(moving, speed, 1.0), np.sin(angles))
    speed0, speed1, torque_end, torque0, torque1 = (pairs[:5, :, 0] * cos
                                                    + pairs[:5, :, 1] * sin)
    torque1 = torque1 / dt
    turned = torque_end - torque0  # the end's Coriolis term runs to target's (a chord)
    r_kt = forces.resistance / forces.kt
    volts0 = speed0 / forces.kv + r_kt * torque0
    end_slope = speed1 / forces.kv + r_kt * (torque1 + turned)
    limit = keep * forces.torque_limit
    fraction = _sag_fraction(
        forces, volts=(np.concatenate([volts0, volts0]),
                       np.concatenate([end_slope, r_kt * torque1])),
        others=(np.concatenate([torque0, torque0]) / limit,
                np.concatenate([torque1 + turned, torque1]) / limit),
        power=(volts0, end_slope, torque0, torque1 + turned))
    fraction = _traction_fraction(forces, fraction, step, turn_start, turn_end, dt, keep)
    return max(0.0, fraction * (1.0 - 1e-12))


def _traction_fraction(forces: ForceMap, fraction: float, step: FloatArray,
                       turn_start: FloatArray, turn_end: FloatArray, dt: float,
                       keep: float) -> float:
    """``fraction`` shortened so each contact force stays in its traction disk at both ends
    of the change (the end's Coriolis term along the chord from start to target)."""
    traction = forces.friction_limits
    if traction is None or fraction <= 0.0:
        return fraction
    force0 = (forces.flat_contacts @ turn_start).reshape(-1, 2)
    force1 = (forces.flat_contacts @ step).reshape(-1, 2) / dt
    chord = (forces.flat_contacts @ (turn_end - turn_start)).reshape(-1, 2)
    return min(fraction, _disk_fraction(force0, force1 + chord, keep * traction),
               _disk_fraction(force0, force1, keep * traction))


def _sag_fraction(forces: ForceMap, volts: tuple[FloatArray, FloatArray],
                  others: tuple[FloatArray, FloatArray],
                  power: tuple[FloatArray, FloatArray, FloatArray, FloatArray]) -> float:
    """Largest f in [0, 1] with every voltage row ``|v0 + f v1|`` [V] within the clamp's
    share of the bus voltage under the step's power at ``f`` and every other row
    ``|o0 + f o1| <= 1``. ``power``: end voltages and torques ``(V0, V1, T0, T1)`` (the
    power at f is ``sum (V0 + f V1)(T0 + f T1) / kt``)."""
    dyn = forces.dynamics
    keep = 1.0 - CLAMP_HEADROOM * dyn.voltage_headroom
    upper = _linear_fraction(*others)
    v0, v1 = volts

    def bus(fraction: float) -> float:
        if dyn.battery_resistance == 0.0:
            return dyn.battery_voltage
        e0, e1, t0, t1 = power
        drawn = float((e0 + fraction * e1) @ (t0 + fraction * t1)) / forces.kt
        return bus_voltage(dyn.battery_voltage, dyn.battery_resistance, drawn)

    def reach(fraction: float) -> float:
        scale = 1.0 / (keep * bus(fraction))
        return _linear_fraction(v0 * scale, v1 * scale)

    if upper <= 0.0:
        return 0.0
    if reach(upper) >= upper:
        return upper
    if dyn.battery_resistance == 0.0:
        return reach(upper)
    # the bus sags with the step's power: the largest f that fits under its own bus
    low, high = 0.0, upper
    if reach(0.0) <= 0.0:
        return 0.0
    for _ in range(12):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if reach(middle) >= middle else (low, middle)
    return low


#: A row whose change over the whole step is below this (in units of its bound) does not
#: move: rounding, not a direction (a wheel held at its speed limit keeps its voltage row
#: where it is). Taken as a direction, a row already beyond its bound stopped the whole step
#: or not by the sign of that rounding (mpc.tick's compiled clamp and this one disagreed).
STILL_SLOPE = 1e-12


def _linear_fraction(start: FloatArray, slope: FloatArray) -> float:
    """Largest f in [0, 1] with ``|start + f slope| <= 1`` for every entry; an entry already
    beyond it may not go further out (then 0), only back in; an entry the step does not
    move (:data:`STILL_SLOPE`) does not limit it."""
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = np.where(np.abs(slope) <= STILL_SLOPE, np.inf,
                         (np.copysign(1.0, slope) - start) / slope)
    return float(min(1.0, max(0.0, reach.min())))


def _disk_fraction(start: FloatArray, slope: FloatArray, bound: FloatArray) -> float:
    """Largest f in [0, 1] with ``|start_c + f slope_c| <= bound_c`` for every row c (rows
    already beyond it: only as far as their closest approach)."""
    a = (slope * slope).sum(axis=1)
    h = (start * slope).sum(axis=1)
    c = (start * start).sum(axis=1) - bound * bound
    moving = a > 0.0
    safe_a = np.where(moving, a, 1.0)
    inside = (-h + np.sqrt(np.maximum(h * h - a * c, 0.0))) / safe_a
    reach = np.where(c > 0.0, np.maximum(0.0, -h / safe_a), inside)
    return float(min(1.0, np.where(moving, reach, np.inf).min()))


def first_step_feedforward(robot: Robot, last: FloatArray, twist: FloatArray, dt: float,
                           steer_angles: FloatArray | None
                           ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None:
    """The first step's feedforward: per wheel the drive force at the floor [N] (the
    effort along the wheel's rolling direction over its radius, wheel inertia
    excluded), each motor's torque at its shaft [N m] and current [A] (wheel inertia
    included), signed like the wheel speeds sent (steered wheels: along their commanded
    ``steer_angles``), and each wheel's whole contact force vector (n, 2) [N] in the body
    frame (a swerve module's drive and lateral force; :meth:`ForceMap.wheel_forces`).
    None without dynamics."""
    if robot.dynamics is None:
        return None
    forces = force_map(robot)
    change = (twist - last) / dt
    middle = 0.5 * (twist + last)
    turn = np.array([-middle[2] * middle[1], middle[2] * middle[0], 0.0])
    static = forces.flat_effort @ (change + turn)
    torque = forces.flat_drive @ change + forces.flat_effort @ turn
    if robot.wheel_dim == 2:
        angles = np.zeros(robot.n_wheels) if steer_angles is None else steer_angles
        cos, sin = np.cos(angles), np.sin(angles)
        static = static[0::2] * cos + static[1::2] * sin
        torque = torque[0::2] * cos + torque[1::2] * sin
    gearing = forces.dynamics.gearing
    return (static / forces.radii, torque / (gearing * forces.count),
            forces.motor_current(torque), forces.wheel_forces(change + turn))
