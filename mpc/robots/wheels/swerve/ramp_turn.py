"""How fast a swerve module's direction turns along a command's ramp.

A robot with dynamics plans each stage at a constant acceleration, and the motor plant's
wheel loops ramp each command over the tick (:mod:`mpc.sim.motor_plant`): a module's
velocity runs along the straight line from the last command's ``b`` to the new one's
``e`` (twists map linearly onto module velocities). Its direction then turns at

    d phi / dt = |b x e| / (dt |v(s)|^2),   v(s) = b + s (e - b),  0 <= s <= 1,

fastest where the line passes closest to rest. The clamp's turn check
(:func:`~mpc.robots.wheels.swerve.limits.turn_fraction`) bounds the whole turn by
``max_steer_rate dt``; a module that slows while it turns can still need more than its
steering rate near the end of the tick, lag its velocity there and scrub sideways
(``docs/guide/traction.md``). :func:`ramp_turn_fraction` bounds the rate on the whole
line.
"""

from __future__ import annotations

from mpc.arrays import FloatArray
from mpc.robots.wheels.swerve.modules import SwerveModules

#: Bisection rounds of :func:`ramp_turn_fraction` (2^-40 of the step).
_ROUNDS = 40


def _peak_rate_fits(start: tuple[float, float], change: tuple[float, float],
                    fraction: float, bound: float) -> bool:
    """Whether the line from ``start`` to ``start + fraction change`` [rad/s at the wheel]
    turns its direction by at most ``bound`` [rad] a tick-length anywhere:
    ``|b x e| <= bound min |v|^2``."""
    bx, by = start
    dx, dy = change[0] * fraction, change[1] * fraction
    cross = abs(bx * dy - by * dx)
    if cross == 0.0:
        return True
    length = dx * dx + dy * dy
    s = min(max(-(bx * dx + by * dy) / length, 0.0), 1.0)
    closest = (bx + s * dx) ** 2 + (by + s * dy) ** 2
    return cross <= bound * closest


def ramp_turn_fraction(robot: SwerveModules, last: FloatArray, target: FloatArray,
                       dt: float) -> float:
    """The largest ``f`` in [0, 1] such that along the ramp from ``last`` to
    ``last + f (target - last)`` (twists) no module's velocity direction turns faster than
    ``max_steer_rate`` (module docstring); 1 when the whole step does."""
    bound = robot.max_steer_rate * dt * (1.0 - 1e-9)
    blocks = robot.wheel_blocks
    starts = (blocks @ last).tolist()
    changes = (blocks @ (target - last)).tolist()
    fraction = 1.0
    for start, change in zip(starts, changes, strict=True):
        if _peak_rate_fits(start, change, fraction, bound):
            continue
        low, high = 0.0, fraction  # 0 fits: no change, no turn
        for _ in range(_ROUNDS):
            middle = 0.5 * (low + high)
            if _peak_rate_fits(start, change, middle, bound):
                low = middle
            else:
                high = middle
        fraction = low
    return fraction if fraction < 1.0 else 1.0
