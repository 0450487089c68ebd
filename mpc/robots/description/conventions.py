"""Wheel commands in another source's own wheel order, signs and units.

Our wheel speeds are rad/s in the layout's order (Mecanum FL, FR, RL, RR; omni
counter-clockwise from ``first_wheel_angle``), positive driving forward (Mecanum) or
counter-clockwise (omni). A driver or a textbook may number, sign and scale them
otherwise; a :class:`WheelConvention` maps between the two:

    source[j] = signs[j] * scale * ours[order[j]]

with ``scale`` ``1 / (2 pi)`` for revolutions per second, ``wheel_radius`` for rim speeds
[m/s] and 1 for rad/s. It is a wiring and units mapping, never kinematics: the model keeps
the project's conventions (docs/guide/conventions.md).

The founding documents' conventions (each listed below; tested against each document's
own equations in ``tests/test_seed_robots.py``):

- ``jetauto``: Hiwonder JetAuto's ROS 2 driver. Motors 1, 2, 3, 4 are FL, RL, FR, RR; it
  takes revolutions per second with the right side negated,
  ``rps = [v1, v2, -v3, -v4] / (pi * wheel_diameter)``.
- ``kosen-mecanum``: the KOSEN robot-club notes' Mecanum. Wheels 1 = front right, then
  counter-clockwise (FR, FL, RL, RR); rim speeds [m/s]; every wheel positive driving
  forward, as ours. The notes' body frame has x to the right and y forward
  (:attr:`WheelConvention.twist_axes`): their ``Vw1 = -Vx + Vy + R w (sin phi + cos phi)``
  is our ``vx + vy + k w`` with ``Vx = -vy``, ``Vy = vx``.
- ``kosen-omni4``: the same notes' four omni wheels at 45 deg, numbered as their Mecanum
  (the ``kosen-omni4`` preset's order); rim speeds [m/s],
  ``Vw = -sin(theta) Vx + cos(theta) Vy + R w`` in either frame (it turns with it).
- ``swedish3``: the Siegwart-style three-wheel tutorial (wheels at 60, -60, 180 deg);
  ``v_i = r phidot_i`` [m/s], our order and signs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.validation import positive, real_array, shown

#: Units a convention's values may be in: factor from rad/s, or None where the wheel
#: radius [m] is the factor (rim speed).
UNITS: Mapping[str, float | None] = {"rad/s": 1.0, "rps": 1.0 / (2.0 * math.pi), "m/s": None}


@dataclass(frozen=True)
class WheelConvention:
    """One source's wheel order, signs and units.

    Attributes:
        name: the convention's name.
        labels: the source's name for each of its wheels, in its order.
        order: the source's wheel ``j`` is our wheel ``order[j]``.
        signs: +-1 per source wheel: the source's positive sense against ours.
        unit: ``"rad/s"``, ``"rps"`` (revolutions per second) or ``"m/s"`` (rim speed).
        twist_axes: the source's body-frame (Vx, Vy) in ours, as names: ``("vx", "vy")``
            when its frame is REP-103's, ``("-vy", "vx")`` for x right and y forward.
        ids: the source's wheel (motor) ids in its order, or None.
    """

    name: str
    labels: tuple[str, ...]
    order: tuple[int, ...]
    signs: tuple[float, ...]
    unit: str
    twist_axes: tuple[str, str] = ("vx", "vy")
    ids: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        count = len(self.order)
        if sorted(self.order) != list(range(count)):
            raise RobotError(f"order must be a permutation of 0..{count - 1}, "
                             f"got {shown(self.order)}")
        if len(self.signs) != count or any(s not in (1.0, -1.0) for s in self.signs):
            raise RobotError(f"signs must be {count} values of +1 or -1, got {shown(self.signs)}")
        if len(self.labels) != count or (self.ids is not None and len(self.ids) != count):
            raise RobotError(f"labels and ids must have {count} entries each")
        if self.unit not in UNITS:
            raise RobotError(f"unit must be one of {list(UNITS)}, got {shown(self.unit)}")
        if self.twist_axes not in (("vx", "vy"), ("-vy", "vx")):
            raise RobotError(f"twist_axes must be ('vx', 'vy') or ('-vy', 'vx'), "
                             f"got {shown(self.twist_axes)}")

    @property
    def n_wheels(self) -> int:
        return len(self.order)

    def scale(self, wheel_radius: float | None = None) -> float:
        """The source's unit per rad/s; rim speeds need ``wheel_radius`` [m]."""
        factor = UNITS[self.unit]
        if factor is not None:
            return factor
        if wheel_radius is None:
            raise RobotError(f"convention {self.name!r} is in m/s at the rim: pass "
                             f"wheel_radius= [m]")
        return positive("wheel_radius", wheel_radius, RobotError)

    def from_ours(self, wheel_speeds: ArrayLike, wheel_radius: float | None = None) -> FloatArray:
        """Our wheel speeds [rad/s], shape (n,) or (k, n), in the source's order, signs and
        unit."""
        speeds = self._values("wheel_speeds", wheel_speeds)
        return speeds[..., list(self.order)] * np.asarray(self.signs) * self.scale(wheel_radius)

    def to_ours(self, values: ArrayLike, wheel_radius: float | None = None) -> FloatArray:
        """The source's wheel values (its order, signs and unit) as our wheel speeds [rad/s]."""
        source = self._values("values", values) * np.asarray(self.signs) / self.scale(
            wheel_radius)
        ours = np.empty_like(source)
        ours[..., list(self.order)] = source
        return ours

    def twist_to_source(self, twist: ArrayLike) -> FloatArray:
        """Our body twist (vx, vy, omega) as the source writes it, (Vx, Vy, omega)."""
        xi = self._twist(twist)
        if self.twist_axes == ("vx", "vy"):
            return xi.copy()
        return np.stack([-xi[..., 1], xi[..., 0], xi[..., 2]], axis=-1)

    def _values(self, name: str, values: ArrayLike) -> FloatArray:
        array = real_array(name, values, f"{self.n_wheels} wheel values", RobotError)
        if array.ndim not in (1, 2) or array.shape[-1] != self.n_wheels:
            raise RobotError(f"convention {self.name!r}: {name} must have shape "
                             f"({self.n_wheels},) or (k, {self.n_wheels}), got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise RobotError(f"{name} must be finite, got {shown(values)}")
        return array

    def _twist(self, twist: ArrayLike) -> FloatArray:
        array = real_array("twist", twist, "(vx, vy, omega)", RobotError)
        if array.ndim not in (1, 2) or array.shape[-1] != 3:
            raise RobotError(f"twist must have shape (3,) or (k, 3), got {array.shape}")
        return array


_FOUR = (1.0, 1.0, 1.0, 1.0)

#: The founding documents' conventions by name (the module docstring says where each is from).
CONVENTIONS: Mapping[str, WheelConvention] = {
    convention.name: convention for convention in (
        WheelConvention("jetauto", ("motor 1 (FL)", "motor 2 (RL)", "motor 3 (FR)",
                                    "motor 4 (RR)"),
                        order=(0, 2, 1, 3), signs=(1.0, 1.0, -1.0, -1.0), unit="rps",
                        ids=(1, 2, 3, 4)),
        WheelConvention("kosen-mecanum", ("1 (FR)", "2 (FL)", "3 (RL)", "4 (RR)"),
                        order=(1, 0, 2, 3), signs=_FOUR, unit="m/s", twist_axes=("-vy", "vx"),
                        ids=(1, 2, 3, 4)),
        WheelConvention("kosen-omni4", ("1 (FR)", "2 (FL)", "3 (RL)", "4 (RR)"),
                        order=(0, 1, 2, 3), signs=_FOUR, unit="m/s", twist_axes=("-vy", "vx"),
                        ids=(1, 2, 3, 4)),
        WheelConvention("swedish3", ("1 (60 deg)", "2 (-60 deg)", "3 (180 deg)"),
                        order=(0, 1, 2), signs=(1.0, 1.0, 1.0), unit="m/s", ids=(1, 2, 3)),
    )
}


def wheel_convention(convention: str | WheelConvention) -> WheelConvention:
    """A convention by name (one of :data:`CONVENTIONS`), or ``convention`` itself."""
    if isinstance(convention, WheelConvention):
        return convention
    if not isinstance(convention, str) or convention not in CONVENTIONS:
        raise RobotError(f"unknown wheel convention {shown(convention)}; expected one of "
                         f"{list(CONVENTIONS)} or a WheelConvention")
    return CONVENTIONS[convention]
