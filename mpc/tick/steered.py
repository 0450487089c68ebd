"""Swerve modules in the compiled tick: the arithmetic of the Python tick's swerve steps as
CasADi expressions, for :mod:`mpc.tick.graphs` to put into ``prepare`` and ``finish``.

Scope: swerve robots whose modules the clamp takes as
:class:`~mpc.robots.base.PlanarModules` (no axle offset, no failed module, no motor model,
no steering range), time mode.

- The rows (``prepare``): each module's speed disk as the faces of
  :func:`~mpc.robots.wheels.swerve.limits.linearised_stage_limits`, turned to the direction
  of the module's velocity in the guess (:func:`~mpc.robots.wheels.swerve.limits.update_linearised`:
  a module too slow to give a direction keeps the one it had, so the directions are state
  carried from tick to tick), its acceleration disk the constant polygon. Every face is a
  row of the graphs (``guard_faces=()``); ``tick.c`` leaves the guard faces out of daqp's
  problem until a plan breaks one (:mod:`mpc.tick.screen`, the Python tick's guard faces
  as a row screen); rows kept from the last tick while a plan stays inside the disks (the
  Python tick's other shortcut) are not done here.
- The clamp (``finish``): :func:`~mpc.control.clamp.clamp_command`'s steps for planar modules
  (``_clamp_planar``: the speed scaling, the acceleration step, the steering check) and, when a
  module would turn past its reach, :func:`~mpc.robots.wheels.swerve.limits.turn_fraction` and
  ``_turn_step``. The fraction's search over a module's roots (at most four, then the points
  between them in order) has a fixed count here: the roots sorted by a network of five
  comparisons, the five intervals they bound walked with flags instead of ``break``.
- The commands (``finish``): :func:`~mpc.robots.wheels.swerve.states.module_states` (the flip
  rule, modules at rest keep their angle), :func:`~mpc.robots.wheels.swerve.states.aimed_angles`
  (a module at rest turns towards its direction in the target) and the forward kinematics of
  what is sent (the twist the wheels will drive, the next tick's last command).

Python's and NumPy's float modulo (the sign of the divisor) is :func:`py_mod`, not C's
``fmod``; the rest are the same operations in the same order, so the two ticks agree to
rounding (a comparison that rounding decides can differ; tests/test_compiled_swerve.py).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import SPEED_SLACK, PlanarModules
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.swerve.limits import (
    FACES,
    MOVING_MODULE_SPEED,
    STOPPED_MODULE_SPEED,
    linearised_stage_limits,
)
from mpc.robots.wheels.swerve.modules import SwerveModules

_HALF = 0.5 * math.pi


def py_mod(a: ca.SX, b: float) -> ca.SX:
    """``a % b`` as Python and NumPy take it for ``b > 0`` (the result in [0, b))."""
    m = ca.fmod(a, b)
    return ca.if_else(m < 0, m + b, m)


def flip_turn(x: ca.SX, y: ca.SX, angle: ca.SX) -> ca.SX:
    """:func:`~mpc.robots.wheels.swerve.limits.flip_turn`: the signed turn [rad] in
    [-pi/2, pi/2) from ``angle`` to the direction of (``x``, ``y``) under the flip rule."""
    return py_mod(ca.atan2(y, x) - angle + _HALF, math.pi) - _HALF


def wrapped(angle: ca.SX) -> ca.SX:
    """:func:`~mpc.angles.wrap_angle`: ``angle`` into (-pi, pi] [rad]."""
    w = py_mod(angle + math.pi, 2.0 * math.pi) - math.pi
    return ca.if_else(w == -math.pi, math.pi, w)


def module_state(x: ca.SX, y: ca.SX, present: ca.SX, radius: float) -> tuple[ca.SX, ca.SX]:
    """``module_states``' rule for one module whose wheel is to move at (``x``, ``y``)
    [rad/s, wheel-rim units]: its signed speed [rad/s] and angle [rad] in (-pi, pi],
    flipped where the turn from ``present`` would exceed 90 deg, held at ``present`` with
    speed 0 below :data:`STOPPED_MODULE_SPEED` at the rim (``radius`` [m])."""
    speed, angle = ca.hypot(x, y), ca.atan2(y, x)
    flip = ca.fabs(wrapped(angle - present)) > _HALF
    angle = ca.if_else(flip, angle + math.pi, angle)
    speed = ca.if_else(flip, -speed, speed)
    still = ca.fabs(speed) * radius < STOPPED_MODULE_SPEED
    return ca.if_else(still, 0.0, speed), wrapped(ca.if_else(still, present, angle))


def _any(values: list[ca.SX]) -> ca.SX:
    out = ca.SX(0)
    for value in values:
        out = ca.logic_or(out, value)
    return out


def _all(values: list[ca.SX]) -> ca.SX:
    out = ca.SX(1)
    for value in values:
        out = ca.logic_and(out, value)
    return out


class Steering:
    """The swerve parts of the tick's graphs for one robot and control tick.

    Args:
        robot: the swerve robot (its modules as :class:`PlanarModules`: checked by
            :func:`mpc.tick.support.check_supported`).
        modules: ``robot.planar_modules``.
        change_times: the model's stage changes [s] (``TrackingModel.change_times``).
        dt: the control tick [s].
    """

    def __init__(self, robot: SwerveModules, modules: PlanarModules, change_times: FloatArray,
                 dt: float) -> None:
        self.robot, self.modules, self.dt = robot, modules, float(dt)
        #: Every face a row daqp solves with (no guards), the acceleration polygon.
        self.limits: StageLimits = linearised_stage_limits(robot, change_times, guard_faces=())
        self.wheels = robot.n_wheels
        self.horizon = len(change_times)
        self._bases = np.asarray(self.limits.memory["kept_bases"])  # (n, 2, 3 FACES)
        self._floor = np.asarray(self.limits.memory["floor"])  # (n,)
        # (3, 2n): the forward kinematics, as the robot's (Robot._flat_pinv: the same call)
        self._pinv = np.linalg.pinv(robot.wheel_blocks.reshape(-1, 3))
        self._reach = modules.steer_rate * self.dt * (1.0 - 1e-9)  # as _clamp_planar's
        accel = modules.accel
        snap = modules.snap
        self._bounds = None if accel is None else tuple(
            a * self.dt if snap == 0.0 else max(a * self.dt - 2.0 * snap, 0.5 * a * self.dt)
            for a in accel)

    @property
    def state(self) -> tuple[float, ...]:
        """The directions the faces start from (N, n, 2, C order): the rows' state."""
        return tuple(float(x) for x in np.ravel(self.limits.memory["directions"]))

    # -- prepare: the rows ------------------------------------------------------------

    def rows_move(self, size: int) -> tuple[bool, ...]:
        """Which of the ``size`` condensed rows move (each stage's speed faces, first)."""
        m, faces = self.limits.rows, self.wheels * FACES
        return tuple(row < self.horizon * m and row % m < faces for row in range(size))

    def rows(self, template: FloatArray, directions: ca.SX, guess: ca.SX
             ) -> tuple[ca.SX, ca.SX]:
        """The condensed limit rows with each module's faces turned to its velocity in
        ``guess`` (3 x N twists), as a sparse SX matrix (the faces' three entries
        structural, the rest ``template``'s nonzeros: ``Condenser.constraints``), and the
        directions after the turn (``directions``: before, ``2 n N``; a module slower than
        its floor keeps its direction)."""
        n, wheels, m = self.horizon, self.wheels, self.limits.rows
        faces = wheels * FACES
        blocks = self.robot.flat_wheel_blocks
        rows, cols, values = [], [], []
        turned = []
        for k in range(n):
            u = guess[:, k]
            for i in range(wheels):
                vx = blocks[2 * i, 0] * u[0] + blocks[2 * i, 1] * u[1] + blocks[2 * i, 2] * u[2]
                vy = (blocks[2 * i + 1, 0] * u[0] + blocks[2 * i + 1, 1] * u[1]
                      + blocks[2 * i + 1, 2] * u[2])
                length = ca.hypot(vx, vy)
                at = 2 * (k * wheels + i)
                moving = length > float(self._floor[i])
                cx = ca.if_else(moving, vx / length, directions[at])
                cy = ca.if_else(moving, vy / length, directions[at + 1])
                turned += [cx, cy]
                for j in range(FACES):
                    row = k * m + FACES * i + j
                    for c in range(3):
                        rows.append(row)
                        cols.append(3 * k + c)
                        values.append(cx * float(self._bases[i, 0, 3 * j + c])
                                      + cy * float(self._bases[i, 1, 3 * j + c]))
        template = np.asarray(template, dtype=float)
        for row, col in zip(*np.nonzero(template), strict=True):
            if row % m >= faces or row >= n * m:  # not a face row (the polygon's)
                rows.append(int(row))
                cols.append(int(col))
                values.append(ca.SX(float(template[row, col])))
        matrix = ca.SX.triplet(rows, cols, ca.vertcat(*values), *template.shape)
        return matrix, ca.vertcat(*turned)

    # -- finish: the fallback's feedforward, the clamp, the commands ---------------------

    def _velocity(self, i: int, tx: ca.SX, ty: ca.SX, tw: ca.SX) -> tuple[ca.SX, ca.SX]:
        a, b, c, d, e, f = self.modules.rows[i]
        return a * tx + b * ty + c * tw, d * tx + e * ty + f * tw

    def desaturated(self, twist: ca.SX) -> ca.SX:
        """:meth:`~mpc.robots.speed_checks.SpeedLimitChecks.desaturate`: ``twist`` scaled
        uniformly into the modules' speed disks (every limit > 0)."""
        ratios = []
        for i, limit in enumerate(self.modules.limits):
            x, y = self._velocity(i, twist[0], twist[1], twist[2])
            ratios.append(ca.sqrt(x * x + y * y) / limit)
        ratio = ca.mmax(ca.vertcat(*ratios))
        return twist * ca.if_else(ratio > 1.0, 1.0 / ratio, 1.0)

    def _fits(self, x: ca.SX, y: ca.SX, angle: ca.SX) -> ca.SX:
        """``_turn_fits``: a module at velocity (x, y) at rest, or within its reach."""
        moving = ca.hypot(x, y) * self.modules.radius > MOVING_MODULE_SPEED
        return ca.logic_or(ca.logic_not(moving),
                           ca.fabs(flip_turn(x, y, angle)) <= self._reach)

    def turn_fraction(self, last: ca.SX, target: ca.SX, steer: ca.SX) -> ca.SX:
        """:func:`~mpc.robots.wheels.swerve.limits.turn_fraction` (no axle offset: the
        robot's ``steering_fraction``) of the step from ``last`` to ``target`` with the
        modules at ``steer`` [rad]."""
        wheels = self.wheels
        starts, changes = [], []
        for i in range(wheels):
            starts.append(self._velocity(i, last[0], last[1], last[2]))
            changes.append(self._velocity(i, target[0] - last[0], target[1] - last[1],
                                          target[2] - last[2]))

        def fits(i: int, g: ca.SX | float) -> ca.SX:
            (sx, sy), (cx, cy) = starts[i], changes[i]
            return self._fits(sx + g * cx, sy + g * cy, steer[i])

        whole = _all([fits(i, 1.0) for i in range(wheels)])
        start = _all([fits(i, 0.0) for i in range(wheels)])
        slope = math.tan(self._reach * (1.0 - 1e-7))
        stopped = MOVING_MODULE_SPEED / self.modules.radius * (1.0 - 1e-6)
        fraction = ca.SX(1.0)
        for i in range(wheels):
            fraction = ca.fmin(fraction, self._module_fraction(
                starts[i], changes[i], steer[i], slope, stopped, lambda g, i=i: fits(i, g)))
        return ca.if_else(whole, 1.0, ca.if_else(start, fraction, 0.0))

    def _module_fraction(self, start: tuple[ca.SX, ca.SX], change: tuple[ca.SX, ca.SX],
                         angle: ca.SX, slope: float, stopped: float, fits: object) -> ca.SX:
        """One module's answer in :func:`turn_fraction`'s loop (1 where nothing breaks):
        its roots (``_turn_roots``) in (0, 1) sorted, the intervals between 0, them and 1
        walked in order with flags (an empty interval, a root met twice, skipped as the
        Python set skips it)."""
        (sx, sy), (cx, cy) = start, change
        ux, uy = ca.cos(angle), ca.sin(angle)
        c0, c1 = ux * sy - uy * sx, ux * cy - uy * cx
        d0, d1 = ux * sx + uy * sy, ux * cx + uy * cy
        candidates: list[tuple[ca.SX, ca.SX]] = []
        for sign in (1.0, -1.0):
            denominator = c1 - sign * slope * d1
            candidates.append(((sign * slope * d0 - c0) / denominator, denominator != 0.0))
        a = cx * cx + cy * cy
        b = 2.0 * (sx * cx + sy * cy)
        c = sx * sx + sy * sy - stopped * stopped
        discriminant = b * b - 4.0 * a * c
        real = ca.logic_and(a > 0.0, discriminant >= 0.0)
        root = ca.sqrt(discriminant)
        candidates += [((-b - root) / (2.0 * a), real), ((-b + root) / (2.0 * a), real)]
        points = []
        for value, valid in candidates:  # outside (0, 1) or not a root: 1 (a repeat)
            inside = ca.logic_and(ca.logic_and(valid, ca.fabs(value) < math.inf),
                                  ca.logic_and(value > 0.0, value < 1.0))
            points.append(ca.if_else(inside, value, 1.0))
        for p, q in ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2)):  # a sorting network
            points[p], points[q] = ca.fmin(points[p], points[q]), ca.fmax(points[p], points[q])
        points = [ca.SX(0.0), *points, ca.SX(1.0)]
        radius = self.modules.radius
        done, fraction = ca.SX(0), ca.SX(1.0)
        resting, rest = ca.SX(0), ca.SX(0.0)  # whether a stretch at rest began, where
        for low, high in zip(points[:-1], points[1:], strict=True):
            live = ca.logic_and(ca.logic_not(done), high > low)
            middle = 0.5 * (low + high)
            fits_middle = fits(middle)  # type: ignore[operator]
            fits_high = fits(high)  # type: ignore[operator]
            first = ca.logic_and(live, ca.logic_not(fits_middle))
            second = ca.logic_and(ca.logic_and(live, fits_middle), ca.logic_not(fits_high))
            fraction = ca.if_else(first, ca.if_else(resting, rest, low),
                                  ca.if_else(second, middle, fraction))
            done = ca.logic_or(done, ca.logic_or(first, second))
            go_on = ca.logic_and(live, ca.logic_not(ca.logic_or(first, second)))
            x, y = sx + middle * cx, sy + middle * cy
            at_rest = ca.logic_not(ca.hypot(x, y) * radius > MOVING_MODULE_SPEED)
            rest = ca.if_else(ca.logic_and(go_on, at_rest), ca.if_else(resting, rest, low),
                              rest)
            resting = ca.if_else(go_on, at_rest, resting)
        return fraction

    def _turn_step(self, last: ca.SX, aim: ca.SX, fraction: ca.SX, steer: ca.SX,
                   last_fits: ca.SX) -> ca.SX:
        """``_turn_step``: ``fraction`` of the step from ``last`` to ``aim``, or a stop
        (``last_fits``: no moving module of ``last`` turns past its reach)."""
        step = last + fraction * (aim - last)
        busy = ca.SX(0)
        if self._bounds is not None:
            busy = _any([ca.hypot(*self._velocity(i, last[0], last[1], last[2])) > bound
                         for i, bound in enumerate(self._bounds)])
        blocks = ca.DM(self.robot.flat_wheel_blocks)
        near = ca.sumsqr(blocks @ aim) < ca.sumsqr(blocks @ (step - aim))
        stop = ca.logic_or(ca.logic_and(fraction == 0.0, ca.logic_not(last_fits)), near)
        return ca.if_else(ca.logic_or(busy, ca.logic_not(stop)), step, ca.SX.zeros(3))

    def clamped(self, target: ca.SX, last: ca.SX, steer: ca.SX) -> tuple[ca.SX, ca.SX]:
        """``_clamp_planar``: ``target`` within every module's speed, acceleration and
        steering limit from ``last`` with the modules at ``steer`` [rad]; the twist and
        whether a step changed it."""
        modules = self.modules
        tx, ty, tw = target[0], target[1], target[2]
        lx, ly, lw = last[0], last[1], last[2]
        scale = ca.SX(math.inf)
        for i, (limit, extra) in enumerate(zip(modules.limits, modules.slack, strict=True)):
            speed = ca.hypot(*self._velocity(i, tx, ty, tw))
            scale = ca.if_else(speed - limit > extra, ca.fmin(scale, limit / speed), scale)
        over = scale < math.inf
        keep_speed = scale * (1.0 - SPEED_SLACK)
        tx, ty, tw = (ca.if_else(over, tx * keep_speed, tx), ca.if_else(over, ty * keep_speed, ty),
                      ca.if_else(over, tw * keep_speed, tw))
        scaled = ca.vertcat(tx, ty, tw)
        last_over = _any([ca.hypot(*self._velocity(i, lx, ly, lw)) - limit * (1 + 1e-9) > extra
                          for i, (limit, extra) in enumerate(zip(modules.limits, modules.slack,
                                                                 strict=True))])
        sx, sy, sw = tx - lx, ty - ly, tw - lw
        changed = over
        if self._bounds is not None:
            ratio = ca.mmax(ca.vertcat(*[ca.hypot(*self._velocity(i, sx, sy, sw)) / bound
                                         for i, bound in enumerate(self._bounds)]))
            limited = ratio > 1.0
            keep = (1.0 - SPEED_SLACK) / ratio
            tx = ca.if_else(limited, lx + keep * sx, tx)
            ty = ca.if_else(limited, ly + keep * sy, ty)
            tw = ca.if_else(limited, lw + keep * sw, tw)
            sx, sy, sw = tx - lx, ty - ly, tw - lw
            changed = ca.logic_or(changed, limited)
        stepped = ca.vertcat(tx, ty, tw)
        # the turn: a moving module past its reach at the target (velocities as
        # _clamp_planar forms them)
        turns = []
        starts = []
        for i in range(self.wheels):
            start = self._velocity(i, lx, ly, lw)
            change = self._velocity(i, sx, sy, sw)
            starts.append(start)
            vx, vy = start[0] + 1.0 * change[0], start[1] + 1.0 * change[1]
            moving = ca.hypot(vx, vy) * modules.radius > modules.moving
            turns.append(ca.logic_and(moving, ca.logic_not(
                ca.fabs(flip_turn(vx, vy, steer[i])) <= self._reach)))
        turning = _any(turns)
        fraction = self.turn_fraction(last, stepped, steer)
        last_fits = _all([self._fits(x, y, steer[i]) for i, (x, y) in enumerate(starts)])
        steered = ca.if_else(fraction < 1.0,
                             self._turn_step(last, stepped, fraction, steer, last_fits), stepped)
        twist = ca.if_else(last_over, scaled, ca.if_else(turning, steered, stepped))
        changed = ca.if_else(last_over, over, ca.logic_or(changed, turning))
        return twist, changed

    def commands(self, twist: ca.SX, aim: ca.SX, steer: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
        """What the modules are told for ``twist`` from angles ``steer`` [rad]
        (``SwerveRobot.wheel_commands`` with ``aim``, the target before the clamp): signed
        wheel speeds [rad/s], steer angles [rad] in (-pi, pi], and the twist they drive
        (the forward kinematics of the two)."""
        radius = self.modules.radius
        reach = self.modules.steer_rate * self.dt
        speeds, angles, velocities = [], [], []
        for i in range(self.wheels):
            present = steer[i]
            speed, angle = module_state(*self._velocity(i, twist[0], twist[1], twist[2]),
                                        present, radius)
            # aimed_angles: a module at rest turns towards its direction in the aim
            gx, gy = self._velocity(i, aim[0], aim[1], aim[2])
            turn = wrapped(ca.atan2(gy, gx) - present)
            turn = ca.if_else(ca.fabs(turn) > _HALF, turn - ca.sign(turn) * math.pi, turn)
            needed = ca.if_else(ca.hypot(gx, gy) * radius > MOVING_MODULE_SPEED,
                                ca.fabs(flip_turn(gx, gy, present)), 0.0)
            waiting = ca.logic_and(speed == 0.0, needed > 0.0)
            stepped = wrapped(present + ca.fmin(ca.fmax(turn, -reach), reach))
            angle = ca.if_else(waiting, stepped, angle)
            speeds.append(speed)
            angles.append(angle)
            velocities += [speed * ca.cos(angle), speed * ca.sin(angle)]
        driven = ca.DM(self._pinv) @ ca.vertcat(*velocities)
        return ca.vertcat(*speeds), ca.vertcat(*angles), driven
