"""The motor-aware part of the compiled tick: a constant-Jacobian robot's voltage, current
and traction rows refilled along the plan inside ``prepare``, the motor clamp and the
feedforward a :class:`~mpc.control.command.Command` carries inside ``finish``.

The rows are :mod:`mpc.robots.drive.motor_limits`'s: its tables (:class:`MotorRows`, the
16-column basis, the force map, the turning rows) built by the same functions the Python
tick uses, and its refill (:func:`~mpc.robots.drive.motor_limits.update_stage_limits`: the
traction polygons turned to the planned force, the Coriolis term linearised along the
guess, the bus sag's Newton step, stage 0 widened to hold the last command) written as
one SX function of a stage, ``(u_k, u_{k-1}, change time, ...) -> (rows, their bounds on
the step)``, mapped over the stages by an MX ``prepare`` around the kinematic one (a loop
in the generated C: written out in one function, the rows of every stage made gcc take
minutes). They depend on the plan, so they change every tick: ``prepare`` gives them as
the nonzeros of their sparse matrix (``rows``), as swerve's moving rows are given, and
``tick.c`` whitens them every tick with the kept ``L^{-1}`` (``mpc_tick_whiten_moving``);
the kept Hessian stays the Hessian alone (:mod:`mpc.tick.reuse`).

The clamp is :func:`~mpc.control.clamp.clamp_command`'s array path for these robots: the
speed scaling and acceleration step (:func:`mpc.tick.graphs._clamped`), then up to four
passes of :func:`~mpc.robots.drive.motor_step.motor_step_fraction` (its bus-sag bisection
and traction disks as expressions). The feedforward is
:func:`~mpc.robots.drive.motor_step.first_step_feedforward`'s.

Rows no plan needs for a while leave daqp's problem in ``tick.c`` as they do in the Python
tick (:mod:`mpc.tick.screen`, where a stage has enough of them: the same optimum, each plan
checked against the rows left out); the virtual machine hands daqp every row. Swerve's
motor rows (drive directions along the plan) are not covered (:mod:`mpc.tick.support`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import Robot, ScalarWheels
from mpc.robots.drive.force_map import ForceMap, force_map
from mpc.robots.drive.motor_limits import LINEARISE_CORIOLIS, MotorStageLimits
from mpc.robots.drive.motor_rows import FIXED, FORCE
from mpc.robots.drive.motor_step import CLAMP_HEADROOM, STILL_SLOPE, _step_rows

#: Passes of the motor step in the clamp (:data:`mpc.control.clamp._MOTOR_PASSES`).
MOTOR_PASSES = 4

#: Bisection steps of the clamp's bus-sag search (``motor_step._sag_fraction``'s loop).
SAG_BISECTIONS = 12


def motor_wheels(robot: Robot) -> ScalarWheels:
    """A constant-Jacobian robot's wheels as the clamp graphs take them (a robot with
    dynamics has no :attr:`~mpc.robots.Robot.scalar_wheels`: its clamp runs on arrays, the
    same arithmetic)."""
    flat = robot.wheel_blocks.reshape(-1, 3)
    accel = robot.max_wheel_accel
    return ScalarWheels(tuple((a, b, c) for a, b, c in flat.tolist()),
                        tuple(robot.max_wheel_speed.tolist()), tuple(robot.speed_slack.tolist()),
                        None if accel is None else tuple(np.asarray(accel, float).tolist()))


def feedforward_size(robot: Robot) -> int:
    """Numbers of the feedforward ``finish`` gives: per wheel its drive force [N], motor
    torque [N m], motor current [A], then its contact force vector (2) [N]: 5 n."""
    return 5 * robot.n_wheels


@dataclass(frozen=True, eq=False)
class MotorGraphs:
    """The motor rows' graph pieces of one model (built by :func:`motor_graphs`).

    Attributes:
        limits: the stage rows (:class:`MotorStageLimits`, the Python tick's tables).
        stage: one stage's rows and their bounds on the step (:func:`_stage_function`).
        forces: the robot's force map.
    """

    limits: MotorStageLimits
    stage: ca.Function
    forces: ForceMap

    @property
    def rows(self) -> int:
        """Rows a stage (the robot's own, then the motor rows)."""
        return int(self.limits.rows)

    def stage_rows(self, guess: ca.MX, last: ca.MX) -> tuple[ca.MX, ca.MX, ca.MX]:
        """``(stage_rows 3 x 2 N m, lower N m, upper N m)`` at the guess twists (3 x N)
        after the command ``last``: each stage's rows on ``u_k`` (a row a column, stages
        in order), then on ``u_{k-1}``, as the Python tick's ``limits.now`` and ``before``
        after ``update_stage_limits``; and the bounds on the step from the guess (stage 0's
        part on ``last`` moved into its bounds). The stage function mapped over the stages
        (a loop in the generated C)."""
        limits, kinematic = self.limits, self.limits.kinematic
        assert kinematic is not None  # set by stage_limits
        n = limits.horizon
        previous = ca.horzcat(last, guess[:, :n - 1])
        first = ca.DM([[1.0] + [0.0] * (n - 1)])
        constants = [ca.DM(np.hstack([block.T for block in kinematic.now])),
                     ca.DM(np.hstack([block.T for block in kinematic.before])),
                     ca.DM(kinematic.lower.T), ca.DM(kinematic.upper.T)]
        now, before, lower, upper = self.stage.map(n)(
            guess, previous, ca.DM(limits.change_times).T, first, *constants)
        return ca.horzcat(now, before), ca.vec(lower), ca.vec(upper)

    def prepare(self, terms: ca.Function, guess_at: int) -> ca.Function:
        """``prepare`` for a robot whose rows move with the plan: ``terms`` (the graph of
        :func:`mpc.tick.graphs.build_graphs`, its bounds left out) called, then the rows
        and bounds of the guess it chose (in its ``carry`` from ``guess_at``); the rows as
        two more outputs, as swerve's moving rows are given (:class:`~mpc.tick.graphs.
        TickGraphs`): ``rows`` (m x 3 N, :meth:`pattern`) and an empty ``next_state``."""
        inputs = [ca.MX.sym(terms.name_in(i), terms.sparsity_in(i))
                  for i in range(terms.n_in())]
        outputs = list(terms(*inputs))
        n = self.limits.horizon
        guess = ca.reshape(outputs[3][guess_at:guess_at + 3 * n], 3, n)
        stage_rows, lower, upper = self.stage_rows(guess, inputs[terms.index_in("last")])
        outputs[1], outputs[2] = lower, upper
        names = [terms.name_out(i) for i in range(terms.n_out())]
        return ca.Function("mpc_tick_prepare", inputs,
                           [*outputs, self.rows_matrix(stage_rows), ca.MX(0, 1)],
                           [terms.name_in(i) for i in range(terms.n_in())],
                           [*names, "rows", "next_state"])

    def pattern(self) -> tuple[ca.Sparsity, list[int]]:
        """The rows' sparsity ``A`` (N m x 3 N: stage ``k``'s rows touch ``u_k`` and
        ``u_{k-1}`` only, six entries a row, three in stage 0) and, for each of its
        nonzeros in order, its entry of ``vec(stage_rows)`` (:meth:`stage_rows`' layout:
        each stage's rows on ``u_k``, then on ``u_{k-1}``)."""
        n, m = self.limits.horizon, self.rows
        rows, columns, picks = [], [], []
        for k in range(n):
            for i in range(m):
                row = k * m + i
                if k > 0:  # the row's part on u_{k-1}: stage_rows' column N m + k m + i
                    columns += [3 * k - 3, 3 * k - 2, 3 * k - 1]
                    picks += [3 * (n * m + row) + axis for axis in range(3)]
                    rows += [row] * 3
                columns += [3 * k, 3 * k + 1, 3 * k + 2]
                picks += [3 * row + axis for axis in range(3)]
                rows += [row] * 3
        pattern, mapping = ca.Sparsity.triplet(n * m, 3 * n, rows, columns, True)
        return pattern, [picks[index] for index in np.argsort(mapping)]

    def rows_matrix(self, stage_rows: ca.MX) -> ca.MX:
        """The rows ``A`` (:meth:`pattern`) of the rows ``stage_rows`` (as
        :meth:`stage_rows` lays them out)."""
        pattern, picks = self.pattern()
        return ca.MX(pattern, ca.vec(stage_rows)[picks])


def motor_graphs(robot: Robot, limits: MotorStageLimits) -> MotorGraphs:
    """The motor rows' graph pieces of ``robot`` (a constant-Jacobian robot with dynamics)
    on ``limits`` (:func:`~mpc.robots.drive.motor_limits.stage_limits`'s)."""
    rows, forces = limits.motor, limits.forces
    if rows is None or forces is None or limits.kinematic is None:
        raise RuntimeError("motor stage limits without motor rows")
    if robot.wheel_dim != 1 or np.any((rows.direction != FIXED) & (rows.direction != FORCE)):
        raise RuntimeError("the compiled tick's motor rows cover wheels that do not steer")
    return MotorGraphs(limits, _stage_function(robot, limits, forces), forces)


def _turn(twist: ca.SX) -> ca.SX:
    """``coriolis(twist)``: ``(-omega vy, omega vx, 0)``."""
    return ca.vertcat(-twist[2] * twist[1], twist[2] * twist[0], 0)


def _stage_function(robot: Robot, limits: MotorStageLimits, forces: ForceMap) -> ca.Function:
    """One stage's motor rows (:meth:`MotorGraphs.stage`), as
    :func:`~mpc.robots.drive.motor_limits.update_stage_limits` refills them."""
    rows = limits.motor
    assert rows is not None
    u, p, dt = ca.SX.sym("u", 3), ca.SX.sym("previous", 3), ca.SX.sym("change_time")
    kinematic = limits.kinematic
    assert kinematic is not None
    own = kinematic.rows
    first = ca.SX.sym("first")  # 1 at stage 0 (its rows hold the last command), else 0
    own_now, own_before = ca.SX.sym("own_now", 3, own), ca.SX.sym("own_before", 3, own)
    own_lower, own_upper = ca.SX.sym("own_lower", own), ca.SX.sym("own_upper", own)
    turn_end, turn_start = _turn(u), _turn(p)
    change = (u - p) / dt
    # _turn_rows: a 2-D contact's polygon turned to the force the guess asks of it at the
    # row's end of the change (no force: along the body x axis)
    unit: dict[tuple[int, bool], tuple[ca.SX, ca.SX]] = {}
    for end, turn in ((True, turn_end), (False, turn_start)):
        acceleration = change + turn
        for c in range(forces.contact_maps.shape[0]):
            force = ca.DM(forces.contact_maps[c]) @ acceleration
            size = ca.hypot(force[0], force[1])
            safe = ca.if_else(size > 0.0, size, 1.0)
            unit[c, end] = (ca.if_else(size == 0.0, 1.0, force[0] / safe),
                            ca.if_else(size == 0.0, 0.0, force[1] / safe))
    basis = limits.basis
    now, before, offset = [], [], []
    for i in range(rows.rows):
        if rows.direction[i] == FORCE:
            ux, uy = unit[int(rows.index[i]), bool(rows.end[i])]
            cos, sin = math.cos(rows.angle[i]), math.sin(rows.angle[i])
            d = ca.horzcat(ux * cos - uy * sin, uy * cos + ux * sin)
        else:
            d = ca.SX(ca.DM(limits.directions[0, i]).T)
        turned = d @ ca.DM(basis[i])  # (1, 16): _fill_rows
        q = turned[0:3] / dt
        base_now, base_before = turned[3:6] + q, turned[6:9] - q
        g_end, g_start = turned[12:14], turned[14:16]
        offset.append(g_end[0] * turn_end[0] + g_end[1] * turn_end[1]
                      + g_start[0] * turn_start[0] + g_start[1] * turn_start[1])
        if LINEARISE_CORIOLIS:  # _linearise_coriolis
            base_now = base_now + ca.horzcat(g_end[1] * u[2], -g_end[0] * u[2],
                                             g_end[1] * u[0] - g_end[0] * u[1])
            base_before = base_before + ca.horzcat(g_start[1] * p[2], -g_start[0] * p[2],
                                                   g_start[1] * p[0] - g_start[0] * p[1])
        now.append(base_now)
        before.append(base_before)
    now_rows, before_rows = ca.vertcat(*now), ca.vertcat(*before)
    shift = ca.vertcat(*offset)
    if LINEARISE_CORIOLIS:
        shift = -shift
    bound = ca.SX(ca.DM(rows.bound))
    if forces.dynamics.battery_resistance > 0.0:
        bound, now_rows, before_rows, shift = _sagged(robot, forces, rows.bound, u, p, dt,
                                                      turn_end, turn_start, bound, now_rows,
                                                      before_rows, shift)
    lower, upper = -bound - shift, bound - shift
    # _reach_last: stage 0's rows widened to hold its start, the last command (previous)
    held = now_rows @ p + before_rows @ p
    lower = ca.if_else(first > 0, ca.fmin(lower, held), lower)
    upper = ca.if_else(first > 0, ca.fmax(upper, held), upper)
    now_rows = ca.vertcat(own_now.T, now_rows)
    before_rows = ca.vertcat(own_before.T, before_rows)
    lower, upper = ca.vertcat(own_lower, lower), ca.vertcat(own_upper, upper)
    at_guess = now_rows @ u + before_rows @ p  # the bounds on the step from the guess
    return ca.Function("mpc_tick_motor_stage",
                       [u, p, dt, first, own_now, own_before, own_lower, own_upper],
                       [now_rows.T, before_rows.T, lower - at_guess, upper - at_guess],
                       ["u", "previous", "change_time", "first", "own_now", "own_before",
                        "own_lower", "own_upper"], ["now", "before", "lower", "upper"],
                       {"cse": True})


def _sagged(robot: Robot, forces: ForceMap, keep_bound: FloatArray, u: ca.SX, p: ca.SX,
            dt: ca.SX, turn_end: ca.SX, turn_start: ca.SX, bound: ca.SX, now: ca.SX,
            before: ca.SX, offset: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    """The voltage rows (the first 2 n) under the bus's sag with the guess's power
    (:func:`mpc.robots.drive.bus_sag.sag` and ``motor_limits._sag_voltage_rows``)."""
    dyn = forces.dynamics
    n = robot.n_wheels
    speed_map = ca.DM(robot.wheel_blocks[:, 0])
    drive_map, effort_map = ca.DM(forces.drive_map[:, 0]), ca.DM(forces.effort_map[:, 0])
    change = (u - p) / dt
    speed_end, speed_start = speed_map @ u, speed_map @ p
    torque_base = drive_map @ change
    torque_end = torque_base + effort_map @ turn_end
    torque_start = torque_base + effort_map @ turn_start
    v_end = speed_end / forces.kv + forces.resistance * torque_end / forces.kt
    v_start = speed_start / forces.kv + forces.resistance * torque_start / forces.kt
    power = ca.sum1(v_end * torque_end) / forces.kt
    volt, resistance = dyn.battery_voltage, dyn.battery_resistance
    disc = volt * volt - 4.0 * resistance * ca.fmax(power, 0.0)
    scale = 0.5 * (volt + ca.sqrt(ca.fmax(disc, 0.0))) / volt  # bus_voltages / E
    slope = ca.if_else(ca.logic_and(power > 0.0, disc > 1e-6 * volt * volt),
                       -resistance / ca.sqrt(ca.fmax(disc, 1e-12)), 0.0) / volt
    through = (v_end + forces.resistance * torque_end / forces.kt) / forces.kt
    by_speed = torque_end / (forces.kv * forces.kt)
    speed_grad, drive_grad = (by_speed.T @ speed_map).T, (through.T @ drive_map).T
    effort_grad = (through.T @ effort_map).T
    turned = ca.vertcat(effort_grad[1] * u[2], -effort_grad[0] * u[2],
                        effort_grad[1] * u[0] - effort_grad[0] * u[1])
    grad_now = speed_grad + drive_grad / dt + turned
    grad_before = -drive_grad / dt
    keep = ca.DM(keep_bound[:2 * n])
    volts = ca.vertcat(v_end, v_start)
    sign = ca.if_else(volts < 0.0, -1.0, 1.0)  # np.sign, 0 counted as +1
    weight = -sign * keep * slope
    at_guess = ca.dot(grad_now, u) + ca.dot(grad_before, p)
    rest = bound.shape[0] - 2 * n
    bound = ca.vertcat(scale * keep, bound[2 * n:])
    now = ca.vertcat(now[:2 * n, :] + weight @ grad_now.T, now[2 * n:, :])
    before = ca.vertcat(before[:2 * n, :] + weight @ grad_before.T, before[2 * n:, :])
    offset = ca.vertcat(offset[:2 * n] - weight * at_guess, offset[2 * n:2 * n + rest])
    return bound, now, before, offset


# ---------------------------------------------------------------- finish: clamp, feedforward
def motor_clamp(robot: Robot, wheels: ScalarWheels, twist: ca.SX, last: ca.SX,
                dt: float) -> ca.SX:
    """The clamp's motor passes (``clamp._limit_step``) on ``twist`` (within the speed and
    acceleration limits already): up to :data:`MOTOR_PASSES` steps from ``last`` each as
    far as :func:`~mpc.robots.drive.motor_step.motor_step_fraction` allows; none when
    ``last`` itself is beyond a speed limit (the speed limits win)."""
    forces = force_map(robot)
    last_over = ca.SX(0)
    for (a, b, c), limit, extra in zip(wheels.rows, wheels.limits, wheels.slack, strict=True):
        last_over = ca.logic_or(
            last_over, ca.fabs(a * last[0] + b * last[1] + c * last[2]) - limit * (1 + 1e-9)
            > extra)
    start, target = ca.SX.sym("last", 3), ca.SX.sym("target", 3)
    step_fraction = ca.Function("mpc_tick_motor_fraction", [start, target],
                                [_step_fraction(forces, start, target, dt)],
                                {"cse": True, "never_inline": True})
    safe, stopped = twist, ca.SX(0)
    for _ in range(MOTOR_PASSES):
        fraction = step_fraction(last, safe)
        stopped = ca.logic_or(stopped, fraction >= 1.0 - 1e-9)
        safe = ca.if_else(stopped, safe, last + fraction * (safe - last))
    return ca.if_else(last_over, twist, safe)


def _step_fraction(forces: ForceMap, last: ca.SX, target: ca.SX, dt: float) -> ca.SX:
    """:func:`~mpc.robots.drive.motor_step.motor_step_fraction` for wheels that do not
    steer, as an expression."""
    dyn = forces.dynamics
    rows = _step_rows(forces)
    step = target - last
    turn_end, turn_start = _turn(target), _turn(last)
    start = ca.DM(rows.a) @ last + ca.DM(rows.b) @ turn_start
    slope = ca.DM(rows.c) @ step + ca.DM(rows.e) @ (step / dt)
    slope_end = slope + ca.DM(rows.b) @ (turn_end - turn_start)
    n = rows.wheels
    keep = 1.0 - CLAMP_HEADROOM * dyn.headroom
    torque_scale = keep * forces.torque_limit
    fraction = _sag_fraction(
        forces, volts=(start[:2 * n], ca.vertcat(slope_end[:n], slope[n:2 * n])),
        others=(ca.vertcat(start[2 * n:], start[2 * n:]),
                ca.vertcat(slope_end[2 * n:], slope[2 * n:])),
        power=(start[:n], slope_end[:n], torque_scale * start[2 * n:3 * n],
               torque_scale * slope_end[2 * n:3 * n]))
    if rows.disks:
        fraction = _traction_fraction(forces, fraction, step, turn_start, turn_end, dt, keep)
    return ca.fmax(0.0, fraction * (1.0 - 1e-12))


def _linear_fraction(start: ca.SX, slope: ca.SX) -> ca.SX:
    """``motor_step._linear_fraction``: the largest f in [0, 1] with every
    ``|start + f slope| <= 1`` (a row already beyond it only back in; a row the step does
    not move, :data:`~mpc.robots.drive.motor_step.STILL_SLOPE`, no limit)."""
    reach = ca.if_else(ca.fabs(slope) <= STILL_SLOPE, math.inf,
                       (ca.copysign(1.0, slope) - start) / slope)
    return ca.fmin(1.0, ca.fmax(0.0, ca.mmin(reach)))


def _sag_fraction(forces: ForceMap, volts: tuple[ca.SX, ca.SX], others: tuple[ca.SX, ca.SX],
                  power: tuple[ca.SX, ca.SX, ca.SX, ca.SX]) -> ca.SX:
    """``motor_step._sag_fraction``: its early returns as selections, its bisection
    unrolled."""
    dyn = forces.dynamics
    keep = 1.0 - CLAMP_HEADROOM * dyn.voltage_headroom
    upper = _linear_fraction(*others)
    v0, v1 = volts
    volt, resistance = dyn.battery_voltage, dyn.battery_resistance

    def bus(fraction: ca.SX) -> ca.SX:
        if resistance == 0.0:
            return ca.SX(volt)
        e0, e1, t0, t1 = power
        drawn = ca.dot(e0 + fraction * e1, t0 + fraction * t1) / forces.kt
        disc = volt * volt - 4.0 * resistance * drawn
        return ca.if_else(drawn <= 0.0, volt, 0.5 * (volt + ca.sqrt(ca.fmax(disc, 0.0))))

    def reach(fraction: ca.SX) -> ca.SX:
        scale = 1.0 / (keep * bus(fraction))
        return _linear_fraction(v0 * scale, v1 * scale)

    at_upper = reach(upper)
    if resistance == 0.0:
        inner = at_upper
    else:
        low, high = ca.SX(0.0), upper
        for _ in range(SAG_BISECTIONS):
            middle = 0.5 * (low + high)
            fits = reach(middle) >= middle
            low, high = ca.if_else(fits, middle, low), ca.if_else(fits, high, middle)
        inner = ca.if_else(reach(ca.SX(0.0)) <= 0.0, 0.0, low)
    return ca.if_else(upper <= 0.0, 0.0, ca.if_else(at_upper >= upper, upper, inner))


def _traction_fraction(forces: ForceMap, fraction: ca.SX, step: ca.SX, turn_start: ca.SX,
                       turn_end: ca.SX, dt: float, keep: float) -> ca.SX:
    """``motor_step._traction_fraction``: each contact's force within its traction disk
    at both ends of the change."""
    traction = forces.friction_limits
    if traction is None:
        return fraction
    flat = ca.DM(forces.flat_contacts)
    force0 = flat @ turn_start
    force1 = (flat @ step) / dt
    chord = flat @ (turn_end - turn_start)
    bound = keep * traction
    shorter = ca.fmin(fraction, ca.fmin(_disk_fraction(force0, force1 + chord, bound),
                                        _disk_fraction(force0, force1, bound)))
    return ca.if_else(fraction <= 0.0, fraction, shorter)


def _disk_fraction(start: ca.SX, slope: ca.SX, bound: FloatArray) -> ca.SX:
    """``motor_step._disk_fraction``: the largest f in [0, 1] with every contact's
    ``|start_c + f slope_c| <= bound_c`` (2-vectors stacked)."""
    reaches = []
    for c, limit in enumerate(bound.tolist()):
        sx, sy = slope[2 * c], slope[2 * c + 1]
        x, y = start[2 * c], start[2 * c + 1]
        a = sx * sx + sy * sy
        h = x * sx + y * sy
        cc = x * x + y * y - limit * limit
        moving = a > 0.0
        safe_a = ca.if_else(moving, a, 1.0)
        inside = (-h + ca.sqrt(ca.fmax(h * h - a * cc, 0.0))) / safe_a
        reach = ca.if_else(cc > 0.0, ca.fmax(0.0, -h / safe_a), inside)
        reaches.append(ca.if_else(moving, reach, math.inf))
    return ca.fmin(1.0, ca.mmin(ca.vertcat(*reaches)))


def motor_feedforward(robot: Robot, last: ca.SX, twist: ca.SX, dt: float) -> ca.SX:
    """:func:`~mpc.robots.drive.motor_step.first_step_feedforward` of the step ``last ->
    twist`` (wheels that do not steer): (drive forces n [N], motor torques n [N m], motor
    currents n [A], contact force vectors n x 2 [N], a wheel's two together)."""
    forces = force_map(robot)
    change = (twist - last) / dt
    middle = 0.5 * (twist + last)
    turn = _turn(middle)
    static = ca.DM(forces.flat_effort) @ (change + turn)
    torque = ca.DM(forces.flat_drive) @ change + ca.DM(forces.flat_effort) @ turn
    vectors = ca.DM(forces.wheel_force_maps.reshape(-1, 3)) @ (change + turn)
    gearing = forces.dynamics.gearing
    return ca.vertcat(static / ca.DM(forces.radii), torque / (gearing * forces.count),
                      torque / (forces.kt * forces.count), vectors)
