"""Mobility analysis of a wheel set (Campion, Bastin & d'Andrea-Novel, IEEE T-RA 1996).

A wheel set is given like a robot description: ``{"wheels": [{"type": ..., "x": ...,
"y": ..., ...}, ...]}`` (and an optional ``"name"``). Body frame REP-103 (x forward,
y left, angles counter-clockwise); ``x``, ``y`` [m] are the wheel's contact point
(fixed, Swedish, ball) or steer axis (steered, caster, axle-offset); ``heading`` [rad]
is the rolling direction ``e = (cos h, sin h)`` of a fixed or Swedish wheel.

=============  ========================  ==================================================
type           keys (optional)           sliding constraint
=============  ========================  ==================================================
fixed          x, y, heading             ``n . v(P) = 0`` with ``n = (-sin h, cos h)``: a row
steered        x, y, (heading)           the same at the steer angle: a row of ``C1s``
axle_offset    x, y, lever, (heading)    as steered (see below)
caster         x, y, offset, (heading)   none: the free steer rate absorbs it
swedish        x, y, heading, (gamma)    none: the rollers absorb it
spherical      x, y                      none
slider         x, y, (heading)           none while the slider is free (its rate absorbs
                                         it; at a stroke end it is a steered wheel)
=============  ========================  ==================================================

With ``v(P) = (vx - omega*y, vy + omega*x)`` the row of a wheel at steer or rolling
angle ``a`` is ``[-sin a, cos a, x cos a + y sin a]``. Stack the fixed wheels' rows
into ``C1f`` and the steered wheels' into ``C1s``; then

- degree of mobility ``dm = 3 - rank([C1f; C1s])``: independent body motions at a
  given steering;
- degree of steerability ``ds = rank([C1f; C1s]) - rank(C1f)`` (<= 2): independent
  steer angles, i.e. how many dimensions steering moves the centre of rotation in;
- manoeuvrability ``dm + ds``.

*Generic* steer angles are not independent random angles (four swerve modules at
random angles admit no motion at all): they are the angles of a motion the robot
can make. So a seeded random twist ``xi`` is drawn from the null space of ``C1f``
and every steered wheel is aligned with its velocity ``v(P, xi)`` (a random angle if
that is zero); the largest rank over a few draws counts. Positions are divided by
the largest wheel distance first (rank is scale-free), and a singular value counts
when above :data:`RANK_TOLERANCE` times the largest.

An axle-offset module's contact ``C = P - L*n`` satisfies ``n . v(C) = n . v(P)``
(the offset adds ``omega*L*e``, along the wheel), so for mobility it is a steered
wheel at its axis.

**Which robots can follow an arbitrary pose trajectory** (the rule of
:func:`require_omnidirectional`): exactly those with ``dm + ds = 3``. Since
``dm + ds = 3 - rank(C1f)``, that means no fixed-wheel sliding constraint: every
body twist is then admissible once each steered wheel points along ``v(P, xi)``
(immediately for ``dm = 3``, after steering for swerve-like ``(1, 2)`` and
``(2, 1)``). With ``rank(C1f) >= 1`` some twist is forbidden whatever the steering
(a differential drive cannot move sideways, a car cannot turn about a point off its
rear axle), so some pose trajectories cannot be followed. For robots without
steered wheels the rule is ``dm = 3``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.robots.base import Robot
from mpc.validation import MAX_COORDINATE, MAX_LENGTH, bounded, shown

#: A singular value counts towards a rank above this fraction of the largest one.
RANK_TOLERANCE = 1e-9
#: Seeded draws of generic steer angles; the largest rank counts.
_DRAWS = 3
_SEED = 20240516

class WheelKind(NamedTuple):
    """One of the analysis's wheel types: its keys besides ``type``, the sliding
    constraint it adds, and what else its values must satisfy."""

    required: frozenset[str]
    optional: frozenset[str] = frozenset()
    #: ``"fixed"``: a sliding row along ``heading``; ``"steered"``: one that turns with its
    #: steer angle; ``None``: none (it can roll or slide every way the body moves it).
    sliding: str | None = None
    #: (a key, a condition on its value (0 when absent), what the error says of it), or
    #: None.
    rule: tuple[str, Callable[[float], bool], str] | None = None


#: The wheel types by name.
WHEEL_KINDS: dict[str, WheelKind] = {
    "fixed": WheelKind(frozenset({"x", "y", "heading"}), sliding="fixed"),
    "steered": WheelKind(frozenset({"x", "y"}), frozenset({"heading"}), sliding="steered"),
    "caster": WheelKind(frozenset({"x", "y", "offset"}), frozenset({"heading"}), rule=(
        "offset", lambda offset: offset > 0.0, "must be > 0 (the contact trails the steer axis)")),
    "swedish": WheelKind(frozenset({"x", "y", "heading"}), frozenset({"gamma"}), rule=(
        "gamma", lambda gamma: abs(math.cos(gamma)) >= 1e-9,
        "must not be +-pi/2 (rollers parallel to the axle: that is a fixed wheel, type 'fixed')")),
    "spherical": WheelKind(frozenset({"x", "y"})),
    "axle_offset": WheelKind(frozenset({"x", "y", "lever"}), frozenset({"heading"}),
                             sliding="steered"),
}
#: Per wheel type: (required keys, optional keys) besides ``type``.
WHEEL_KEYS: dict[str, tuple[frozenset[str], frozenset[str]]] = {
    name: (kind.required, kind.optional) for name, kind in WHEEL_KINDS.items()}


def register_wheel_kind(name: str, kind: WheelKind) -> None:
    """Add a wheel type the classical five do not cover to the analysis (its module calls
    this on import, as the slider does)."""
    WHEEL_KINDS[name] = kind
    WHEEL_KEYS[name] = (kind.required, kind.optional)


class Mobility(NamedTuple):
    """Campion's degrees of a wheel set (see the module docstring)."""

    degree_of_mobility: int
    degree_of_steerability: int

    @property
    def manoeuvrability(self) -> int:
        """``dm + ds``: 3 means any body twist is reachable (after steering if ds > 0)."""
        return self.degree_of_mobility + self.degree_of_steerability


@dataclass(frozen=True)
class WheelSpec:
    """One wheel of a description, validated. Lengths [m], angles [rad]; None when absent."""

    kind: str
    x: float
    y: float
    heading: float | None = None
    offset: float | None = None
    lever: float | None = None
    gamma: float | None = None


def parse_wheels(description: object, source: str = "robot description") -> tuple[WheelSpec,
                                                                                   ...]:
    """The validated wheels of a description; RobotError naming the wheel index and field."""
    if not isinstance(description, Mapping):
        raise RobotError(f"{source}: expected a table with 'wheels', "
                         f"got {type(description).__name__}")
    unknown = sorted(set(description) - {"wheels", "name"}, key=str)
    if unknown:
        raise RobotError(f"{source}: unknown key(s) {unknown}; expected 'wheels' and "
                         "optionally 'name'")
    if "name" in description and not isinstance(description["name"], str):
        raise RobotError(f"{source}: name must be a string, got {description['name']!r}")
    wheels = description.get("wheels")
    if not isinstance(wheels, Sequence) or isinstance(wheels, (str, bytes)) or not wheels:
        raise RobotError(f"{source}: wheels must be a non-empty list of wheel tables, "
                         f"got {shown(wheels)}")
    return tuple(_parse_wheel(table, f"{source}: wheels[{index}]")
                 for index, table in enumerate(wheels))


def _parse_wheel(table: object, where: str) -> WheelSpec:
    if not isinstance(table, Mapping):
        raise RobotError(f"{where} must be a table, got {shown(table)}")
    kind = table.get("type")
    if not isinstance(kind, str) or kind not in WHEEL_KEYS:
        raise RobotError(f"{where}.type must be one of {sorted(WHEEL_KEYS)}, got {shown(kind)}")
    required, optional = WHEEL_KEYS[kind]
    keys = set(table) - {"type"}
    unknown = sorted(keys - required - optional, key=str)
    missing = sorted(required - keys)
    if unknown or missing:
        raise RobotError(f"{where} ({kind}): unknown key(s) {unknown}, missing key(s) "
                         f"{missing}; expected {sorted(required)} and optionally "
                         f"{sorted(optional)}")
    values: dict[str, Any] = {}
    for key in sorted(keys):
        angle = key in ("heading", "gamma")
        values[key] = bounded(f"{where}.{key}", table[key],
                              MAX_COORDINATE if angle else MAX_LENGTH,
                              "[rad]" if angle else "[m]", RobotError)
    rule = WHEEL_KINDS[kind].rule
    if rule is not None and not rule[1](values.get(rule[0], 0.0)):
        raise RobotError(f"{where}.{rule[0]} {rule[2]}, got {shown(table[rule[0]])}")
    return WheelSpec(kind=kind, **values)


def _sliding_rows(points: FloatArray, angles: FloatArray) -> FloatArray:
    """``n . v(P)`` as rows ``[-sin a, cos a, x cos a + y sin a]``, shape (k, 3)."""
    c, s = np.cos(angles), np.sin(angles)
    return np.stack([-s, c, points[:, 0] * c + points[:, 1] * s], axis=1)


def _rank(rows: FloatArray) -> int:
    if rows.shape[0] == 0:
        return 0
    singular = np.linalg.svd(rows, compute_uv=False)
    return int(np.sum(singular > RANK_TOLERANCE * singular[0]))


def _generic_steer_angles(steered: FloatArray, fixed_rows: FloatArray,
                          rng: np.random.Generator) -> FloatArray:
    """Steer angles along ``v(P, xi)`` for a random twist ``xi`` the fixed wheels allow."""
    if fixed_rows.shape[0]:
        _, singular, vh = np.linalg.svd(fixed_rows)
        rank = int(np.sum(singular > RANK_TOLERANCE * singular[0]))
        basis = vh[rank:].T  # (3, 3 - rank)
    else:
        basis = np.eye(3)
    twist = basis @ rng.normal(size=basis.shape[1])
    velocity = np.stack([twist[0] - twist[2] * steered[:, 1],
                         twist[1] + twist[2] * steered[:, 0]], axis=1)
    angles = np.arctan2(velocity[:, 1], velocity[:, 0])
    still = np.hypot(velocity[:, 0], velocity[:, 1]) <= RANK_TOLERANCE * (
        1.0 + np.linalg.norm(twist))
    return np.where(still, rng.uniform(-math.pi, math.pi, size=len(angles)), angles)


def wheel_mobility(wheels: Sequence[WheelSpec]) -> Mobility:
    """(dm, ds) of validated wheels (see the module docstring for the method)."""
    points = np.array([[w.x, w.y] for w in wheels], dtype=float).reshape(-1, 2)
    size = float(np.hypot(points[:, 0], points[:, 1]).max(initial=0.0))
    points = points / (size if size > 0.0 else 1.0)
    kinds = [w.kind for w in wheels]
    sliding = [WHEEL_KINDS[k].sliding for k in kinds]
    fixed = np.array([s == "fixed" for s in sliding])
    steered = np.array([s == "steered" for s in sliding])
    headings = np.array([w.heading if w.heading is not None else 0.0 for w in wheels])
    fixed_rows = _sliding_rows(points[fixed], headings[fixed])
    rank_fixed = _rank(fixed_rows)
    rank_all = rank_fixed
    if steered.any():
        rng = np.random.default_rng(_SEED)
        for _ in range(_DRAWS):
            angles = _generic_steer_angles(points[steered], fixed_rows, rng)
            rows = np.vstack([fixed_rows, _sliding_rows(points[steered], angles)])
            rank_all = max(rank_all, _rank(rows))
    return Mobility(3 - rank_all, rank_all - rank_fixed)


def mobility(description: Mapping[str, Any], source: str = "robot description") -> Mobility:
    """Campion's (degree of mobility, degree of steerability) of a wheel-set description.

    Args:
        description: ``{"wheels": [{"type": ..., "x": ..., "y": ..., ...}, ...]}`` (see
            the module docstring for the types and their keys), optionally ``"name"``.
        source: names the description in error messages.
    """
    return wheel_mobility(parse_wheels(description, source))


def _meaning(result: Mobility) -> str:
    dm, ds = result
    return (f"(degree of mobility, degree of steerability) = ({dm}, {ds}): {dm} independent "
            f"body motion(s) at fixed steer angles, {ds} independent steer angle(s)")


def require_omnidirectional(description: Mapping[str, Any],
                            source: str = "robot description") -> Mobility:
    """The mobility of ``description``, or RobotError (one line) if it cannot follow an
    arbitrary pose trajectory: manoeuvrability ``dm + ds < 3`` (see the module docstring
    for why that is the rule)."""
    result = mobility(description, source)
    if result.manoeuvrability < 3:
        raise RobotError(
            f"{source}: {_meaning(result)}; manoeuvrability {result.manoeuvrability} < 3: "
            "its fixed wheels' sliding constraints forbid some body twist whatever the "
            "steering, so it cannot follow an arbitrary pose trajectory (x, y, theta)(t)")
    return result


def robot_description(robot: Robot) -> dict[str, Any]:
    """The wheel-set description of a robot object (for :func:`mobility`): its wheel
    type's tables (:meth:`~mpc.robots.base.Robot.mobility_wheels`)."""
    return {"name": robot.name, "wheels": robot.mobility_wheels()}


def robot_mobility(robot: Robot) -> Mobility:
    """(dm, ds) of a robot object: Swedish, ball and caster robots (3, 0), swerve (1, 2)."""
    return mobility(robot_description(robot), f"robot {robot.name!r}")
