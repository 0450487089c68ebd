"""Motor-aware limits: battery voltage, motor current and traction as rows on the plan.

For a robot with :class:`~mpc.robots.drive.dynamics.RobotDynamics`, every stage ``k`` of a plan
of twists (``u_{-1}``: the last command) gets, on top of the kinematic rows, per wheel::

    |V_end|, |V_start| <= (1 - voltage_headroom) V_bus   (battery voltage)
    |T| <= (1 - headroom) T_limit                          (current limit: T = kt I)

and per contact ``|F_c| <= (1 - headroom) mu N_c`` (traction), where over the change
from ``u_{k-1}`` to ``u_k`` (``change_times[k]`` seconds, a constant acceleration):

- the body acceleration is ``a_k = (u_k - u_{k-1}) / change_times[k] + coriolis(ubar_k)``
  (:mod:`mpc.robots.drive.force_map`), the wheel torque ``T = D (u_k - u_{k-1}) / dt + E c``
  (minimum-norm efforts plus wheel inertia) and the contact force ``F = C a_k``;
- the voltage a wheel's gearbox needs, ``V = w / kv + R T / kt``, is affine in time over
  the change, so it is bounded at both ends: at the speed the change ends with
  (``W u_k``, ``V_end``) and starts from (``W u_{k-1}``, ``V_start``). Braking needs less
  voltage than accelerating at the same speed (back-EMF helps): the rows see it.

Every row is linear in ``(u_k, u_{k-1})`` once the Coriolis term ``coriolis(ubar_k)``
(``ubar_k``: the middle of the change in the plan the solver starts from) and the bus
voltage are taken from that plan; both enter the bounds only, so the QP's rows never
change and the fast path stays one QP per tick. ``V_bus`` is the bus voltage under the
power that plan draws (``V_bus^2 - E V_bus + R_battery P = 0``); ``E`` without
``battery_resistance``. The NLP takes the Coriolis term and the sag of its own plan,
exactly.

Swerve modules. The drive motor gives the torque along the wheel, ``e . q`` with
``q = tau + J dv/dt`` the module's torque vector, at the speed ``e . v = |v|``; the QP
bounds the vectors ``p = v / kv + R q / kt`` (at both ends) and ``q`` by an inscribed
polygon (``|e . p| <= |p|``): exact when the module pushes along its wheel, and
conservative by the lateral force's resistive voltage otherwise (about 1 % of the battery
voltage at full cornering traction for the swerve preset), or, for the current, by the
lateral force when the current limit is below the traction limit. The NLP uses the drive
components along ``e = v / |v|`` exactly. Traction: a disk, a polygon in the QP
(turned to the planned force, the edge facing it tangent to the disk).

The rows themselves are built once in :mod:`mpc.robots.drive.motor_rows`, the bus's sag in
:mod:`mpc.robots.drive.bus_sag`; this module lays them on the stages and refills them each tick.
The NLP's exact versions are in :mod:`mpc.robots.drive.motor_nlp`; the first command is kept
within the same limits by the clamp (:mod:`mpc.robots.drive.motor_step`), the present wheel
speeds being the last command's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from mpc.arrays import FloatArray
from mpc.robots.base import Robot
from mpc.robots.drive.bus_sag import bus_voltages, sag
from mpc.robots.drive.force_map import AT_REST, ForceMap, force_map
from mpc.robots.drive.motor_rows import DRIVE, FIXED, FORCE, TRACTION_SIDES, MotorRows, motor_rows
from mpc.robots.limits import StageLimits

__all__ = ["LINEARISE_CORIOLIS", "TRACTION_SIDES", "MotorRows", "MotorStageLimits",
           "bus_voltages", "motor_rows", "stage_limits", "update_stage_limits"]

#: Whether the QP's rows carry the Coriolis term linearised around the plan the solver starts
#: from (rows refilled every tick) rather than its value there (bounds only).
LINEARISE_CORIOLIS = True


@dataclass(eq=False)
class MotorStageLimits(StageLimits):
    """:class:`StageLimits` whose first ``kinematic.rows`` rows are the robot's own and the
    rest its motor rows (:class:`MotorRows`), refilled each tick."""

    kinematic: StageLimits | None = None
    motor: MotorRows | None = None
    forces: ForceMap | None = None
    # work arrays of the refill
    previous: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    turn: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    turn_start: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    directions: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 2)))
    motor_bound: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    base_now: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    base_before: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    g: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    g_end: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 2)))
    g_start: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 2)))
    coef: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    basis: FloatArray = field(default_factory=lambda: np.zeros((0, 2, _BASIS)))
    turning: _Turning | None = None
    first_moving: int = 0  # the motor rows from this one on turn with the plan


def stage_limits(robot: Robot, change_times: FloatArray,
                 polygon_sides: int | None) -> StageLimits:
    """The QP's stage rows: the robot's own (:meth:`Robot.stage_limits`), plus the motor
    rows for a robot with dynamics (module docstring). ``polygon_sides`` goes to the
    robot's own rows; a 2-D traction disk is a :data:`TRACTION_SIDES`-gon."""
    kinematic = robot.stage_limits(change_times, polygon_sides)
    if robot.dynamics is None:
        return kinematic
    forces = force_map(robot)
    rows = motor_rows(forces)
    horizon = len(change_times)
    directions = np.zeros((horizon, rows.rows, 2))
    directions[:, :, 0] = np.cos(rows.angle)
    directions[:, :, 1] = np.sin(rows.angle)
    bound = np.broadcast_to(rows.bound, (horizon, rows.rows))
    empty = np.zeros((horizon, rows.rows, 3))
    limits = MotorStageLimits(
        now=np.concatenate([kinematic.now, empty], axis=1),
        before=np.concatenate([kinematic.before, empty], axis=1),
        lower=np.concatenate([kinematic.lower, -bound], axis=1),
        upper=np.concatenate([kinematic.upper, bound], axis=1),
        constant=False, change_times=np.array(change_times, dtype=float), screened=True,
        kinematic=kinematic, motor=rows, forces=forces,
        previous=np.zeros((horizon, 3)), turn=np.zeros((horizon, 3)),
        turn_start=np.zeros((horizon, 3)), directions=directions,
        motor_bound=np.array(bound), base_now=empty.copy(), base_before=empty.copy(),
        g=empty.copy(), g_end=np.zeros((horizon, rows.rows, 2)),
        g_start=np.zeros((horizon, rows.rows, 2)), coef=empty.copy(), basis=_basis(rows),
        turning=_turning(rows),
        first_moving=int(np.sum(rows.direction == FIXED)))
    _fill_rows(limits)
    return limits


#: Columns of :func:`_basis`: ``q``, ``s_now``, ``s_before``, ``g`` (three each), then
#: ``g``'s first two at the row's end of the change and at its start (two each).
_BASIS = 16


def _basis(rows: MotorRows) -> FloatArray:
    """(m, 2, 16): each motor row's matrices side by side, so that one product with its unit
    direction ``d`` gives all of ``d . q``, ``d . s_now``, ... (see :func:`_fill_rows`)."""
    end = rows.end[:, None, None]
    return np.concatenate([rows.q, rows.s_now, rows.s_before, rows.g,
                           rows.g[:, :, :2] * end, rows.g[:, :, :2] * ~end], axis=2)


def _fill_rows(limits: MotorStageLimits, first: int = 0) -> None:
    """The motor rows' base coefficients and Coriolis rows for the present directions (of
    the rows from ``first`` on: the moving ones are last): one batch of (N, 2) x (2, 16)
    products, a row at a time (quicker than element-wise products broadcast over
    (N, m, 3): docs/design/tick-costs.md)."""
    pick = slice(first, None)
    turned = np.matmul(limits.directions[:, pick].transpose(1, 0, 2),
                       limits.basis[pick]).transpose(1, 0, 2)  # (N, rows, 16)
    q = turned[:, :, 0:3] / limits.change_times[:, None, None]
    np.add(turned[:, :, 3:6], q, out=limits.base_now[:, pick])
    np.subtract(turned[:, :, 6:9], q, out=limits.base_before[:, pick])
    limits.g[:, pick] = turned[:, :, 9:12]
    limits.g_end[:, pick] = turned[:, :, 12:14]
    limits.g_start[:, pick] = turned[:, :, 14:16]


def update_stage_limits(robot: Robot, limits: StageLimits, guess: FloatArray,
                        last: FloatArray, steer_angles: FloatArray | None) -> None:
    """Refill the rows that depend on the plan the solver starts from (``guess`` twists
    (N, 3), ``last`` command): the robot's own, then the motor rows (their directions, the
    Coriolis term linearised along ``guess``, the bus voltage under its power)."""
    if not isinstance(limits, MotorStageLimits) or limits.kinematic is None:
        robot.update_stage_limits(limits, guess, last, steer_angles)
        return
    rows, forces = limits.motor, limits.forces
    if rows is None or forces is None:  # pragma: no cover - set by stage_limits
        raise RuntimeError("motor stage limits without motor rows")
    _update_kinematic_rows(robot, limits, limits.kinematic, guess, last, steer_angles)
    m = limits.kinematic.rows
    previous = limits.previous
    previous[0] = last
    previous[1:] = guess[:-1]
    turn_end, turn_start = limits.turn, limits.turn_start  # third columns stay 0
    _coriolis(guess, turn_end)
    _coriolis(previous, turn_start)
    if rows.moving:
        _turn_rows(limits, forces, guess, previous, steer_angles)
        _fill_rows(limits, limits.first_moving)
    g_end, g_start = limits.g_end, limits.g_start  # (N, m, 2): each row's end's own
    # g . coriolis at each row's end of the change (N, m_motor)
    offset = (g_end[:, :, 0] * turn_end[:, 0:1] + g_end[:, :, 1] * turn_end[:, 1:2]
              + g_start[:, :, 0] * turn_start[:, 0:1] + g_start[:, :, 1] * turn_start[:, 1:2])
    if LINEARISE_CORIOLIS:
        _linearise_coriolis(limits, guess, previous, m)
        np.negative(offset, out=offset)
        limits.changed = True
    elif rows.moving:
        limits.now[:, m:] = limits.base_now
        limits.before[:, m:] = limits.base_before
        limits.changed = True
    bound = limits.motor_bound
    if forces.dynamics.battery_resistance > 0.0:
        _sag_voltage_rows(robot, limits, forces, guess, previous, offset, m)
    np.subtract(bound, offset, out=limits.upper[:, m:])
    np.subtract(-bound, offset, out=limits.lower[:, m:])
    _reach_last(limits, last, m)


def _reach_last(limits: MotorStageLimits, last: FloatArray, m: int) -> None:
    """Widen the first stage's motor rows to hold its start (``u_0 = u_{-1}``, the last
    command: always within reach). Their bus sag, Coriolis term and directions are
    linearised around the plan the solver starts from; where that plan is out of reach
    of the last command (the clamp cut the step it asked for), the rows could exclude
    every first command and the QP was infeasible (a voltage row under the sag of the
    plan's power against the current and traction rows). The clamp still keeps the
    command sent within the limits."""
    held = limits.now[0, m:] @ last + limits.before[0, m:] @ last
    np.minimum(limits.lower[0, m:], held, out=limits.lower[0, m:])
    np.maximum(limits.upper[0, m:], held, out=limits.upper[0, m:])


def _update_kinematic_rows(robot: Robot, limits: MotorStageLimits, kinematic: StageLimits,
                           guess: FloatArray, last: FloatArray,
                           steer_angles: FloatArray | None) -> None:
    """Refill the robot's own rows (the first ``kinematic.rows``) and copy them in;
    ``limits.changed`` says whether the matrices changed."""
    m = kinematic.rows
    limits.changed = False
    if kinematic.constant:
        return
    robot.update_stage_limits(kinematic, guess, last, steer_angles)
    if kinematic.changed:
        limits.now[:, :m] = kinematic.now
        limits.before[:, :m] = kinematic.before
        limits.changed = True
    limits.lower[:, :m] = kinematic.lower
    limits.upper[:, :m] = kinematic.upper


def _linearise_coriolis(limits: MotorStageLimits, guess: FloatArray, previous: FloatArray,
                        m: int) -> None:
    """The motor rows' matrices with the Coriolis term linearised along the guess.

    ``coriolis(u) ~ J u - coriolis(ubar)``, ``J`` its Jacobian at ``ubar``: ``g J`` on the
    end's twist (``u_k`` for the end's rows, ``u_{k-1}`` for the start's); the caller turns
    the offset's sign."""
    for twists, out, base, side in ((guess, limits.now, limits.base_now, limits.g_end),
                                    (previous, limits.before, limits.base_before,
                                     limits.g_start)):
        omega, vx, vy = twists[:, 2:3], twists[:, 0:1], twists[:, 1:2]
        gx, gy = side[:, :, 0], side[:, :, 1]
        target = out[:, m:]
        np.add(base[:, :, 0], gy * omega, out=target[:, :, 0])
        np.subtract(base[:, :, 1], gx * omega, out=target[:, :, 1])
        np.add(base[:, :, 2], gy * vx - gx * vy, out=target[:, :, 2])


def _sag_voltage_rows(robot: Robot, limits: MotorStageLimits, forces: ForceMap,
                      guess: FloatArray, previous: FloatArray, offset: FloatArray,
                      m: int) -> None:
    """The voltage rows under the bus's sag with the plan's power.

    Their bound keeps ``B(P) / E``, linearised around the guess (Newton: a bound read off
    the guess alone lags the plan and swings between too loose and too tight). The voltage
    rows are the first ``2 n`` motor rows: each wheel's at the change's end, then at its
    start. Writes ``limits.motor_bound``, the rows' matrices and ``offset``."""
    rows = limits.motor
    if rows is None:  # pragma: no cover - set by stage_limits
        return
    bus = sag(forces, guess, previous, limits.change_times, limits.turn, limits.turn_start,
              limits.directions)
    n = robot.n_wheels
    volts = slice(0, 2 * n)
    keep = rows.bound[volts]
    limits.motor_bound[:, volts] = bus.scale[:, None] * keep
    sign = np.sign(np.concatenate([bus.v_end, bus.v_start], axis=1))
    sign[sign == 0.0] = 1.0
    weight = -sign * keep * bus.slope[:, None]  # (N, 2 n)
    limits.now[:, m:m + 2 * n] += weight[:, :, None] * bus.grad_now[:, None]
    limits.before[:, m:m + 2 * n] += weight[:, :, None] * bus.grad_before[:, None]
    at_guess = (bus.grad_now * guess).sum(axis=1) + (bus.grad_before * previous).sum(axis=1)
    offset[:, volts] -= weight * at_guess[:, None]
    limits.changed = True


@dataclass(frozen=True, eq=False)
class _Turning:
    """Which motor rows turn with the plan, and how (built once: :func:`_turning`):
    steered wheels' rows (``drive``) along their wheel's velocity (``drive_wheels``); 2-D
    contacts' traction rows, at the change's end and at its start (``sides``: the rows,
    their contacts, and the cosine and sine of their edge's angle from the force)."""

    drive: npt.NDArray[np.intp]
    drive_wheels: npt.NDArray[np.intp]
    sides: tuple[tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], FloatArray, FloatArray],
                 ...]


def _turning(rows: MotorRows) -> _Turning:
    drive = np.flatnonzero(rows.direction == DRIVE)
    sides = []
    for end in (True, False):
        side = np.flatnonzero((rows.direction == FORCE) & (rows.end == end))
        sides.append((side, rows.index[side], np.cos(rows.angle[side]),
                      np.sin(rows.angle[side])))
    return _Turning(drive, rows.index[drive], tuple(sides))


def _turn_rows(limits: MotorStageLimits, forces: ForceMap, guess: FloatArray,
               previous: FloatArray, steer_angles: FloatArray | None) -> None:
    """Point the moving rows: a steered wheel's along its velocity at the stage's end in
    ``guess`` (where that is at rest: the stage before's, or the present steer angle), a
    2-D contact's polygon at the force ``guess`` asks of it at the row's end (no force:
    along the body x axis). Unit vectors throughout, no angles."""
    turning, d = limits.turning, limits.directions
    if turning is None:  # pragma: no cover - set by stage_limits
        return
    horizon = len(guess)
    if turning.drive.size:
        n = forces.robot.n_wheels
        velocity = (guess @ forces.flat_blocks.T).reshape(horizon, n, 2)
        speed = np.hypot(velocity[:, :, 0], velocity[:, :, 1])
        stopped = speed <= AT_REST
        unit = velocity / np.where(stopped, 1.0, speed)[:, :, None]
        if stopped.any():  # at rest: keep the direction before
            rest = np.zeros(n) if steer_angles is None else np.asarray(steer_angles, float)
            before = np.stack([np.cos(rest), np.sin(rest)], axis=1)
            for k in range(horizon):
                unit[k] = np.where(stopped[k, :, None], before, unit[k])
                before = unit[k]
        d[:, turning.drive] = unit[:, turning.drive_wheels]
    if turning.sides[0][0].size or turning.sides[1][0].size:
        change = (guess - previous) / limits.change_times[:, None]
        contacts = forces.contact_maps.shape[0]
        for (rows, contact, cos, sin), turn in zip(turning.sides,
                                                    (limits.turn, limits.turn_start),
                                                    strict=True):
            force = ((change + turn) @ forces.flat_contacts.T).reshape(horizon, contacts, 2)
            size = np.hypot(force[:, :, 0], force[:, :, 1])
            unit = force / np.where(size > 0.0, size, 1.0)[:, :, None]
            unit[size == 0.0] = (1.0, 0.0)
            along = unit[:, contact]  # (N, rows, 2): each row's contact's force direction
            d[:, rows, 0] = along[:, :, 0] * cos - along[:, :, 1] * sin
            d[:, rows, 1] = along[:, :, 1] * cos + along[:, :, 0] * sin


def _coriolis(twists: FloatArray, out: FloatArray) -> None:
    """``coriolis(twists)`` (N, 3) into ``out`` (its third column left as it is)."""
    np.multiply(twists[:, 2], twists[:, 1], out=out[:, 0])
    np.negative(out[:, 0], out=out[:, 0])
    np.multiply(twists[:, 2], twists[:, 0], out=out[:, 1])
