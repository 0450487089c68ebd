"""Axle-offset swerve modules (Neobotix MPO-700: the ``mpo700`` preset) in the compiled
tick: the Python tick's steps for them as CasADi expressions, for :mod:`mpc.tick.graphs`
to put into ``finish``. Their QP rows are the constant polygon
(:meth:`SwerveRobot.stage_limits <mpc.robots.wheels.swerve.robot.SwerveRobot.stage_limits>`
with an axle offset: each side doubled with ``+-L omega``), so ``prepare`` is the
constant-rows one; the steer angles are state as for centred modules
(:mod:`mpc.tick.steered`).

- The fallback's feedforward: ``desaturate`` with the speed ``(|v_i| + L |omega|) / r``
  (:func:`~mpc.robots.wheels.swerve.axle.axle_speed_ratio`).
- The clamp (``finish``): :func:`~mpc.control.clamp.clamp_command`'s array steps
  (``_clamp_arrays``, ``_limit_step``: the speed scaling, the acceleration step, then
  :func:`~mpc.robots.wheels.swerve.limits.steering_fraction` and ``_turn_step``). The
  steering fraction is the centred modules' closed form (:class:`~mpc.tick.steered.Steering`)
  and then, where the drives' limit with the steering term ``L turn / (r dt)`` breaks at it,
  the Python search: the first round's 41 points over [0, fraction], then two more rounds of
  40 inside the first interval where a point fails, the earliest such interval taken (a
  reverse scan with flags instead of NumPy's ``flatnonzero``); the check at each point is
  one small function called there, not inlined (the generated C compiles about 7x quicker).
- The commands (``finish``): :meth:`SwerveRobot.wheel_commands
  <mpc.robots.wheels.swerve.robot.SwerveRobot.wheel_commands>` with an axle offset (the
  flip rule, modules at rest keep their angle, no aimed turn; the drive corrected by
  ``L (omega + turn / dt) / r``) and the twist they drive while steering
  (:func:`~mpc.robots.wheels.swerve.axle.axle_forward_kinematics`: its 3 x 3 normal
  equations by a Cholesky factor written out, as LAPACK's ``dposv`` solves them).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import SPEED_SLACK, PlanarModules
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.caster.robot import CasterRobot
from mpc.robots.wheels.swerve.limits import (
    _SEARCH_GRID,
    _SEARCH_ROUNDS,
    MOVING_MODULE_SPEED,
    STOPPED_MODULE_SPEED,
)
from mpc.robots.wheels.swerve.robot import SwerveRobot
from mpc.tick.casters import CasterSteering
from mpc.tick.steered import Steering, _all, _any, flip_turn, module_state, wrapped


def axle_modules(robot: SwerveRobot) -> PlanarModules:
    """The modules' rows and limits as Python floats (as
    :attr:`~mpc.robots.base.Robot.planar_modules` has them for centred modules, which an
    axle offset leaves None)."""
    n = robot.n_wheels
    accel = robot.max_wheel_accel
    return PlanarModules(
        tuple((a, b, c, d, e, f) for a, b, c, d, e, f in
              robot.wheel_blocks.reshape(n, 6).tolist()),
        tuple(robot.max_wheel_speed.tolist()), tuple(robot.speed_slack.tolist()),
        None if accel is None else tuple(np.asarray(accel, dtype=float).tolist()),
        robot.command_snap, robot.max_steer_rate, robot.wheel_radius, MOVING_MODULE_SPEED)


class AxleSteering(Steering):
    """The axle-offset parts of the tick's graphs for one robot and control tick (the
    interface of :class:`~mpc.tick.steered.Steering`; its rows do not move).

    Args:
        robot: the swerve robot with ``axle_offset > 0`` (no steering range, failed module
            or motor model: :func:`mpc.tick.support.check_supported`).
        modules: :func:`axle_modules` of it.
        change_times: the model's stage changes [s].
        dt: the control tick [s].
    """

    #: The rows are the constant polygon: ``prepare`` gives no row values.
    moves = False

    def __init__(self, robot: SwerveRobot, modules: PlanarModules, change_times: FloatArray,
                 dt: float) -> None:
        self.robot, self.modules, self.dt = robot, modules, float(dt)
        #: The constant polygon rows (Robot.stage_limits with the default sides).
        self.limits: StageLimits = robot.stage_limits(change_times, None)
        self.wheels = robot.n_wheels
        self.horizon = len(change_times)
        self._lever = robot.axle_offset / robot.wheel_radius  # [rad/s per rad/s]
        self._reach = modules.steer_rate * self.dt * (1.0 - 1e-9)  # as _reach
        accel = modules.accel
        snap = modules.snap
        self._bounds = None if accel is None else tuple(
            a * self.dt if snap == 0.0 else max(a * self.dt - 2.0 * snap, 0.5 * a * self.dt)
            for a in accel)
        self._blocks = robot.flat_wheel_blocks

    @property
    def state(self) -> tuple[float, ...]:
        """No rows' state (the rows are constant)."""
        return ()

    # -- the speed with the axle offset ---------------------------------------------------

    def _magnitudes(self, tx: ca.SX, ty: ca.SX, tw: ca.SX) -> list[ca.SX]:
        """``wheel_magnitudes``: ``|v_i| / r + L |omega| / r`` a module [rad/s]."""
        spin = self.robot.axle_offset * ca.fabs(tw) / self.modules.radius  # (as NumPy's)
        return [ca.hypot(*self._velocity(i, tx, ty, tw)) + spin for i in range(self.wheels)]

    def desaturated(self, twist: ca.SX) -> ca.SX:
        """``desaturate`` with :func:`~mpc.robots.wheels.swerve.axle.axle_speed_ratio`."""
        ratios = []
        spin = self.robot.axle_offset * ca.fabs(twist[2]) / self.modules.radius
        for i, limit in enumerate(self.modules.limits):
            x, y = self._velocity(i, twist[0], twist[1], twist[2])
            ratios.append((ca.sqrt(x * x + y * y) + spin) / limit)
        ratio = ca.mmax(ca.vertcat(*ratios))
        return twist * ca.if_else(ratio > 1.0, 1.0 / ratio, 1.0)

    # -- the steering fraction's search (steering_fraction with an axle offset) -----------

    def _drives_fit(self, twist: tuple[ca.SX, ca.SX, ca.SX], steer: ca.SX) -> ca.SX:
        """``_drives_fit``: every module's drive rate (the steering term and ``L omega``
        in) within its limit and every moving module's turn within its reach."""
        u0, u1, u2 = twist
        radius, lever = self.modules.radius, self._lever
        fits = []
        for i, limit in enumerate(self.modules.limits):
            x, y = self._velocity(i, u0, u1, u2)
            angle = steer[i]
            turn = flip_turn(x, y, angle)
            magnitude = ca.hypot(x, y)
            ground = magnitude * radius
            speed = ca.copysign(magnitude, x * ca.cos(angle) + y * ca.sin(angle))
            speed = speed + (lever / self.dt) * turn
            drive = ca.if_else(ground < STOPPED_MODULE_SPEED, 0.0, speed) + lever * u2
            fits.append(ca.logic_and(ca.fabs(drive) <= limit * (1.0 + 1e-12),
                                     ca.logic_or(ca.fabs(turn) <= self._reach,
                                                 ground <= MOVING_MODULE_SPEED)))
        return _all(fits)

    def _fits_at(self, last: ca.SX, step: tuple[ca.SX, ca.SX, ca.SX], part: ca.SX,
                 steer: ca.SX) -> ca.SX:
        """:meth:`_drives_fit` at ``last + part * step`` (as ``within`` forms the points),
        through :attr:`_fit`: one small function called at each of the search's points
        (not inlined: the library compiles in a fraction of the time)."""
        point = ca.vertcat(*[last[c] + part * step[c] for c in range(3)])
        return self._fit(point, steer)

    @property
    def _fit(self) -> ca.Function:
        """:meth:`_drives_fit` as a function ``(twist 3, steer n) -> fits``, built once."""
        fit = getattr(self, "_fit_function", None)
        if fit is None:
            twist, steer = ca.SX.sym("twist", 3), ca.SX.sym("steer", self.wheels)
            fit = ca.Function("mpc_tick_drives_fit", [twist, steer],
                              [self._drives_fit((twist[0], twist[1], twist[2]), steer)],
                              {"never_inline": True, "cse": True})
            self._fit_function = fit
        return fit

    def steering_fraction(self, last: ca.SX, target: ca.SX, steer: ca.SX) -> ca.SX:
        """:func:`~mpc.robots.wheels.swerve.limits.steering_fraction` with an axle offset."""
        fraction = self.turn_fraction(last, target, steer)
        step = (target[0] - last[0], target[1] - last[1], target[2] - last[2])
        grid = [float(g) for g in _SEARCH_GRID]
        fits_fraction = self._drives_fit(tuple(last[c] + fraction * step[c]  # type: ignore[arg-type]
                                               for c in range(3)), steer)
        first = [fraction * g for g in grid]  # parts[0] = 0: the start
        first_fits = [self._fits_at(last, step, part, steer) for part in first]
        # the rounds: the earliest failing point's interval (low, high), or done at high
        low, high = ca.SX(0.0), fraction
        done, answer = ca.SX(0), ca.SX(0.0)
        for round_ in range(_SEARCH_ROUNDS):
            if round_:
                parts = [low + (high - low) * g for g in grid]
                fits = [self._fits_at(last, step, part, steer) for part in parts[1:]]
            else:
                parts, fits = first, first_fits[1:]
            found, new_low, new_high = ca.SX(0), low, high
            for j in range(len(fits) - 1, -1, -1):  # the earliest failing point wins
                bad = ca.logic_not(fits[j])
                found = ca.logic_or(found, bad)
                new_low = ca.if_else(bad, parts[j], new_low)
                new_high = ca.if_else(bad, parts[j + 1], new_high)
            answer = ca.if_else(ca.logic_and(ca.logic_not(done), ca.logic_not(found)), high,
                                answer)
            done = ca.logic_or(done, ca.logic_not(found))
            low, high = new_low, new_high
        searched = ca.if_else(done, answer, low)
        searched = ca.if_else(first_fits[-1], fraction,
                              ca.if_else(ca.logic_not(first_fits[0]), 0.0, searched))
        return ca.if_else(ca.logic_or(fraction == 0.0, fits_fraction), fraction, searched)

    # -- the clamp (clamp_command's array steps) -----------------------------------------

    def _turn_step(self, last: ca.SX, aim: ca.SX, fraction: ca.SX, steer: ca.SX,
                   last_fits: ca.SX) -> ca.SX:
        """``_turn_step``: ``fraction`` of the step from ``last`` to ``aim``, or a stop
        (``last_fits``: ``steering_fraction(last, last)`` is 1)."""
        step = last + fraction * (aim - last)
        busy = ca.SX(0)
        if self._bounds is not None:
            busy = _any([magnitude > bound for magnitude, bound in zip(
                self._magnitudes(last[0], last[1], last[2]), self._bounds, strict=True)])
        blocks = ca.DM(self._blocks)
        near = ca.sumsqr(blocks @ aim) < ca.sumsqr(blocks @ (step - aim))
        stop = ca.logic_or(ca.logic_and(fraction == 0.0, ca.logic_not(last_fits)), near)
        return ca.if_else(ca.logic_or(busy, ca.logic_not(stop)), step, ca.SX.zeros(3))

    def clamped(self, target: ca.SX, last: ca.SX, steer: ca.SX) -> tuple[ca.SX, ca.SX]:
        """``_clamp_arrays`` and ``_limit_step``: ``target`` within every module's speed
        (``(|v_i| + L |omega|) / r``), acceleration and steering limit from ``last`` with
        the modules at ``steer`` [rad]; the twist and whether a step may have changed it."""
        modules = self.modules
        speeds = self._magnitudes(target[0], target[1], target[2])
        scale = ca.SX(math.inf)
        for speed, limit, extra in zip(speeds, modules.limits, modules.slack, strict=True):
            scale = ca.if_else(speed - limit > extra, ca.fmin(scale, limit / speed), scale)
        over = scale < math.inf
        safe = ca.if_else(over, target * scale * (1.0 - SPEED_SLACK), target)
        last_over = _any([speed - limit * (1 + 1e-9) > extra for speed, limit, extra in zip(
            self._magnitudes(last[0], last[1], last[2]), modules.limits, modules.slack,
            strict=True)])
        stepped = safe
        if self._bounds is not None:
            step = safe - last
            ratio = ca.mmax(ca.vertcat(*[magnitude / bound for magnitude, bound in zip(
                self._magnitudes(step[0], step[1], step[2]), self._bounds, strict=True)]))
            stepped = ca.if_else(ratio > 1.0, last + (1.0 - SPEED_SLACK) / ratio * step, safe)
        fraction = self.steering_fraction(last, stepped, steer)
        last_fits = self._drives_fit((last[0], last[1], last[2]), steer)
        turned = ca.if_else(fraction < 1.0,
                            self._turn_step(last, stepped, fraction, steer, last_fits), stepped)
        return ca.if_else(last_over, safe, turned), ca.SX(1)

    # -- the commands -----------------------------------------------------------------------

    def commands(self, twist: ca.SX, aim: ca.SX, steer: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
        """``SwerveRobot.wheel_commands`` with an axle offset (no aimed turn) and the twist
        the modules drive while steering (``steering_forward_kinematics``): signed wheel
        speeds [rad/s], steer angles [rad] in (-pi, pi], the twist."""
        radius, lever = self.modules.radius, self.robot.axle_offset
        speeds, angles = [], []
        for i in range(self.wheels):
            present = steer[i]
            speed, angle = module_state(*self._velocity(i, twist[0], twist[1], twist[2]),
                                        present, radius)
            turning = wrapped(angle - present) / self.dt
            speeds.append(speed + lever * (twist[2] + turning) / radius)
            angles.append(angle)
        # the twist they drive (wheel_output: the turn a tick, NumPy's modulo, not wrap_angle)
        rates = [(_mod(angles[i] - steer[i] + math.pi, 2.0 * math.pi) - math.pi) / self.dt
                 for i in range(self.wheels)]
        driven = self._forward(speeds, angles, rates)
        return ca.vertcat(*speeds), ca.vertcat(*angles), driven

    def _forward(self, speeds: list[ca.SX], angles: list[ca.SX], rates: list[ca.SX]) -> ca.SX:
        """:func:`~mpc.robots.wheels.swerve.axle.axle_forward_kinematics`: the normal
        equations ``(R'R) xi = R_roll' rolling`` solved by their Cholesky factor."""
        lever = self.robot.axle_offset
        ground = self.robot.ground_maps()  # (n, 2, 3)
        rows = []
        rolling = []
        for i in range(self.wheels):
            c, s = ca.cos(angles[i]), ca.sin(angles[i])
            along = [c * float(ground[i, 0, j]) + s * float(ground[i, 1, j]) for j in range(3)]
            along[2] = along[2] + lever
            across = [-s * float(ground[i, 0, j]) + c * float(ground[i, 1, j])
                      for j in range(3)]
            rows += [along, across]
            rolling.append(self.robot.wheel_radius * speeds[i] - lever * rates[i])
        gram = [[sum((row[a] * row[b] for row in rows[1:]), rows[0][a] * rows[0][b])
                 for b in range(3)] for a in range(3)]
        right = [sum((rows[2 * i][a] * rolling[i] for i in range(1, self.wheels)),
                     rows[0][a] * rolling[0]) for a in range(3)]
        return _cholesky_solve(gram, right)


def _mod(a: ca.SX, b: float) -> ca.SX:
    """NumPy's ``np.mod(a, b)`` for ``b > 0`` (the result in [0, b))."""
    m = ca.fmod(a, b)
    return ca.if_else(m < 0, m + b, m)


def _cholesky_solve(a: list[list[ca.SX]], b: list[ca.SX]) -> ca.SX:
    """``a x = b`` for a symmetric positive definite 3 x 3 ``a`` (LAPACK's ``dposv``:
    ``a = L L'``, then the two triangular solves)."""
    n = len(b)
    low = [[ca.SX(0.0)] * n for _ in range(n)]
    for j in range(n):
        pivot = a[j][j] - sum((low[j][k] * low[j][k] for k in range(j)), ca.SX(0.0))
        low[j][j] = ca.sqrt(pivot)
        for i in range(j + 1, n):
            value = a[i][j] - sum((low[i][k] * low[j][k] for k in range(j)), ca.SX(0.0))
            low[i][j] = value / low[j][j]
    y: list[ca.SX] = []
    for i in range(n):
        y.append((b[i] - sum((low[i][k] * y[k] for k in range(i)), ca.SX(0.0))) / low[i][i])
    x: list[ca.SX] = [ca.SX(0.0)] * n
    for i in range(n - 1, -1, -1):
        x[i] = (y[i] - sum((low[k][i] * x[k] for k in range(i + 1, n)), ca.SX(0.0))) / low[i][i]
    return ca.vertcat(*x)


def steering_for(robot: object, modules: PlanarModules, change_times: FloatArray,
                 dt: float) -> Steering:
    """The steered parts of the tick's graphs: :class:`AxleSteering` for axle-offset
    modules, :class:`~mpc.tick.casters.CasterSteering` for casters, else
    :class:`~mpc.tick.steered.Steering`."""
    if isinstance(robot, CasterRobot):
        return CasterSteering(robot, modules, change_times, dt)  # type: ignore[return-value]
    if isinstance(robot, SwerveRobot) and robot.axle_offset:
        return AxleSteering(robot, modules, change_times, dt)
    return Steering(robot, modules, change_times, dt)  # type: ignore[arg-type]
