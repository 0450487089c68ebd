"""Plausible ranges for a wheeled robot, so that numbers in the wrong unit fail loudly.

A wheelbase of 300 given in millimetres, a wheel speed in rpm or a heading in degrees are
all finite positive numbers: the library's hard bounds (:mod:`mpc.validation`) accept them,
and the controller would plan for a 300 m robot. The robot factories, robot files and the
controller's front door therefore refuse a value beyond the range below with a
:class:`~mpc.errors.RobotError` (:class:`~mpc.errors.ControllerError` for poses) naming the
value, the bound and the unit mistakes that would explain it ("wheelbase 300 m is over
5 m: millimetres (0.3 m) or centimetres (3 m)?"), unless the caller passes
``allow_unusual=True`` (a factory's keyword, ``allow_unusual = true`` in a robot file,
``Controller(..., allow_unusual=True)``).

Each bound sits a factor of about 1.5 or more beyond the largest real robot the row
names, and well below what the unit mistakes it guards against produce. Neobotix's
MPO-500 figures are from its documentation (neobotix-docs.de), the motor speeds from the
WPILib presets in :mod:`mpc.robots.drive.motor`; the others are approximate makers' figures:

==========================  ===========  ===================================================
quantity                    at most      real robots it came from
==========================  ===========  ===================================================
wheelbase, track, a wheel   5 m          FRC swerve frames: modules 0.5-0.9 m apart;
or module's distance from                TurtleBot3: wheels 0.16-0.29 m apart; Clearpath
the body origin, base                    Husky: about 0.55 m track; Neobotix MPO-500: wheel
radius                                   axes 0.25 m from the centre, 0.548 m track; the
                                         mpo700 preset: modules at (+-0.24, +-0.20) m;
                                         large omnidirectional AGVs: 3-4 m long
wheel (or ball) radius      0.5 m        TurtleBot3 0.033 m; FRC 4 in wheels 0.051 m;
                                         MPO-500 0.127 m; Husky about 0.165 m; heavy AGV
                                         wheels up to about 0.25 m
caster offset, axle offset  0.5 m        the mpo700 preset's axle offset 0.045 m; powered
                                         casters 0.02-0.1 m
wheel speed limit           1000 rad/s   brushless motors' free speed, ungeared: Kraken X60
                                         628 rad/s, Falcon 500 668 rad/s; geared wheels
                                         10-100 rad/s
wheel rim speed             20 m/s       FRC swerve at most about 6 m/s free speed;
(radius x speed limit)                   MPO-500 0.9 m/s; Husky about 1 m/s; TurtleBot3
                                         0.22-0.26 m/s
wheel rim acceleration      100 m/s^2    floors give about 1-1.5 g of traction (FRC tread
(radius x accel limit)      (~10 g)      friction 1.1-1.5); MPO-500 2.4 m/s^2
steering rate limit         200 rad/s    FRC steering: NEO 550 at 12.8:1 about 90 rad/s,
                                         Kraken X60 at 21.4:1 about 29 rad/s; the mpo700
                                         preset 24.4 rad/s
mass ([dynamics])           100,000 kg   TurtleBot3 about 1 kg, FRC robots up to about
                                         70 kg, Husky about 50 kg; heavy-load
                                         omnidirectional platforms (KUKA omniMove) carry
                                         up to about 90 t
pose heading                2 pi 1e4 rad 10,000 turns: hours of continuous spinning
==========================  ===========  ===================================================

The unit mistakes each row names are those that turn a plausible value into one beyond
its bound: lengths in millimetres, centimetres or inches; speeds and steering rates in
rpm or degrees per second; accelerations in degrees per second squared; masses in grams;
headings in degrees. No lower bounds: small robots are real, and these mistakes make
numbers larger (a speed in m/s given as rad/s is smaller, and still a plausible robot).

The heading rule for a single measured pose (:func:`check_heading`): a heading is
refused when it is more than one turn from 0 (so not a wrapped heading in (-pi, pi] or
[0, 2 pi)) *and* more than one turn from the reference's heading it is compared with (so
not a multi-turn heading following a multi-turn reference). The controller uses a
heading only modulo whole turns (it shifts the reference by turns to within pi of it),
so wrapping a heading never changes a command: the rule costs a legitimate caller at
most ``math.remainder(theta, 2 * math.pi)``. The controller applies it at the first
tick of a start from rest (after construction, ``reset()`` without a moving
``last_twist``, a new trajectory while at rest), never while the robot moves: a heading
legitimately drifts whole turns from a spinning reference (the controller aims at the
nearest turn, and a clock jump or a new reference moves the reference's turns), and
refusing a tick then would stop a moving robot. A heading in degrees
within one turn of 0 (below 6.3 degrees) or of the reference's heading cannot be told
from radians, and passes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mpc.arrays import FloatArray
from mpc.errors import MpcError, RobotError
from mpc.validation import flag

_INCH = 0.0254  # [m]
_RPM = math.pi / 30.0  # [rad/s per rpm]
_DEGREE = math.pi / 180.0  # [rad per degree]

#: Unit mistakes of lengths: (the unit, its size in metres).
_LENGTH_MISTAKES = (("millimetres", 1e-3), ("centimetres", 1e-2), ("inches", _INCH))
_RATE_MISTAKES = (("rpm", _RPM), ("degrees/s", _DEGREE))


@dataclass(frozen=True)
class Limit:
    """A plausible range's upper bound and the unit mistakes that would exceed it.

    Attributes:
        quantity: what is bounded, for the message ("wheel radius").
        bound: the largest plausible value, in ``unit``.
        unit: the SI unit the library expects ("m", "rad/s").
        mistakes: (unit name, that unit's size in ``unit``) of likely mistakes.
    """

    quantity: str
    bound: float
    unit: str
    mistakes: tuple[tuple[str, float], ...] = ()


#: Wheelbase, track, base radius, a wheel's distance from the body origin [m].
SIZE = Limit("size", 5.0, "m", _LENGTH_MISTAKES)
#: A wheel's (or ball's) radius [m].
WHEEL_RADIUS = Limit("wheel radius", 0.5, "m", _LENGTH_MISTAKES)
#: A caster's trail or a swerve module's axle offset [m].
OFFSET = Limit("caster or axle offset", 0.5, "m", _LENGTH_MISTAKES)
#: A wheel speed limit [rad/s].
WHEEL_SPEED = Limit("wheel speed", 1000.0, "rad/s", _RATE_MISTAKES)
#: A wheel's rim speed at its speed limit, radius x limit [m/s].
RIM_SPEED = Limit("rim speed", 20.0, "m/s")
#: A wheel's rim acceleration at its acceleration limit, radius x limit [m/s^2].
RIM_ACCEL = Limit("rim acceleration", 100.0, "m/s^2")
#: A wheel acceleration limit [rad/s^2]: bounded through :data:`RIM_ACCEL`.
WHEEL_ACCEL = Limit("wheel acceleration", math.inf, "rad/s^2",
                    (("degrees/s^2", _DEGREE), ("rpm/s", _RPM)))
#: A steering rate limit [rad/s].
STEER_RATE = Limit("steering rate", 200.0, "rad/s", _RATE_MISTAKES)
#: A robot's mass [kg].
MASS = Limit("mass", 1e5, "kg", (("grams", 1e-3),))
#: A pose's heading [rad]: 10,000 turns.
HEADING = Limit("heading", 2.0 * math.pi * 1e4, "rad", (("degrees", _DEGREE),))

#: Every limit, for documentation and tests.
LIMITS: tuple[Limit, ...] = (SIZE, WHEEL_RADIUS, OFFSET, WHEEL_SPEED, RIM_SPEED, RIM_ACCEL,
                             STEER_RATE, MASS, HEADING)

_OVERRIDE = "Pass allow_unusual=True if it is real."


def unit_hint(limit: Limit, value: float, bound: float | None = None) -> str:
    """The unit mistakes that would put ``value`` within ``bound`` (default the limit's),
    as "millimetres (0.3 m) or centimetres (3 m)?", or a plain request to check the unit."""
    top = limit.bound if bound is None else bound
    fits = [f"{name} ({value * size:.3g} {limit.unit})" for name, size in limit.mistakes
            if value * size <= top]
    return f"{' or '.join(fits)}?" if fits else f"is it in {limit.unit}?"


def _beyond(name: str, value: float, limit: Limit, what: str = "") -> str:
    """A message for ``name`` at ``value`` beyond ``limit``."""
    return (f"{name} {value:.6g} {limit.unit}{what} is over {limit.bound:g} {limit.unit}, "
            f"beyond any real wheeled robot's {limit.quantity}: {unit_hint(limit, value)} "
            f"{_OVERRIDE}")


def _values(value: object) -> FloatArray:
    """``value`` as a flat float array (None: empty)."""
    return np.zeros(0) if value is None else np.asarray(value, dtype=float).reshape(-1)


def _paired(radius: FloatArray, rate: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Radii repeated to one per rate (one per wheel or ball, rates per actuator)."""
    if radius.size and rate.size % radius.size == 0:
        return np.repeat(radius, rate.size // radius.size), rate
    return np.full(rate.size, radius.max(initial=0.0)), rate


def check_plausible(values: Mapping[str, tuple[Limit, object]], allow_unusual: object,
                    error: type[MpcError] = RobotError) -> None:
    """Raise ``error`` unless every value is within its :class:`Limit` (module docstring),
    or ``allow_unusual`` is True.

    Args:
        values: ``{argument name: (limit, value)}`` with values already checked (finite
            numbers, or arrays of them; None is skipped). A :data:`SIZE` value of shape
            (n, 2) is body points: each row's distance from the origin is bounded. With a
            :data:`WHEEL_RADIUS` entry, :data:`WHEEL_SPEED` and :data:`WHEEL_ACCEL`
            entries are bounded at the rim too (radius x rate, wheel by wheel).
        allow_unusual: True skips every check (a real robot beyond the ranges).
        error: the error type to raise.
    """
    if flag("allow_unusual", allow_unusual, error):
        return
    radius = next((_values(v) for limit, v in values.values() if limit is WHEEL_RADIUS),
                  None)
    for name, (limit, value) in values.items():
        if value is None:
            continue
        array = np.asarray(value, dtype=float)
        points = limit is SIZE and array.ndim == 2 and array.shape[-1] == 2
        sizes = np.hypot(array[:, 0], array[:, 1]) if points else array.reshape(-1)
        worst = int(np.argmax(sizes)) if sizes.size else 0
        if sizes.size and sizes[worst] > limit.bound:
            if points:
                raise error(_beyond(f"{name}[{worst}]", float(sizes[worst]), limit,
                                    " from the body origin"))
            same = float(sizes.max()) == float(sizes.min())  # one value, maybe broadcast
            label = name if same else f"{name}[{worst}]"
            raise error(_beyond(label, float(sizes[worst]), limit))
        rim = {WHEEL_SPEED: RIM_SPEED, WHEEL_ACCEL: RIM_ACCEL}.get(limit)
        if rim is not None and radius is not None and sizes.size:
            radii, rates = _paired(radius, sizes)
            products = radii * rates
            at = int(np.argmax(products))
            if products[at] > rim.bound:
                hint = unit_hint(limit, float(rates[at]), rim.bound / float(radii[at]))
                raise error(
                    f"{name} {rates[at]:.6g} {limit.unit} at a wheel radius of "
                    f"{radii[at]:.6g} m gives a {rim.quantity} of {products[at]:.4g} "
                    f"{rim.unit}, which is over {rim.bound:g} {rim.unit}, beyond any real "
                    f"wheeled robot's: {hint} {_OVERRIDE}")


def check_heading(name: str, heading: float, reference: float | None, allow_unusual: bool,
                  error: type[MpcError]) -> None:
    """Raise ``error`` for a heading [rad] beyond :data:`HEADING`, or one more than a turn
    from both 0 and the ``reference`` heading [rad] it is tracked against (None: only the
    bound), unless ``allow_unusual`` (the rule: module docstring)."""
    if allow_unusual:
        return
    if abs(heading) > HEADING.bound:
        raise error(f"{name} heading {heading:.6g} rad is over {HEADING.bound:.6g} rad "
                    f"(10,000 turns), beyond any robot's: degrees, or accumulated without "
                    f"wrapping? Wrap it with math.remainder(theta, 2 * math.pi) (the "
                    f"controller uses headings modulo whole turns). {_OVERRIDE}")
    turn = 2.0 * math.pi
    if reference is not None and abs(heading) > turn and abs(heading - reference) > turn:
        raise error(
            f"{name} heading {heading:.6g} rad is {abs(heading) / turn:.3g} turns from 0 and "
            f"{abs(heading - reference) / turn:.3g} turns from the reference's heading "
            f"{reference:.6g} rad: degrees ({math.remainder(heading * _DEGREE, turn):.4g} "
            f"rad)? Headings are radians. A multi-turn heading is used modulo whole turns: "
            f"wrap it with math.remainder(theta, 2 * math.pi). {_OVERRIDE}")
