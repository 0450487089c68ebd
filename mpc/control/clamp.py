"""The last line of safety: every command within every wheel's speed and acceleration limit.

Wheel ``i``'s speed for a twist is ``||W_i twist||`` (the robot's
:meth:`~mpc.robots.Robot.wheel_magnitudes`); its acceleration over a tick is
the same measure of the twist's change. Both sets are convex in the twist,
which the clamp relies on.
"""

from __future__ import annotations

import math

import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import SPEED_SLACK, PlanarModules, Robot, ScalarWheels
from mpc.robots.drive.motor_step import motor_step_fraction
from mpc.robots.wheels.swerve.limits import flip_turn

#: Passes of the motor step: each takes the Coriolis term of the step the last one left.
_MOTOR_PASSES = 4


def clamp_command(
    robot: Robot, target: FloatArray, last: FloatArray, dt: float,
    steer_angles: FloatArray | None = None,
) -> tuple[FloatArray, bool]:
    """Bring ``target`` within every wheel limit, moving it as little as the rules allow.

    1. Speed: project out any motion of a failed wheel (limit 0), then
       scale ``target`` uniformly into the speed limits (a solver's output
       is off by its tolerance at most, so this is a tiny scaling).
    2. Acceleration: step from ``last`` towards that twist only as far as
       every wheel's acceleration limit allows. Both ends lie in the convex
       speed-limit set, so the whole step does too.

    3. Motors (robots with dynamics): step from ``last`` only as far as every wheel stays
       within its battery voltage and current limit and every contact within traction,
       the wheels turning at ``last``'s speeds now
       (:func:`~mpc.robots.drive.motor_step.motor_step_fraction`).
    4. Steering (steered wheels, given their present ``steer_angles``): step from
       ``last`` only as far as no wheel turns faster than its steering rate
       (:meth:`~mpc.robots.Robot.steering_fraction`); a wheel that must turn
       before it can drive waits at rest while it turns. Robots with dynamics, whose
       wheel loops ramp the step over the tick, also no faster anywhere along that ramp
       (:meth:`~mpc.robots.Robot.ramp_turn_fraction`).

    Robots whose limits depend on measured steer angles (casters) clamp at those angles
    themselves (:meth:`~mpc.robots.Robot.clamp_joints`) instead of steps 1-3. Robots with
    :attr:`~mpc.robots.Robot.scalar_wheels` take steps 1 and 2 in plain Python (the same
    arithmetic, wheel by wheel), robots with :attr:`~mpc.robots.Robot.planar_modules` steps
    1, 2 and 4 (step 4's search, when a module would turn too far, in NumPy).

    Returns the clamped twist and whether it differs from ``target``. If
    ``last`` itself breaks a speed limit (the limits were just derated),
    acceleration and motor limits cannot be honoured as well; the speed limits win.
    """
    if steer_angles is not None:
        own = robot.clamp_joints(target, last, dt, steer_angles)  # casters: at these angles
        if own is not None:
            return own, bool(own is not target and not np.array_equal(own, target))
        if robot.planar_modules is not None:
            return _clamp_planar(robot, robot.planar_modules, target, last, dt, steer_angles)
    elif robot.scalar_wheels is not None:
        return _clamp_scalar(robot.scalar_wheels, target, last, dt)
    return _clamp_arrays(robot, target, last, dt, steer_angles)


def _clamp_arrays(robot: Robot, target: FloatArray, last: FloatArray, dt: float,
                  steer_angles: FloatArray | None) -> tuple[FloatArray, bool]:
    """Steps 1-4 of :func:`clamp_command` in NumPy (any robot)."""
    safe = target
    if robot.rest_projector is not None:
        safe = robot.rest_projector @ safe
    limit = robot.max_wheel_speed
    speed = robot.wheel_magnitudes(safe)
    over = speed - limit > robot.speed_slack  # beyond rounding
    if over.any():
        # The smallest limit / speed over the wheels; a failed wheel (limit 0) stops the robot.
        safe = safe * (limit[over] / speed[over]).min() * (1.0 - SPEED_SLACK)
    safe = _limit_step(robot, safe, last, dt, steer_angles, limit)
    return safe, bool(safe is not target and not np.array_equal(safe, target))


def _clamp_scalar(wheels: ScalarWheels, target: FloatArray, last: FloatArray,
                  dt: float) -> tuple[FloatArray, bool]:
    """Steps 1 and 2 of :func:`clamp_command` for wheels with scalar speeds, in Python
    floats (``target`` itself returned when it is within every limit)."""
    tx, ty, tw = target.tolist()
    lx, ly, lw = last.tolist()
    rows, limits, slack = wheels.rows, wheels.limits, wheels.slack
    scale = _speed_scale([abs(a * tx + b * ty + c * tw) for a, b, c in rows], limits, slack)
    changed = scale < math.inf
    if changed:
        tx, ty, tw = _scaled(tx, ty, tw, scale)
    accel = wheels.accel
    # A last command beyond the speed limits (the limits were just derated): see _limit_step.
    if accel is not None and not any(
            abs(a * lx + b * ly + c * lw) - limit * (1 + 1e-9) > extra
            for (a, b, c), limit, extra in zip(rows, limits, slack, strict=True)):
        sx, sy, sw = tx - lx, ty - ly, tw - lw
        ratio = max(abs(a * sx + b * sy + c * sw) / (limit * dt)
                    for (a, b, c), limit in zip(rows, accel, strict=True))
        if ratio > 1.0:
            keep = (1.0 - SPEED_SLACK) / ratio
            tx, ty, tw = lx + keep * sx, ly + keep * sy, lw + keep * sw
            changed = True
    return _float_result(target, tx, ty, tw, changed)


def _clamp_planar(robot: Robot, modules: PlanarModules, target: FloatArray,
                  last: FloatArray, dt: float, steer_angles: FloatArray
                  ) -> tuple[FloatArray, bool]:
    """Steps 1, 2 and 4 of :func:`clamp_command` for steered modules whose speed is their
    velocity's length, in Python floats (as :func:`_clamp_arrays` takes them: the speed
    scaling, the acceleration step with ``command_snap`` kept at each end, then the turn:
    whole if no moving module turns past ``max_steer_rate dt``, else the robot's
    :meth:`~mpc.robots.Robot.steering_fraction` search)."""
    tx, ty, tw = target.tolist()
    lx, ly, lw = last.tolist()
    rows, limits, slack = modules.rows, modules.limits, modules.slack
    scale = _speed_scale([math.hypot(a * tx + b * ty + c * tw, d * tx + e * ty + f * tw)
                          for a, b, c, d, e, f in rows], limits, slack)
    changed = scale < math.inf
    if changed:
        tx, ty, tw = _scaled(tx, ty, tw, scale)
    if any(math.hypot(a * lx + b * ly + c * lw, d * lx + e * ly + f * lw)
           - limit * (1 + 1e-9) > extra
           for (a, b, c, d, e, f), limit, extra in zip(rows, limits, slack, strict=True)):
        return _float_result(target, tx, ty, tw, changed)  # the speed limits win
    sx, sy, sw = tx - lx, ty - ly, tw - lw
    if modules.accel is not None:
        snap = modules.snap
        ratio = max(
            math.hypot(a * sx + b * sy + c * sw, d * sx + e * sy + f * sw)
            / (accel * dt if snap == 0.0 else max(accel * dt - 2.0 * snap, 0.5 * accel * dt))
            for (a, b, c, d, e, f), accel in zip(rows, modules.accel, strict=True))
        if ratio > 1.0:
            keep = (1.0 - SPEED_SLACK) / ratio
            tx, ty, tw = lx + keep * sx, ly + keep * sy, lw + keep * sw
            sx, sy, sw = tx - lx, ty - ly, tw - lw
            changed = True
    # The turn: every moving module within its reach of its present angle at the target
    # (the velocities as turn_fraction forms them, from last plus the whole change).
    reach = modules.steer_rate * dt * (1.0 - 1e-9)
    for (a, b, c, d, e, f), angle in zip(rows, steer_angles.tolist(), strict=True):
        vx = (a * lx + b * ly + c * lw) + 1.0 * (a * sx + b * sy + c * sw)
        vy = (d * lx + e * ly + f * lw) + 1.0 * (d * sx + e * sy + f * sw)
        if (math.hypot(vx, vy) * modules.radius > modules.moving
                and not abs(flip_turn(vx, vy, angle)) <= reach):
            safe = np.array((tx, ty, tw))
            fraction = robot.steering_fraction(last, safe, steer_angles, dt)
            if fraction < 1.0:
                safe = _turn_step(robot, last, safe, fraction, steer_angles, dt)
            return safe, bool(not np.array_equal(safe, target))
    return _float_result(target, tx, ty, tw, changed)


def _speed_scale(speeds: list[float], limits: tuple[float, ...],
                 slack: tuple[float, ...]) -> float:
    """Step 1's factor: the smallest limit / speed over the wheels above their limits by
    more than their rounding slack (inf when none is)."""
    scale = math.inf
    for speed, limit, extra in zip(speeds, limits, slack, strict=True):
        if speed - limit > extra:
            scale = min(scale, limit / speed)
    return scale


def _scaled(tx: float, ty: float, tw: float, scale: float) -> tuple[float, float, float]:
    """The twist scaled into the speed limits (as the array clamp scales it)."""
    return (tx * scale * (1.0 - SPEED_SLACK), ty * scale * (1.0 - SPEED_SLACK),
            tw * scale * (1.0 - SPEED_SLACK))


def _float_result(target: FloatArray, tx: float, ty: float, tw: float,
                  changed: bool) -> tuple[FloatArray, bool]:
    """``target`` itself if unchanged, else the new twist and whether it differs."""
    if not changed:
        return target, False
    safe = np.array((tx, ty, tw))
    return safe, bool(not np.array_equal(safe, target))


def _limit_step(robot: Robot, safe: FloatArray, last: FloatArray, dt: float,
                steer_angles: FloatArray | None, limit: FloatArray) -> FloatArray:
    """Steps 2-4 of :func:`clamp_command`: the step from ``last`` towards ``safe`` (within
    the speed limits ``limit``) shortened for acceleration, motors and steering."""
    # A last command beyond the speed limits (the limits were just derated) cannot be
    # stepped from within the other limits: the speed limits win, and the step is whole.
    if (robot.wheel_magnitudes(last) - limit * (1 + 1e-9) > robot.speed_slack).any():
        return safe
    accel = robot.max_wheel_accel
    if accel is not None:
        step = safe - last
        # Wheels' acceleration per tick as a fraction of their limit; the largest decides.
        # A command sent a little off W u (a stopped swerve module) may use up to
        # command_snap of the limit at each end.
        snap = robot.command_snap
        bound = (accel * dt if snap == 0.0
                 else np.maximum(accel * dt - 2.0 * snap, 0.5 * accel * dt))
        ratio = float((robot.wheel_magnitudes(step) / bound).max())
        if ratio > 1.0:
            safe = last + (1.0 - SPEED_SLACK) / ratio * step
    if robot.dynamics is not None:
        for _ in range(_MOTOR_PASSES):  # the Coriolis term moves with the step: again
            fraction = motor_step_fraction(robot, last, safe, dt, steer_angles)
            if fraction >= 1.0 - 1e-9:
                break
            safe = last + fraction * (safe - last)
    if steer_angles is not None:
        fraction = robot.steering_fraction(last, safe, steer_angles, dt)
        if robot.dynamics is not None:  # the wheel loops ramp the step over the tick
            fraction = min(fraction, robot.ramp_turn_fraction(last, safe, dt))
        if fraction < 1.0:
            safe = _turn_step(robot, last, safe, fraction, steer_angles, dt)
    return safe


def _turn_step(robot: Robot, last: FloatArray, aim: FloatArray, fraction: float,
               steer_angles: FloatArray, dt: float) -> FloatArray:
    """Step 4's command: ``fraction`` of the step from ``last`` to ``aim``, or a stop (every
    module at rest, free to turn towards ``aim``) where the stop is within the acceleration
    limits (a robot with dynamics: its motors brake to it within the tick) and either
    nearer ``aim`` in the wheels' velocities or the only command within the steering rate
    (``last`` itself turns a module too far: a creep the wheel commands snapped partly to
    rest). Without it a module that must turn far crept along the step,
    its direction swept round by the step's, for many ticks."""
    step = last + fraction * (aim - last)
    if (robot.dynamics is not None  # a stop only where the motors can brake to it
            and motor_step_fraction(robot, last, np.zeros(3), dt, steer_angles) < 1.0 - 1e-9):
        return step
    accel = robot.max_wheel_accel
    if accel is not None:
        snap = robot.command_snap
        bound = (accel * dt if snap == 0.0
                 else np.maximum(accel * dt - 2.0 * snap, 0.5 * accel * dt))
        if (robot.wheel_magnitudes(last) > bound).any():
            return step
    if fraction == 0.0 and robot.steering_fraction(last, last, steer_angles, dt) < 1.0:
        return np.zeros(3)
    blocks = robot.flat_wheel_blocks
    if float(np.sum((blocks @ aim) ** 2)) < float(np.sum((blocks @ (step - aim)) ** 2)):
        return np.zeros(3)
    return step
