"""Motor-aware limits: battery voltage, motor current and traction as rows on the plan.

For a robot with :class:`~mpc.robots.dynamics.RobotDynamics`, every stage ``k`` of a plan
of twists (``u_{-1}``: the last command) gets, on top of the kinematic rows, per wheel::

    |V_end|, |V_start| <= (1 - headroom) V_bus      (battery voltage)
    |T| <= (1 - headroom) T_limit                   (current limit: T = kt I)

and per contact ``|F_c| <= (1 - headroom) mu N_c`` (traction), where over the change
from ``u_{k-1}`` to ``u_k`` (``change_times[k]`` seconds, a constant acceleration):

- the body acceleration is ``a_k = (u_k - u_{k-1}) / change_times[k] + coriolis(ubar_k)``
  (:mod:`mpc.robots.force_map`), the wheel torque ``T = D (u_k - u_{k-1}) / dt + E c``
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
components along ``e = v / |v|`` exactly. Traction: a disk, a polygon in the QP.

The NLP's exact versions are in :mod:`mpc.robots.motor_nlp`; the first command is kept
within the same limits by the clamp (:mod:`mpc.robots.motor_step`), the present wheel
speeds being the last command's.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from mpc.arrays import BoolArray, FloatArray
from mpc.robots.base import Robot
from mpc.robots.force_map import AT_REST, ForceMap, apothem, force_map
from mpc.robots.limits import StageLimits

#: Whether the QP's rows carry the Coriolis term linearised around the plan the solver starts
#: from (rows refilled every tick) rather than its value there (bounds only).
LINEARISE_CORIOLIS = True


#: Sides of the polygon standing in for a 2-D contact's traction disk in the QP, turned
#: each tick so that one edge faces the force the plan it starts from asks of the contact.
TRACTION_SIDES = 12

#: How a row's direction is chosen each tick (:attr:`MotorRows.direction`).
_FIXED, _DRIVE, _FORCE = 0, 1, 2


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
        return bool(np.any(self.direction != _FIXED))


def motor_rows(forces: ForceMap) -> MotorRows:
    """The motor rows of a robot (:class:`MotorRows`): per wheel the voltage at both ends
    and the torque at both ends of each change (along the drive direction for steered
    wheels), per contact its traction at both ends (a :data:`TRACTION_SIDES`-gon turned to
    the planned force for 2-D contacts)."""
    dyn = forces.dynamics
    robot = forces.robot
    blocks = robot.wheel_blocks  # (n, d, 3)
    n, d = blocks.shape[:2]
    keep = 1.0 - dyn.headroom
    volt = dyn.battery_voltage
    parts: dict[str, list[FloatArray]] = {key: [] for key in (
        "s_now", "s_before", "q", "g", "bound", "voltage", "kind", "index", "end",
        "direction", "angle")}

    def pad(matrices: FloatArray) -> FloatArray:
        """(r, d, 3) -> (r, 2, 3)."""
        out = np.zeros((matrices.shape[0], 2, 3))
        out[:, :matrices.shape[1]] = matrices
        return out

    def add(s_now: FloatArray, s_before: FloatArray, q: FloatArray, g: FloatArray,
            bound: float, voltage: bool, kind: int, index: npt.NDArray[np.intp],
            direction: int, angle: FloatArray, ends: tuple[bool, ...] = (True, False)
            ) -> None:
        rows = q.shape[0]
        for end in ends:
            for key, value in (("s_now", s_now), ("s_before", s_before), ("q", q),
                               ("g", g)):
                parts[key].append(pad(value))
            parts["bound"].append(np.full(rows, bound))
            parts["voltage"].append(np.full(rows, voltage))
            parts["kind"].append(np.full(rows, float(kind)))
            parts["index"].append(index.astype(float))
            parts["end"].append(np.full(rows, end))
            parts["direction"].append(np.full(rows, float(direction)))
            parts["angle"].append(angle)

    wheel = np.arange(n)
    steer = _DRIVE if d == 2 else _FIXED
    zero = np.zeros_like(blocks)
    r_over = forces.resistance / (forces.kt * volt)
    speed = blocks / (forces.kv * volt)
    for end in (True, False):
        add(speed if end else zero, zero if end else speed, r_over * forces.drive_map,
            r_over * forces.effort_map, keep, True, 0, wheel, steer, np.zeros(n), (end,))
    limit = forces.torque_limit
    add(zero, zero, forces.drive_map / limit, forces.effort_map / limit, keep, False, 1,
        wheel, steer, np.zeros(n))
    traction = forces.friction_limits
    if traction is not None:
        for c in range(forces.n_contacts):
            direction = forces.contact_directions[c]
            contact = forces.contact_maps[c] / traction[c]  # (2, 3)
            if np.any(direction):  # one direction: its row, exactly
                row = (direction @ contact)[None, None, :]
                add(np.zeros_like(row), np.zeros_like(row), row, row, keep, False, 2,
                    np.array([c]), _FIXED, np.zeros(1))
                continue
            sides = TRACTION_SIDES
            angles = 2.0 * math.pi * np.arange(sides // 2) / sides
            many = np.repeat(contact[None], sides // 2, axis=0)
            add(np.zeros_like(many), np.zeros_like(many), many, many, keep * apothem(sides),
                False, 2, np.full(sides // 2, c), _FORCE, angles)
    stacked = {key: np.concatenate(value) for key, value in parts.items()}
    order = np.argsort(stacked["direction"] != _FIXED, kind="stable")  # moving rows last
    stacked = {key: value[order] for key, value in stacked.items()}
    return MotorRows(s_now=stacked["s_now"], s_before=stacked["s_before"], q=stacked["q"],
                     g=stacked["g"], bound=stacked["bound"],
                     voltage=stacked["voltage"].astype(bool), kind=stacked["kind"],
                     index=stacked["index"].astype(np.intp), end=stacked["end"].astype(bool),
                     direction=stacked["direction"].astype(np.intp), angle=stacked["angle"])


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
    first_moving: int = 0  # the motor rows from this one on turn with the plan


def stage_limits(robot: Robot, change_times: FloatArray, polygon_sides: int) -> StageLimits:
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
        constant=False, change_times=np.array(change_times, dtype=float),
        kinematic=kinematic, motor=rows, forces=forces,
        previous=np.zeros((horizon, 3)), turn=np.zeros((horizon, 3)),
        turn_start=np.zeros((horizon, 3)), directions=directions,
        motor_bound=np.array(bound), base_now=empty.copy(), base_before=empty.copy(),
        g=empty.copy(), coef=empty.copy(),
        first_moving=int(np.sum(rows.direction == _FIXED)))
    _fill_rows(limits)
    return limits


def _fill_rows(limits: MotorStageLimits, first: int = 0) -> None:
    """The motor rows' base coefficients and Coriolis rows for the present directions (of
    the rows from ``first`` on: the moving ones are last)."""
    rows = limits.motor
    if rows is None:  # pragma: no cover - set by stage_limits
        return
    pick = slice(first, None)
    times = limits.change_times[:, None, None]
    d0 = limits.directions[:, pick, 0:1]
    d1 = limits.directions[:, pick, 1:2]

    def turned(matrix: FloatArray) -> FloatArray:  # d . matrix per stage and row
        return d0 * matrix[pick, 0, :] + d1 * matrix[pick, 1, :]

    q = turned(rows.q) / times
    limits.base_now[:, pick] = turned(rows.s_now) + q
    limits.base_before[:, pick] = turned(rows.s_before) - q
    limits.g[:, pick] = turned(rows.g)


def update_stage_limits(robot: Robot, limits: StageLimits, guess: FloatArray,
                        last: FloatArray, steer_angles: FloatArray | None) -> None:
    """Refill the rows that depend on the plan the solver starts from (``guess`` twists
    (N, 3), ``last`` command): the robot's own, then the motor rows (their directions, the
    Coriolis term linearised along ``guess``, the bus voltage under its power)."""
    if not isinstance(limits, MotorStageLimits) or limits.kinematic is None:
        robot.update_stage_limits(limits, guess, last, steer_angles)
        return
    kinematic, rows, forces = limits.kinematic, limits.motor, limits.forces
    if rows is None or forces is None:  # pragma: no cover - set by stage_limits
        raise RuntimeError("motor stage limits without motor rows")
    m = kinematic.rows
    limits.changed = False
    if not kinematic.constant:
        robot.update_stage_limits(kinematic, guess, last, steer_angles)
        if kinematic.changed:
            limits.now[:, :m] = kinematic.now
            limits.before[:, :m] = kinematic.before
            limits.changed = True
        limits.lower[:, :m] = kinematic.lower
        limits.upper[:, :m] = kinematic.upper
    previous = limits.previous
    previous[0] = last
    previous[1:] = guess[:-1]
    turn_end, turn_start = limits.turn, limits.turn_start  # third columns stay 0
    _coriolis(guess, turn_end)
    _coriolis(previous, turn_start)
    if rows.moving:
        _turn_rows(limits, forces, guess, previous, steer_angles)
        _fill_rows(limits, limits.first_moving)
    if rows.moving or limits.g_end.shape[0] == 0:
        limits.g_end = limits.g[:, :, :2] * rows.end[None, :, None]
        limits.g_start = limits.g[:, :, :2] * ~rows.end[None, :, None]
    g_end, g_start = limits.g_end, limits.g_start  # (N, m, 2): each row's end's own
    # g . coriolis at each row's end of the change (N, m_motor)
    offset = (g_end[:, :, 0] * turn_end[:, 0:1] + g_end[:, :, 1] * turn_end[:, 1:2]
              + g_start[:, :, 0] * turn_start[:, 0:1] + g_start[:, :, 1] * turn_start[:, 1:2])
    if LINEARISE_CORIOLIS:
        # coriolis(u) ~ J u - coriolis(ubar), J its Jacobian at ubar: g J on the end's
        # twist (u_k for the end's rows, u_{k-1} for the start's); the offset turns sign.
        for twists, out, base, side in ((guess, limits.now, limits.base_now, g_end),
                                        (previous, limits.before, limits.base_before,
                                         g_start)):
            omega, vx, vy = twists[:, 2:3], twists[:, 0:1], twists[:, 1:2]
            gx, gy = side[:, :, 0], side[:, :, 1]
            target = out[:, m:]
            np.add(base[:, :, 0], gy * omega, out=target[:, :, 0])
            np.subtract(base[:, :, 1], gx * omega, out=target[:, :, 1])
            np.add(base[:, :, 2], gy * vx - gx * vy, out=target[:, :, 2])
        np.negative(offset, out=offset)
        limits.changed = True
    elif rows.moving:
        limits.now[:, m:] = limits.base_now
        limits.before[:, m:] = limits.base_before
        limits.changed = True
    bound = limits.motor_bound
    if forces.dynamics.battery_resistance > 0.0:
        # the bus sags with the plan's power: the voltage rows' bound keep B(P) / E,
        # linearised around the guess (Newton: a bound read off the guess alone lags the
        # plan and swings between too loose and too tight). The voltage rows are the first
        # 2 n motor rows: each wheel's at the change's end, then at its start.
        sag = _sag(forces, guess, previous, limits.change_times, turn_end, turn_start,
                   limits.directions)
        volts = slice(0, 2 * robot.n_wheels)
        keep = rows.bound[volts]
        bound[:, volts] = sag.scale[:, None] * keep
        sign = np.sign(np.concatenate([sag.v_end, sag.v_start], axis=1))
        sign[sign == 0.0] = 1.0
        weight = -sign * keep * sag.slope[:, None]  # (N, 2 n)
        limits.now[:, m:m + 2 * robot.n_wheels] += weight[:, :, None] * sag.grad_now[:, None]
        limits.before[:, m:m + 2 * robot.n_wheels] += (weight[:, :, None]
                                                       * sag.grad_before[:, None])
        at_guess = (sag.grad_now * guess).sum(axis=1) + (sag.grad_before * previous).sum(axis=1)
        offset[:, volts] -= weight * at_guess[:, None]
        limits.changed = True
    np.subtract(bound, offset, out=limits.upper[:, m:])
    np.subtract(-bound, offset, out=limits.lower[:, m:])


def _turn_rows(limits: MotorStageLimits, forces: ForceMap, guess: FloatArray,
               previous: FloatArray, steer_angles: FloatArray | None) -> None:
    """Point the moving rows: a steered wheel's along its velocity at the stage's end in
    ``guess`` (where that is at rest: the stage before's, or the present steer angle), a
    2-D contact's polygon at the force ``guess`` asks of it at the row's end."""
    rows = limits.motor
    if rows is None:  # pragma: no cover
        return
    d = limits.directions
    drive = rows.direction == _DRIVE
    if np.any(drive):
        n = forces.robot.n_wheels
        velocity = (guess @ forces.flat_blocks.T).reshape(len(guess), n, 2)
        speed = np.hypot(velocity[:, :, 0], velocity[:, :, 1])
        angle = np.arctan2(velocity[:, :, 1], velocity[:, :, 0])
        rest = np.zeros(n) if steer_angles is None else np.asarray(steer_angles, float)
        stopped = speed <= AT_REST
        if np.any(stopped):  # at rest: keep the direction before
            for k in range(len(guess)):
                angle[k] = np.where(stopped[k], rest, angle[k])
                rest = angle[k]
        wheel = rows.index[drive]
        d[:, drive, 0] = np.cos(angle[:, wheel])
        d[:, drive, 1] = np.sin(angle[:, wheel])
    force_rows = rows.direction == _FORCE
    if np.any(force_rows):
        change = (guess - previous) / limits.change_times[:, None]
        contact = rows.index[force_rows]
        ends = rows.end[force_rows]
        angles = np.empty((len(guess), int(force_rows.sum())))
        for turn, mask in ((limits.turn, ends), (limits.turn_start, ~ends)):
            accel = change + turn  # (N, 3)
            force = np.einsum("cij,kj->kci", forces.contact_maps, accel)  # (N, c, 2)
            heading = np.arctan2(force[:, :, 1], force[:, :, 0])
            angles[:, mask] = heading[:, contact[mask]]
        angles += rows.angle[force_rows]
        d[:, force_rows, 0] = np.cos(angles)
        d[:, force_rows, 1] = np.sin(angles)


def _coriolis(twists: FloatArray, out: FloatArray) -> None:
    """``coriolis(twists)`` (N, 3) into ``out`` (its third column left as it is)."""
    np.multiply(twists[:, 2], twists[:, 1], out=out[:, 0])
    np.negative(out[:, 0], out=out[:, 0])
    np.multiply(twists[:, 2], twists[:, 0], out=out[:, 1])


@dataclass(frozen=True, eq=False)
class _Sag:
    """The bus along the guess: ``scale = B(P) / E`` (N,), its slope ``B'(P) / E`` [per W]
    (N,), the power's gradient on ``u_k`` and ``u_{k-1}`` (N, 3) [W per twist unit], and
    every wheel's voltage at the end and the start of each change (N, n) [V]."""

    scale: FloatArray
    slope: FloatArray
    grad_now: FloatArray
    grad_before: FloatArray
    v_end: FloatArray
    v_start: FloatArray


def _sag(forces: ForceMap, twists: FloatArray, previous: FloatArray, change_times: FloatArray,
         turn_end: FloatArray, turn_start: FloatArray, directions: FloatArray) -> _Sag:
    """:class:`_Sag` of the plan ``twists`` (power at each change's end: ``sum V T / kt``);
    steered wheels drive along the directions of their voltage rows (the first ``n`` motor
    rows of ``directions``)."""
    dyn = forces.dynamics
    robot = forces.robot
    n = robot.n_wheels
    times = change_times[:, None]
    change = (twists - previous) / times
    if robot.wheel_dim == 2:  # along each wheel's drive direction, as its rows have it
        e = directions[:, :n]  # (N, n, 2)
        speed_map = np.einsum("knd,ndj->knj", e, robot.wheel_blocks)
        drive_map = np.einsum("knd,ndj->knj", e, forces.drive_map)
        effort_map = np.einsum("knd,ndj->knj", e, forces.effort_map)

        def apply(maps: FloatArray, twist: FloatArray) -> FloatArray:
            return np.matmul(maps, twist[:, :, None])[:, :, 0]
    else:
        speed_map, drive_map = robot.wheel_blocks[:, 0], forces.drive_map[:, 0]
        effort_map = forces.effort_map[:, 0]

        def apply(maps: FloatArray, twist: FloatArray) -> FloatArray:
            return twist @ maps.T
    speed_end, speed_start = apply(speed_map, twists), apply(speed_map, previous)
    torque_base = apply(drive_map, change)
    torque_end = torque_base + apply(effort_map, turn_end)
    torque_start = torque_base + apply(effort_map, turn_start)
    v_end = forces.voltage(torque_end, speed_end)
    v_start = forces.voltage(torque_start, speed_start)
    power = (v_end * torque_end).sum(axis=1) / forces.kt
    volt, resistance = dyn.battery_voltage, dyn.battery_resistance
    disc = volt * volt - 4.0 * resistance * np.maximum(power, 0.0)
    scale = bus_voltages(volt, resistance, power) / volt
    slope = np.where((power > 0.0) & (disc > 1e-6 * volt * volt),
                     -resistance / np.sqrt(np.maximum(disc, 1e-12)), 0.0) / volt
    # dP = sum_j (T_j / kv ds_j + (V_j + R T_j / kt) dT_j) / kt, with ds = e W du_k and
    # dT = e D (du_k - du_{k-1}) / dt + e E J(ubar_k) du_k (J: the Coriolis Jacobian)
    through = (v_end + forces.resistance * torque_end / forces.kt) / forces.kt  # (N, n)
    by_speed = torque_end / (forces.kv * forces.kt)
    if robot.wheel_dim == 2:
        speed_grad = np.matmul(by_speed[:, None, :], speed_map)[:, 0]
        drive_grad = np.matmul(through[:, None, :], drive_map)[:, 0]
        effort_grad = np.matmul(through[:, None, :], effort_map)[:, 0]
    else:
        speed_grad, drive_grad = by_speed @ speed_map, through @ drive_map
        effort_grad = through @ effort_map
    omega, vx, vy = twists[:, 2], twists[:, 0], twists[:, 1]
    turned = np.stack([effort_grad[:, 1] * omega, -effort_grad[:, 0] * omega,
                       effort_grad[:, 1] * vx - effort_grad[:, 0] * vy], axis=1)
    grad_now = speed_grad + drive_grad / times + turned
    grad_before = -drive_grad / times
    return _Sag(scale=scale, slope=slope, grad_now=grad_now, grad_before=grad_before,
                v_end=v_end, v_start=v_start)


def bus_voltages(open_circuit: float, resistance: float, power: FloatArray) -> FloatArray:
    """:func:`~mpc.robots.dynamics.bus_voltage` for an array of powers [W]."""
    disc = np.maximum(open_circuit * open_circuit - 4.0 * resistance * np.maximum(power, 0.0),
                      0.0)
    return 0.5 * (open_circuit + np.sqrt(disc))
