"""A swerve module's limits for the solvers: speed and acceleration disks, steering rate.

For module ``i`` with velocity ``v = W_i u`` [rad/s] (ground velocity / r):

- speed: ``|v_k| <= max_wheel_speed`` (axle offset ``L``: ``|v_k| + L |omega_k| / r``);
  acceleration: ``|v_k - v_{k-1}| <= max_wheel_accel dt``;
- steering: the module turns at most ``max_steer_rate dt`` a tick. With the flip rule a
  module may reverse instead of turning, so what is bounded is the turn modulo a half
  turn: ``|v_k x v_{k-1}| <= sin(max_steer_rate dt) |v_k| |v_{k-1}|``.

The NLP takes the disks and, between consecutive stages of the plan, the steering
bound (squared, so smooth; exact for modules at speed, see :data:`NLP_STEERING_SLACK`).
The QPs take the speed disk linearised around the plan the solver starts from and the
acceleration disk as a constant polygon (:func:`linearised_stage_limits`), or both disks
as a constant regular polygon (:func:`qp_speed_rows`) when asked for one, and the
steering rate as the cost on the change of module velocity
(``Weights.module_rate``). For every command, the final clamp
(:func:`mpc.control.clamp.clamp_command`) keeps every module within all three limits: the
first command's turn against the present steer angles is the clamp's to keep, in both
paths.
"""

from __future__ import annotations

import functools
import itertools
import math

import casadi as ca
import numpy as np
import numpy.typing as npt

from mpc.arrays import FloatArray, IntArray
from mpc.errors import RobotError
from mpc.robots.limits import SpeedRows, StageLimits, outermost
from mpc.robots.wheels.swerve.modules import SwerveModules
from mpc.validation import integer_at_least

#: The NLP's steering rows, in module speed over its nominal limit (``a = v / max``,
#: ``b = w / max``: rows of order 1 for IPOPT), hold
#: ``(a x b)^2 - sin^2 |a|^2 |b|^2 <= NLP_STEERING_SLACK^4``: exact for modules at speed,
#: looser below about this fraction of the limit at both ends of a change (at 0.2 of it a
#: 0.24 rad limit reads 0.35 rad; at 0.5, 0.24 rad). The exact row is a cone with its apex
#: at rest, where it has no gradient: IPOPT stalled on it (a swerve reference that ends at
#: speed failed most ticks after the horizon reached its end). The first command's turn is
#: the clamp's to keep, exactly, in any case.
NLP_STEERING_SLACK = 0.1


def nlp_stage_limits(robot: SwerveModules, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                     change_times: FloatArray
                     ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
    """The exact limits for the NLP (squared forms; see the module docstring), ``u_k``
    following ``u_{k-1}`` by ``change_times[k]`` [s] (the ``dt`` of the module docstring)."""
    blocks = [ca.DM(block) for block in robot.wheel_blocks]
    speed, accel = robot.max_wheel_speed, robot.max_wheel_accel
    slack = NLP_STEERING_SLACK**4  # of the rows in speed / limit
    values: list[ca.SX] = []
    lower: list[FloatArray] = []
    upper: list[FloatArray] = []

    def add(value: ca.SX, high: float) -> None:
        values.append(value)
        lower.append(np.array([-np.inf]))
        upper.append(np.array([high]))

    for k in range(twists.shape[1]):
        for i, block in enumerate(blocks):
            v = block @ twists[:, k]
            w = block @ (last if k == 0 else twists[:, k - 1])
            if robot.axle_offset:  # |v| + L |omega| / r <= max, as smooth rows
                spin = robot.axle_offset / robot.wheel_radius * twists[2, k]
                bound = float(speed[i])
                add(ca.sumsqr(v) - (bound - spin) ** 2, 0.0)
                add(ca.sumsqr(v) - (bound + spin) ** 2, 0.0)
                values.append(spin)
                lower.append(np.array([-bound]))
                upper.append(np.array([bound]))
            else:
                add(ca.sumsqr(v), float(speed[i]) ** 2)
            dt = float(change_times[k])
            if accel is not None:
                add(ca.sumsqr(v - w), float(accel[i] * dt) ** 2)
            if k > 0:
                sine2 = math.sin(min(robot.max_steer_rate * dt, math.pi / 2)) ** 2
                scale = float(robot.nominal_max_wheel_speed[i])  # not derated: never 0
                a, b = v / scale, w / scale  # rows of order 1 for IPOPT
                cross = a[0] * b[1] - a[1] * b[0]
                add(cross**2 - sine2 * ca.sumsqr(a) * ca.sumsqr(b), slack)
    return values, lower, upper


#: Below this module speed [m/s] a module is at rest and keeps its steer angle.
STOPPED_MODULE_SPEED = 1e-6

#: The steering limits count a module as moving a little below that speed: rounding
#: between the limit's check and the command's own computation can then only make the
#: command keep an angle the limit allowed to change, never the reverse.
MOVING_MODULE_SPEED = STOPPED_MODULE_SPEED * (1.0 - 1e-3)


def _flip_turn(x: FloatArray, y: FloatArray, steer_angles: FloatArray) -> FloatArray:
    """The signed turn [rad] in [-pi/2, pi/2) from ``steer_angles`` to the velocities'
    (``x``, ``y``) directions under the flip rule (a module may drive backwards)."""
    return np.mod(np.arctan2(y, x) - steer_angles + 0.5 * math.pi, math.pi) - 0.5 * math.pi


def _reach(robot: SwerveModules, dt: float) -> float:
    """The turn a module may make in ``dt`` [rad], a hair inside the steering rate."""
    return robot.max_steer_rate * dt * (1.0 - 1e-9)


def flip_turn(x: float, y: float, steer_angle: float) -> float:
    """:func:`_flip_turn` of one module in Python floats (the same operations): the signed
    turn [rad] in [-pi/2, pi/2) from ``steer_angle`` to the direction of (``x``, ``y``)."""
    half = 0.5 * math.pi
    return (math.atan2(y, x) - steer_angle + half) % math.pi - half


def turns(robot: SwerveModules, velocities: FloatArray, steer_angles: FloatArray) -> FloatArray:
    """How far each module must turn [rad] to drive ``velocities`` (n, 2) from its present
    angle, with the flip rule (so in [0, pi / 2]); 0 for a module at rest."""
    turn = np.abs(_flip_turn(velocities[:, 0], velocities[:, 1], steer_angles))
    speed = np.hypot(velocities[:, 0], velocities[:, 1])
    moving = speed * robot.wheel_radius > MOVING_MODULE_SPEED
    return np.where(moving, turn, 0.0)


#: The search for the drives' limit (axle offsets): rounds, each splitting the interval
#: left into this many parts at once (40^3: the fraction to 1.6e-5 of the turn's). A call
#: costs about the same for 2 points or 40 (NumPy's overhead), so each round is one call
#: (docs/design/axle-offset-search.md).
_SEARCH_ROUNDS, _SEARCH_PARTS = 3, 40
#: A round's grid over [0, 1], made once (``np.linspace`` a call is a fifth of a round:
#: docs/design/axle-offset-search.md).
_SEARCH_GRID = np.linspace(0.0, 1.0, _SEARCH_PARTS + 1)


def steering_fraction(robot: SwerveModules, last: FloatArray, target: FloatArray,
                      steer_angles: FloatArray, dt: float) -> float:
    """:func:`turn_fraction`, and with an axle offset no further than every wheel's drive
    rate, corrected for the module's steering over ``dt``, stays within its limit (searched
    below the turn's fraction: the last point of a fine grid before the first where a drive
    or a module's turn leaves its limit)."""
    fraction = turn_fraction(robot, last, target, steer_angles, dt)
    if not robot.axle_offset or fraction == 0.0:
        return fraction
    step = target - last
    reach = _reach(robot, dt)

    def within(parts: FloatArray) -> npt.NDArray[np.bool_]:
        return _drives_within(robot, last + parts[:, None] * step, steer_angles, dt, reach)

    # Most ticks need no search: the fraction's point fits (checked on its own, in Python
    # floats: a NumPy call costs about the same for 1 point as for 41). Else the first
    # round's grid (its last point the fraction's) checked with the start in one call. The
    # turn is checked with the drives: the target may fit where points on the way to it do
    # not.
    if _drives_fit(robot, last + fraction * step, steer_angles, dt, reach):
        return fraction
    parts = fraction * _SEARCH_GRID  # parts[0] = 0: the start
    fits = within(parts)
    if fits[-1]:
        return fraction
    if not fits[0]:
        return 0.0
    low, high = 0.0, fraction
    for round_ in range(_SEARCH_ROUNDS):
        if round_:
            parts = low + (high - low) * _SEARCH_GRID
            fits = within(parts[1:])
        else:
            fits = fits[1:]
        bad = np.flatnonzero(~fits)
        if bad.size == 0:
            return high
        first = int(bad[0])
        low, high = parts[first], parts[first + 1]
    return low


def _drives_within(robot: SwerveModules, twists: FloatArray, steer_angles: FloatArray,
                   dt: float, reach: float | None = None) -> npt.NDArray[np.bool_]:
    """For each of ``twists`` (K, 3): whether every wheel's drive rate as
    :meth:`SwerveRobot.wheel_commands` gives it is within its limit (and with ``reach``
    [rad], every moving module's turn within it); the K twists at once.

    The flip rule in closed form: a module turns by ``turn`` (in [-pi/2, pi/2)) from its
    present angle and drives backwards where its velocity points away from it; a module at
    rest keeps its angle; the axle offset adds ``L (omega + turn / dt) / r``.
    """
    velocities = twists @ robot.flat_wheel_blocks.T  # (K, 2n): (x, y) a module [rad/s]
    x, y = velocities[:, 0::2], velocities[:, 1::2]
    turn = _flip_turn(x, y, steer_angles)
    magnitude = np.hypot(x, y)
    ground = magnitude * robot.wheel_radius  # [m/s]
    speed = np.copysign(magnitude, x * np.cos(steer_angles) + y * np.sin(steer_angles))
    lever = robot.axle_offset / robot.wheel_radius
    # (NumPy calls on arrays of K x n: few, each one counts in a search round)
    speed += (lever / dt) * turn
    drive = np.where(ground < STOPPED_MODULE_SPEED, 0.0, speed)
    drive += lever * twists[:, 2:3]
    within = np.abs(drive) <= robot.max_wheel_speed * (1.0 + 1e-12)
    if reach is not None:
        within &= (np.abs(turn) <= reach) | (ground <= MOVING_MODULE_SPEED)
    return np.all(within, axis=1)


def _drives_fit(robot: SwerveModules, twist: FloatArray, steer_angles: FloatArray, dt: float,
                reach: float) -> bool:
    """:func:`_drives_within` for one ``twist`` (3,), in Python floats: the same operations
    module by module."""
    u0, u1, u2 = twist.tolist()
    rows = robot.flat_wheel_blocks.tolist()
    radius = robot.wheel_radius
    lever = robot.axle_offset / radius
    for i, (angle, limit) in enumerate(zip(steer_angles.tolist(),
                                           robot.max_wheel_speed.tolist(), strict=True)):
        (a0, a1, a2), (b0, b1, b2) = rows[2 * i], rows[2 * i + 1]
        x = a0 * u0 + a1 * u1 + a2 * u2
        y = b0 * u0 + b1 * u1 + b2 * u2
        turn = flip_turn(x, y, angle)
        magnitude = math.hypot(x, y)
        ground = magnitude * radius  # [m/s]
        speed = math.copysign(magnitude, x * math.cos(angle) + y * math.sin(angle))
        speed += (lever / dt) * turn
        drive = (0.0 if ground < STOPPED_MODULE_SPEED else speed) + lever * u2
        if not (abs(drive) <= limit * (1.0 + 1e-12)
                and (abs(turn) <= reach or ground <= MOVING_MODULE_SPEED)):
            return False
    return True


def turn_fraction(robot: SwerveModules, last: FloatArray, target: FloatArray,
                  steer_angles: FloatArray, dt: float) -> float:
    """1 if ``target`` turns no module by more than ``max_steer_rate dt`` from its present
    angle (only the command sent has to); else the largest ``f`` in [0, 1] such
    that every point of ``last + g (target - last)``, ``0 <= g <= f``, does so (0 if
    ``last`` itself does not).

    Closed form: along the step a module's velocity ``a + g b`` is a line, so with ``u``
    its present direction the bound ``|u x v| <= tan(reach) |u . v|`` (a double cone: the
    flip rule) changes sign only where ``u x v = +-tan(reach) u . v`` (linear in ``g``) or
    where the module's speed crosses the stopped threshold (a module at rest turns by 0).
    Each module's answer is one of its roots: its roots and the points between them are
    checked in order up to the first that breaks the bound, and the smallest answer over
    the modules is the step's. In Python floats, module by module (a few modules, and most
    calls stop at the first check: NumPy's arrays of all the roots at once were slower,
    docs/design/axle-offset-search.md).
    """
    reach = _reach(robot, dt)
    blocks = robot.wheel_blocks
    modules = list(zip((blocks @ last).tolist(), (blocks @ (target - last)).tolist(),
                       steer_angles.tolist(), strict=True))
    radius = robot.wheel_radius
    if all(_turn_fits(start, change, angle, 1.0, reach, radius)
           for start, change, angle in modules):  # most ticks: no module turns too far
        return 1.0
    # the last command itself out of line (e.g. after a reset): no step at all
    if not all(_turn_fits(start, change, angle, 0.0, reach, radius)
               for start, change, angle in modules):
        return 0.0
    # The roots a hair inside the limits, so that rounding cannot push them out.
    slope = math.tan(reach * (1.0 - 1e-7))
    stopped = MOVING_MODULE_SPEED / radius * (1.0 - 1e-6)
    fraction = 1.0
    for start, change, angle in modules:
        roots = _turn_roots(start, change, angle, slope, stopped)
        points = sorted({0.0, 1.0, *(root for root in roots if 0.0 < root < 1.0)})
        resting: float | None = None  # where the module's present stretch at rest began
        for low, high in itertools.pairwise(points):  # low fits (0 does, see above)
            middle = 0.5 * (low + high)
            if not _turn_fits(start, change, angle, middle, reach, radius):
                # A module that must turn past its reach as it leaves rest waits at rest
                # from where its rest began: creeping to the stopped speed instead moved
                # the other modules at about that speed, and a robot starting from rest
                # stayed on such a creep, its angles held by it.
                fraction = min(fraction, low if resting is None else resting)
                break
            if not _turn_fits(start, change, angle, high, reach, radius):
                fraction = min(fraction, middle)
                break
            at_rest = not _moving(start, change, middle, radius)
            resting = (low if resting is None else resting) if at_rest else None
    return fraction


def _moving(start: list[float], change: list[float], fraction: float,
            wheel_radius: float) -> bool:
    """Whether a module whose velocity is ``start + fraction * change`` [rad/s] moves (the
    rest test of :func:`_turn_fits`)."""
    x = start[0] + fraction * change[0]
    y = start[1] + fraction * change[1]
    return math.hypot(x, y) * wheel_radius > MOVING_MODULE_SPEED


def _turn_fits(start: list[float], change: list[float], angle: float, fraction: float,
               reach: float, wheel_radius: float) -> bool:
    """Whether a module whose velocity is ``start + fraction * change`` [rad/s] turns by at
    most ``reach`` [rad] from ``angle`` (the flip rule; a module at rest turns by 0): the
    operations of :func:`_flip_turn`, in Python floats."""
    x = start[0] + fraction * change[0]
    y = start[1] + fraction * change[1]
    if not math.hypot(x, y) * wheel_radius > MOVING_MODULE_SPEED:
        return True
    return abs(flip_turn(x, y, angle)) <= reach


def _turn_roots(start: list[float], change: list[float], angle: float, slope: float,
                stopped: float) -> list[float]:
    """Fractions ``g`` where a module's velocity ``start + g change`` [rad/s] meets the edge
    of its steering cone (``|u x v| = slope |u . v|`` about its angle ``u``, both ways) or
    the stopped speed ``stopped`` [rad/s]."""
    ux, uy = math.cos(angle), math.sin(angle)
    (sx, sy), (cx, cy) = start, change
    c0, c1 = ux * sy - uy * sx, ux * cy - uy * cx
    d0, d1 = ux * sx + uy * sy, ux * cx + uy * cy
    roots = []
    for sign in (1.0, -1.0):  # c0 + c1 g = sign * slope * (d0 + d1 g)
        denominator = c1 - sign * slope * d1
        if denominator != 0.0:
            roots.append((sign * slope * d0 - c0) / denominator)
    # |start + g change|^2 = stopped^2
    a = cx * cx + cy * cy
    b = 2.0 * (sx * cx + sy * cy)
    c = sx * sx + sy * sy - stopped * stopped
    discriminant = b * b - 4.0 * a * c
    if a > 0.0 and discriminant >= 0.0:
        root = math.sqrt(discriminant)
        roots += [(-b - root) / (2.0 * a), (-b + root) / (2.0 * a)]
    return [root for root in roots if math.isfinite(root)]


def qp_speed_rows(robot: SwerveModules, polygon_sides: int) -> SpeedRows:
    """A regular polygon with ``polygon_sides`` sides (even, >= 4; half as many two-sided
    rows per module) midway between the ones inscribed in and circumscribed about the
    disk: its edges' middles at ``R (1 + c) / 2``, its vertices at ``R (1 + c) / (2 c)``,
    ``c = cos(pi / sides)`` (within about 1 % of the disk at 16 sides): it tracks closer to
    the exact disk than the inscribed polygon (docs/design/swerve-speed-faces.md); the
    clamp keeps every command inside the disk."""
    sides = integer_at_least("polygon_sides", polygon_sides, 4, RobotError)
    if sides % 2:
        raise RobotError(f"polygon_sides must be an even integer >= 4, got {polygon_sides!r}")
    angles = 2.0 * math.pi * np.arange(sides // 2) / sides
    normals = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # (M/2, 2)
    rows = np.einsum("md,ndj->nmj", normals, robot.wheel_blocks)
    if robot.axle_offset:  # |c . v| + L |omega| <= b as the pair c . v +- L omega
        spin = np.zeros(3)
        spin[2] = robot.axle_offset / robot.wheel_radius
        rows = np.concatenate([rows + spin, rows - spin], axis=1)
    wheel = np.repeat(np.arange(robot.n_wheels), rows.shape[1])
    return SpeedRows(rows.reshape(-1, 3), wheel, 0.5 * (1.0 + math.cos(math.pi / sides)))


#: Below this module speed [rad/s, per the wheel's limit] the guess gives no direction to
#: linearise about: the faces keep the last direction they had.
_DIRECTION_FLOOR = 1e-3

#: The linearised speed disk: faces of a polygon circumscribed about it, their normals at
#: these angles [rad] from the planned direction (two-sided rows, so each face has its
#: opposite). The face along the planned direction is the tangent; the two 5 deg beside it
#: leave its corners 0.1 % outside the disk; the ones at 45 and 90 deg keep a turning plan
#: within 8 % of the disk elsewhere. Tracks as IPOPT's exact disk does; fewer faces slid
#: along their corners (docs/design/swerve-speed-faces.md).
FACE_ANGLES = tuple(math.radians(angle) for angle in (-45.0, -5.0, 0.0, 5.0, 45.0, 90.0))
FACES = len(FACE_ANGLES)

#: The faces at +-45 and 90 deg are guards (:attr:`StageLimits.guards`, each stage's last
#: rows): a plan reaches them only when it turns a module far from the guess's direction
#: (the first tick, or a sudden turn), so daqp solves without them, the plan is checked
#: against them and the tick solved again with them when one breaks: the same plans, fewer
#: rows (docs/design/swerve-guard-faces.md).
GUARD_FACES = tuple(j for j, angle in enumerate(FACE_ANGLES) if abs(angle) > math.radians(30))

#: The acceleration disk: a constant regular polygon of this many sides (half as many
#: two-sided rows a module), midway between the inscribed and the circumscribed one (within
#: 1 % of the disk). Faces turned to the planned change cost daqp many iterations, 8 and 12
#: sides tracked worse in path mode (docs/design/swerve-accel-sides.md).
ACCEL_SIDES = 16


def linearised_stage_limits(robot: SwerveModules, change_times: FloatArray,
                            guard_faces: tuple[int, ...] | None = None) -> StageLimits:
    """Each module's speed disk as faces of a polygon circumscribed about it
    (:data:`FACE_ANGLES`), turned to the direction of the module's velocity in the plan the
    solver starts from (:func:`update_linearised`): two-sided rows ``|n_j . v| <= R``;
    its acceleration disk as the constant :data:`ACCEL_SIDES`-gon.

    The face along the planned direction is the speed disk's linearisation at the guess (a
    sequential linear programme of the exact disk: at a fixed point of the real-time
    iteration the planned module speed meets the disk exactly, not a polygon); the others
    keep a step that turns the module close to the disk. Rows a stage
    (:func:`face_rows` numbers the faces'): the faces within 30 deg of the direction,
    module by module (``moving``); with an acceleration limit, the acceleration polygon's
    outermost rows (:func:`~mpc.robots.limits.outermost`: two a direction, ``ACCEL_SIDES``
    in all, where the modules share one limit); last the guard faces (:data:`GUARD_FACES`).
    The faces point along the body x axis until the first tick turns them. Every face is a
    supporting line of the disk, so the disk satisfies the faces of any refill
    (``StageLimits.inside``): a plan within the disks with no face active is the answer
    whichever way they point. ``guard_faces``: the faces that are guards (None:
    :data:`GUARD_FACES`; ``()``: every face a kept row, as the compiled tick solves them).
    """
    n = robot.n_wheels
    horizon = len(change_times)
    guard_faces = GUARD_FACES if guard_faces is None else tuple(guard_faces)
    kept_faces = _kept_faces(guard_faces)
    kept, guards = n * len(kept_faces), n * len(guard_faces)
    accel = robot.max_wheel_accel
    polygon = None if accel is None else outermost(qp_speed_rows(robot, ACCEL_SIDES), accel)
    m = kept + guards + (0 if polygon is None else len(polygon.rows))
    bound = np.repeat(robot.max_wheel_speed[None, :], horizon, axis=0)  # (N, n)
    bounds = [np.repeat(bound, len(kept_faces), axis=1)]
    now, before = np.zeros((horizon, m, 3)), np.zeros((horizon, m, 3))
    if polygon is not None and accel is not None:
        bounds.append(polygon.scale * accel[polygon.wheel][None, :]
                      * np.asarray(change_times, dtype=float)[:, None])
        now[:, kept:m - guards] = polygon.rows
        before[:, kept:m - guards] = -polygon.rows
    bounds.append(np.repeat(bound, len(guard_faces), axis=1))
    upper = np.concatenate(bounds, axis=1)
    limits = StageLimits(now=now, before=before, lower=-upper, upper=upper, constant=False,
                         change_times=np.array(change_times, dtype=float), moving=kept,
                         guards=guards, inside=functools.partial(_within_disks, robot))
    directions = np.zeros((horizon, n, 2))
    directions[..., 0] = 1.0
    limits.memory["directions"] = directions  # each module's planned unit direction
    for name, faces, rows in (("kept", kept_faces, limits.now[:, :kept]),
                              ("guards", guard_faces, limits.now[:, m - guards:])):
        limits.memory[f"{name}_bases"] = _face_bases(robot, faces)
        view = rows.reshape(horizon, n, 1, 3 * len(faces))
        if view.size and not np.shares_memory(view, limits.now):  # refills write the rows
            raise RuntimeError("the speed faces' rows are not a view of the stage rows")
        limits.memory[f"{name}_rows"] = view
    limits.memory["floor"] = _DIRECTION_FLOOR * robot.nominal_max_wheel_speed
    _fill_faces(limits)
    return limits


def _kept_faces(guard_faces: tuple[int, ...] | None = None) -> tuple[int, ...]:
    """The faces solved with always (not ``guard_faces``, None: :data:`GUARD_FACES`), in
    angle order."""
    guards = GUARD_FACES if guard_faces is None else guard_faces
    return tuple(j for j in range(FACES) if j not in guards)


def _within_disks(robot: SwerveModules, twists: FloatArray, ratio: float) -> bool:
    """Whether every module's velocity in ``twists`` (N, 3) keeps within ``ratio`` of its
    speed limit (the disks every face of :func:`linearised_stage_limits` contains)."""
    velocities = twists @ robot.flat_wheel_blocks.T  # (N, 2n)
    squares = velocities[:, 0::2] ** 2 + velocities[:, 1::2] ** 2
    limit = ratio * robot.max_wheel_speed
    return bool((squares <= limit * limit).all())


def face_rows(n_wheels: int, rows: int) -> IntArray:
    """(n, F): the row of a stage (of ``rows``) holding module ``i``'s face ``j`` (the
    face at ``FACE_ANGLES[j]``) in :func:`linearised_stage_limits`."""
    index = np.empty((n_wheels, FACES), dtype=np.intp)
    modules = np.arange(n_wheels)[:, None]
    kept = _kept_faces()
    index[:, list(kept)] = len(kept) * modules + np.arange(len(kept))
    index[:, list(GUARD_FACES)] = (rows - len(GUARD_FACES) * n_wheels
                                   + len(GUARD_FACES) * modules + np.arange(len(GUARD_FACES)))
    return index


def update_linearised(robot: SwerveModules, limits: StageLimits, guess: FloatArray,
                      last: FloatArray) -> None:
    """Turn each speed disk's faces to the direction of its module's velocity in
    ``guess`` (N, 3); where that is too slow to give a direction, the faces keep the one
    they had. (``last``, the last command, bounds the first stage's acceleration rows,
    which do not move.)

    Every tick: some module at some stage turns a few degrees a tick, so a threshold
    would seldom keep them (docs/design/swerve-speed-faces.md)."""
    velocities = (guess @ robot.flat_wheel_blocks.T).reshape(len(guess), -1, 2)  # (N, n, 2)
    _turn(limits.memory["directions"], velocities, limits.memory["floor"])
    _fill_faces(limits)


def _turn(directions: FloatArray, vectors: FloatArray, floor: FloatArray) -> None:
    """The unit directions of ``vectors`` (N, n, 2) into ``directions`` where they are
    longer than ``floor`` (n,)."""
    lengths = np.hypot(vectors[..., 0], vectors[..., 1])
    np.divide(vectors, lengths[..., None], out=directions, where=(lengths > floor)[..., None])


def _face_bases(robot: SwerveModules, faces: tuple[int, ...]) -> FloatArray:
    """(n, 2, 3 F): module ``i``'s rows of the faces ``faces`` (indices into
    :data:`FACE_ANGLES`; three numbers each, side by side) for a direction (1, 0), then
    for (0, 1), so that the rows for a unit direction ``(c, s)`` are ``(c, s) @ bases[i]``
    (the face normal turned by the face's angle from the direction, times ``W_i``)."""
    blocks = robot.wheel_blocks  # (n, 2, 3): module i's velocity is blocks[i] @ u
    offsets = np.asarray(FACE_ANGLES)[list(faces)]
    c, s = np.cos(offsets)[None, :, None], np.sin(offsets)[None, :, None]  # (1, F, 1)
    along, across = blocks[:, None, 0, :], blocks[:, None, 1, :]  # (n, 1, 3)
    bases = np.stack([c * along + s * across, c * across - s * along], axis=1)  # (n, 2, F, 3)
    return bases.reshape(robot.n_wheels, 2, 3 * len(faces))


def _fill_faces(limits: StageLimits) -> None:
    """The speed faces' rows ``n_j . W_i u`` from the directions (one batch of (1, 2) x
    (2, 3 F) products, written into the rows in place)."""
    directions = limits.memory["directions"][:, :, None, :]  # (N, n, 1, 2)
    np.matmul(directions, limits.memory["kept_bases"], out=limits.memory["kept_rows"])
    np.matmul(directions, limits.memory["guards_bases"], out=limits.memory["guards_rows"])
    limits.changed = True
