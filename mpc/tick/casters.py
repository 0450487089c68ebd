"""Powered offset casters (:mod:`mpc.robots.wheels.caster`, the ``caster4`` preset) in the
compiled tick: the Python tick's caster steps as CasADi expressions, for
:mod:`mpc.tick.graphs` to put into ``prepare`` and ``finish``.

A caster's steer angle is a state of the robot: each tick takes the measured angles
(``Controller.step(pose, t, steer_angles)``; in C ``mpc_tick_set_steer_angles`` before
``mpc_tick_step``), as the swerve slice takes its angles (:mod:`mpc.tick.steered`).

- The rows (``prepare``): every stage's drive rows ``D(beta_k)`` and steer rows
  ``S(beta_k)`` (:func:`~mpc.robots.wheels.caster.limits.joint_rows`) at the angles the
  guess's twists turn the casters through from the measured ones
  (:func:`~mpc.robots.wheels.caster.limits.update_stage_limits`: the robot's own RK4
  prediction, its CasADi function called in the graph). They move every tick: ``rows``,
  whitened every tick as swerve's faces and a motor model's rows are.
- The fallback's feedforward: ``desaturate`` with the trailing drive rate ``|v(P)| / r``.
- The clamp (``finish``): :func:`~mpc.robots.wheels.caster.limits.clamp_at` at the measured
  angles (the target if within every joint limit, else the largest step from the last
  command, else the target scaled into the limits).
- The commands (``finish``): :func:`~mpc.control.wheel_output.tick_rates` (the angle flow
  over the tick in two halves by the robot's RK4, the drive rates its Simpson average, the
  steer rates the flow's end over the tick, both scaled into the limits together); the
  steer angles out are ``measured + rates dt``, as the Python tick believes them.

Not covered (refused by :func:`mpc.tick.support.check_supported`): casters with an
acceleration limit (their rows on ``u_{k-1}`` move with the angles too, and stage 0's
shift by the last command with them).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import PlanarModules
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.caster import limits as caster_limits
from mpc.robots.wheels.caster.robot import CasterRobot

#: clamp_at's relative slack (rounding), and the step's share kept a hair inside.
_SLACK = caster_limits._SLACK


def caster_modules(robot: CasterRobot) -> PlanarModules:
    """The casters' axis rows and drive limits in the shape the tick's graphs dispatch on
    (:class:`~mpc.robots.base.PlanarModules`; :class:`CasterSteering` reads the robot)."""
    n = robot.n_wheels
    return PlanarModules(
        tuple((a, b, c, d, e, f) for a, b, c, d, e, f in
              robot.wheel_blocks.reshape(n, 6).tolist()),
        tuple(robot.max_wheel_speed.tolist()), tuple(robot.speed_slack.tolist()), None, 0.0,
        float(robot.max_steer_rates.max()), float(robot.radii.max()), 0.0)


class CasterSteering:
    """The caster parts of the tick's graphs for one robot and control tick (the interface
    of :class:`~mpc.tick.steered.Steering`; its rows take the measured angles).

    Args:
        robot: the caster robot (no acceleration limit, no motor model:
            :func:`mpc.tick.support.check_supported`).
        modules: :func:`caster_modules` of it.
        change_times: the model's stage changes [s].
        dt: the control tick [s].
    """

    #: The rows move every tick (the angles along the guess).
    moves = True
    #: ``rows`` takes the measured steer angles.
    measured = True

    def __init__(self, robot: CasterRobot, modules: PlanarModules, change_times: FloatArray,
                 dt: float) -> None:
        self.robot, self.modules, self.dt = robot, modules, float(dt)
        #: The rows a stage: n drive rows, then n steer rows (filled at zero angles).
        self.limits: StageLimits = caster_limits.stage_limits(robot, change_times)
        self.wheels = robot.n_wheels
        self.horizon = len(change_times)
        durations = tuple(float(h) for h in self.limits.memory["durations"])
        #: The angles along a plan (the Python tick's own function), None for N = 1.
        self._along = (caster_limits._predictor(robot, durations).function if durations
                       else None)
        half = 0.5 * self.dt  # (wheel_output._tick_halves)
        self._over_tick = caster_limits._predictor(robot, (half, half)).function

    @property
    def state(self) -> tuple[float, ...]:
        """No rows' state (the angles are measured)."""
        return ()

    def rows_move(self, size: int) -> tuple[bool, ...]:
        """Every one of the ``size`` condensed rows moves with the angles."""
        return (True,) * size

    # -- prepare: the rows ------------------------------------------------------------

    def _drive_steer(self, angle: ca.SX, i: int) -> tuple[list[ca.SX], list[ca.SX]]:
        """Caster ``i``'s drive and steer rows at ``angle`` (``joint_rows``' arithmetic)."""
        px, py = (float(v) for v in np.asarray(self.robot.caster_positions)[i])
        d, r = float(self.robot.offsets[i]), float(self.robot.radii[i])
        c, s = ca.cos(angle), ca.sin(angle)
        return ([c / r, s / r, (px * s - py * c) / r],
                [-s / d, c / d, (px * c + py * s - d) / d])

    def rows(self, template: FloatArray, state: ca.SX, guess: ca.SX,
             steer: ca.SX) -> tuple[ca.SX, ca.SX]:
        """The condensed limit rows at the angles the guess (3 x N twists) turns the
        casters through from the measured ``steer`` [rad] (every row's three entries
        structural), and the (empty) next state; checked against ``template`` (the rows at
        zero angles) when built."""
        n, wheels = self.horizon, self.wheels
        if self._along is None:
            angles = ca.reshape(steer, wheels, 1)
        else:
            angles = self._along(steer, guess[:, :n - 1])  # (wheels x N)
        template = np.asarray(template, dtype=float)
        at_zero = ca.evalf(self._matrix(ca.SX.zeros(wheels, n), template.shape))
        if np.abs(np.asarray(ca.densify(at_zero)) - template).max() > 1e-12:
            raise RuntimeError("the caster rows' layout differs from the condensed rows'")
        matrix = self._matrix(angles, template.shape)
        return matrix, state

    def _matrix(self, angles: ca.SX, shape: tuple[int, int]) -> ca.SX:
        """The condensed rows (``shape``) at the angles (wheels x N): stage k's drive rows,
        then its steer rows, on ``u_k``."""
        n, wheels, m = self.horizon, self.wheels, self.limits.rows
        rows, cols, values = [], [], []
        for k in range(n):
            for i in range(wheels):
                drive, turn = self._drive_steer(angles[i, k], i)
                for offset, row in ((0, drive), (wheels, turn)):
                    for c in range(3):
                        rows.append(k * m + offset + i)
                        cols.append(3 * k + c)
                        values.append(row[c])
        return ca.SX.triplet(rows, cols, ca.vertcat(*values), *shape)

    # -- finish: the fallback's feedforward, the clamp, the commands ---------------------

    def _joint_rows(self, steer: ca.SX) -> tuple[list[list[ca.SX]], list[list[ca.SX]]]:
        pairs = [self._drive_steer(steer[i], i) for i in range(self.wheels)]
        return [drive for drive, _ in pairs], [turn for _, turn in pairs]

    def desaturated(self, twist: ca.SX) -> ca.SX:
        """``desaturate``: ``twist`` scaled uniformly into the trailing drive rates'
        limits ``|v(P)| / r <= max_wheel_speed``."""
        ratios = []
        for (a, b, c, d, e, f), limit in zip(self.modules.rows, self.modules.limits,
                                             strict=True):
            x = a * twist[0] + b * twist[1] + c * twist[2]
            y = d * twist[0] + e * twist[1] + f * twist[2]
            ratios.append(ca.sqrt(x * x + y * y) / limit)
        ratio = ca.mmax(ca.vertcat(*ratios))
        return twist * ca.if_else(ratio > 1.0, 1.0 / ratio, 1.0)

    def clamped(self, target: ca.SX, last: ca.SX, steer: ca.SX) -> tuple[ca.SX, ca.SX]:
        """:func:`~mpc.robots.wheels.caster.limits.clamp_at`: ``target`` within every drive
        and steer rate limit at the measured angles ``steer`` [rad]; the twist and whether
        it may have changed."""
        drive, turn = self._joint_rows(steer)
        rows = drive + turn
        bound = list(self.robot.max_wheel_speed) + list(self.robot.max_steer_rates)
        bound = [float(b) for b in bound]

        def times(row: list[ca.SX], twist: ca.SX | list[ca.SX]) -> ca.SX:
            return row[0] * twist[0] + row[1] * twist[1] + row[2] * twist[2]

        value = [times(row, target) for row in rows]
        tolerance = [b * _SLACK + 1e-12 for b in bound]
        inside = _all([ca.fabs(v) <= b + t for v, b, t in zip(value, bound, tolerance,
                                                               strict=True)])
        step = target - last
        start = [times(row, last) for row in rows]
        start_inside = _all([ca.fabs(v) <= b + t for v, b, t in zip(start, bound, tolerance,
                                                                     strict=True)])
        rate = [times(row, step) for row in rows]
        fraction = _largest_fraction(start, rate, bound)
        stepped = last + fraction * (1.0 - _SLACK) * step
        ratios = [ca.if_else(ca.fabs(v) > 1e-12, b / ca.fabs(v), math.inf)
                  for v, b in zip(value, bound, strict=True)]
        scaled = target * ca.fmin(1.0, ca.mmin(ca.vertcat(*ratios))) * (1.0 - _SLACK)
        twist = ca.if_else(inside, target, ca.if_else(start_inside, stepped, scaled))
        return twist, ca.logic_not(inside)

    def commands(self, twist: ca.SX, aim: ca.SX, steer: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
        """:func:`~mpc.control.wheel_output.tick_rates` from the measured angles ``steer``:
        drive rates [rad/s], the steer angles ``steer + rates dt`` [rad], the twist (as
        given: the casters' commands drive it)."""
        flow = self._over_tick(steer, ca.repmat(twist, 1, 2))  # (wheels x 3)
        drive, rates = [], []
        for i in range(self.wheels):
            at = [self._drive_steer(flow[i, j], i)[0] for j in range(3)]
            values = [row[0] * twist[0] + row[1] * twist[1] + row[2] * twist[2] for row in at]
            drive.append((values[0] + 4.0 * values[1] + values[2]) / 6.0)
            rates.append((flow[i, 2] - flow[i, 0]) / self.dt)
        bound = ([float(b) for b in self.robot.max_wheel_speed]
                 + [float(b) for b in self.robot.max_steer_rates])
        scale = ca.SX(math.inf)
        for value, limit in zip(drive + rates, bound, strict=True):
            magnitude = ca.fabs(value)
            scale = ca.if_else(magnitude > limit, ca.fmin(scale, limit / magnitude), scale)
        over = scale < math.inf
        drive = [ca.if_else(over, value * scale, value) for value in drive]
        rates = [ca.if_else(over, value * scale, value) for value in rates]
        angles = [steer[i] + rates[i] * self.dt for i in range(self.wheels)]
        return ca.vertcat(*drive), ca.vertcat(*angles), twist


def _all(values: list[ca.SX]) -> ca.SX:
    out = ca.SX(1)
    for value in values:
        out = ca.logic_and(out, value)
    return out


def _largest_fraction(start: list[ca.SX], rate: list[ca.SX], bound: list[float]) -> ca.SX:
    """``_largest_fraction``: the largest ``f`` in [0, 1] with ``|start + f rate| <=
    bound``."""
    fraction = ca.SX(1.0)
    for s, v, b in zip(start, rate, bound, strict=True):
        up = ca.if_else(v > 1e-15, (b - s) / v, math.inf)
        down = ca.if_else(v < -1e-15, (-b - s) / v, math.inf)
        fraction = ca.fmin(fraction, ca.fmin(up, down))
    return ca.fmax(0.0, fraction)
