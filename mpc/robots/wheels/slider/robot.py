"""Steered wheels on radial sliders (the founding analysis's Eq. 8; SWOM): the robot.

Unit ``i``: a rail from the body origin at ``rail_angles[i]``, a slider carrying a
steered wheel along it within its stroke ``[l_min, l_max]`` [m], the steer angle measured
from the rail (:mod:`.kinematics` has the equations). A unit has three joints: the drive
rate ``phidot`` [rad/s], the steer rate ``betadot`` [rad/s] and the slider rate ``ldot``
[m/s], each with a limit, and two joint states, the steer angle and the slider position.

- The steer angles are commanded: the controller chooses them along its plan (a schedule
  within the steer-rate limit, :mod:`.rows`); both solvers then choose the twists within
  the drive-rate, slider-rate and stroke limits at those angles (:mod:`.limits`).
- The slider positions follow the motion; the controller measures them and the steer
  angles each tick (:class:`mpc.control.slider.SliderController`).
- Without joint states in hand (the steady state: sliders at mid-stroke and at rest) a
  unit is a swerve module at mid-stroke: ``wheel_blocks`` are its contact point's velocity
  there over the radius, and the generic kinematics (``wheel_speeds``,
  ``forward_kinematics``, ``commands_from_velocities``) read it so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, listed, readonly
from mpc.errors import MpcError, RobotError
from mpc.plausibility import SIZE, STEER_RATE, WHEEL_RADIUS, WHEEL_SPEED, check_plausible
from mpc.robots.base import Robot, SpeedRows, WheelCommands, as_twists
from mpc.robots.description.mobility import WheelKind, register_wheel_kind
from mpc.robots.description.registry import register
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.contact_disk import disk_casadi_limits, disk_speed_rows
from mpc.robots.wheels.slider import limits as slider_limits
from mpc.robots.wheels.slider import rows as slider_rows
from mpc.robots.wheels.slider.kinematics import SliderUnit
from mpc.validation import MAX_COORDINATE, checked_arguments, real_array, shown


def _per_unit(name: str, value: object, count: int, unit: str, shape: tuple[int, ...] = ()
              ) -> FloatArray:
    """One value (of ``shape``) for every unit, or one per unit, as (count, *shape)."""
    array = real_array(name, value, f"one value {unit} or one per unit ({count})", RobotError)
    if array.shape == shape:
        array = np.broadcast_to(array, (count, *shape)).copy()
    if array.shape != (count, *shape):
        raise RobotError(f"{name} must be one value {unit} or one per unit ({count}), got "
                         f"shape {array.shape}")
    return array


@dataclass(frozen=True, eq=False)
class SliderRobot(Robot):
    """A robot of steered wheels on radial sliders (module docstring).

    Attributes:
        rails: (n,) each rail's angle from the body x axis [rad], n >= 2
            (:attr:`rail_angles`).
        stroke: (n, 2) each slider's ``(l_min, l_max)`` [m].
        wheel_radius: (n,) [m].
        max_speed: (n,) drive-rate limits [rad/s].
        max_steer_rate: (n,) steer-rate limits [rad/s].
        max_slider_speed: (n,) slider-rate limits [m/s].
    """

    kind = "slider"
    steered = True
    steer_states = True

    rails: ArrayLike = field(default_factory=lambda: np.zeros(0))
    stroke: ArrayLike = field(default=(0.15, 0.35), kw_only=True)
    wheel_radius: ArrayLike = field(default=0.05, kw_only=True)
    max_speed: ArrayLike = field(default=20.0, kw_only=True)
    max_steer_rate: ArrayLike = field(default=5.0, kw_only=True)
    max_slider_speed: ArrayLike = field(default=0.5, kw_only=True)
    units: tuple[SliderUnit, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        angles = real_array("rail_angles", self.rails, "n >= 2 angles [rad]", RobotError)
        if angles.ndim != 1 or angles.size < 2:
            raise RobotError(f"rail_angles must be n >= 2 angles [rad], got {shown(angles)}")
        n = angles.size
        stroke = _per_unit("stroke", self.stroke, n, "(l_min, l_max) [m]", (2,))
        values = {name: _per_unit(name, getattr(self, attribute), n, unit) for
                  name, attribute, unit in (
                      ("wheel_radius", "wheel_radius", "[m]"),
                      ("max_wheel_speed", "max_speed", "[rad/s]"),
                      ("max_steer_rate", "max_steer_rate", "[rad/s]"),
                      ("max_slider_speed", "max_slider_speed", "[m/s]"))}
        units = tuple(SliderUnit(float(a), (float(s[0]), float(s[1])),
                                 float(values["wheel_radius"][i]),
                                 float(values["max_wheel_speed"][i]),
                                 float(values["max_steer_rate"][i]),
                                 float(values["max_slider_speed"][i]))
                      for i, (a, s) in enumerate(zip(angles, stroke, strict=True)))
        object.__setattr__(self, "units", units)
        object.__setattr__(self, "rails", readonly(angles.astype(float)))
        object.__setattr__(self, "stroke", readonly(np.array([u.stroke for u in units])))
        for attribute, name in (("wheel_radius", "wheel_radius"), ("max_speed", "max_wheel_speed"),
                                ("max_steer_rate", "max_steer_rate"),
                                ("max_slider_speed", "max_slider_speed")):
            object.__setattr__(self, attribute, readonly(np.array(
                [getattr(u, name) for u in units], dtype=float)))
        if float(np.min(self.strokes[:, 0])) <= 0.0:
            raise RobotError(f"stroke must keep every contact off the body origin (l_min > 0) "
                             f"[m], got {shown(self.stroke)}")
        middle = self.strokes.mean(axis=1)
        blocks = np.zeros((n, 2, 3))
        blocks[:, 0, 0] = 1.0
        blocks[:, 1, 1] = 1.0
        blocks[:, 0, 2] = -middle * np.sin(angles)
        blocks[:, 1, 2] = middle * np.cos(angles)
        object.__setattr__(self, "wheel_blocks", readonly(blocks / self.radii[:, None, None]))
        object.__setattr__(self, "nominal_max_wheel_speed", self.max_speed)
        object.__setattr__(self, "nominal_max_wheel_accel", None)
        self._finish()

    # ------------------------------------------------------------ description
    @property
    def rail_angles(self) -> FloatArray:
        """(n,) each rail's angle from the body x axis [rad]."""
        return np.asarray(self.rails, dtype=float)

    @property
    def strokes(self) -> FloatArray:
        """(n, 2) each slider's ``(l_min, l_max)`` [m]."""
        return np.asarray(self.stroke, dtype=float)

    @property
    def radii(self) -> FloatArray:
        return np.asarray(self.wheel_radius, dtype=float)

    @property
    def max_steer_rates(self) -> FloatArray:
        return np.asarray(self.max_steer_rate, dtype=float)

    @property
    def max_slider_speeds(self) -> FloatArray:
        """(n,) slider-rate limits [m/s]."""
        return np.asarray(self.max_slider_speed, dtype=float)

    @property
    def wheel_positions(self) -> FloatArray:
        """Contact points with every slider at mid-stroke [m], shape (n, 2)."""
        middle = self.strokes.mean(axis=1)
        return np.stack([middle * np.cos(self.rail_angles), middle * np.sin(self.rail_angles)],
                        axis=1)

    def initial_slider_positions(self) -> FloatArray:
        """Every slider at mid-stroke [m] (n,)."""
        return self.strokes.mean(axis=1)

    def joint_parameter_size(self, horizon: int) -> int:
        """Measured steer angles and slider positions, and each stage's mid-stage angle of
        the steer schedule (:func:`.rows.joint_parameters`)."""
        return self.n_wheels * (2 + horizon)

    def check_joints(self, steer_angles: ArrayLike, slider_positions: ArrayLike,
                     error: type[MpcError] = RobotError) -> tuple[FloatArray, FloatArray]:
        """Measured steer angles [rad] and slider positions [m], each (n,): finite, the angles
        within +-MAX_COORDINATE and the positions within their stroke
        up to 1 mm (a slider at its stop reads a little past it)."""
        n = self.n_wheels
        angles = real_array("steer_angles", steer_angles, f"{n} angles [rad]", error)
        where = real_array("slider_positions", slider_positions, f"{n} positions [m]", error)
        for name, array, unit in (("steer_angles", angles, "[rad]"),
                                  ("slider_positions", where, "[m]")):
            if array.shape != (n,) or not bool(np.all(np.isfinite(array))):
                raise error(f"{name} must be {n} finite numbers {unit}, one a unit, got "
                            f"{shown(array)}")
        if not bool(np.all(np.abs(angles) <= MAX_COORDINATE)):
            raise error(f"steer_angles must lie within +-{MAX_COORDINATE:g} [rad], got "
                        f"{shown(angles)}")
        outside = (where < self.strokes[:, 0] - 1e-3) | (where > self.strokes[:, 1] + 1e-3)
        if outside.any():
            raise error(f"slider_positions must lie within each stroke {shown(self.stroke)} "
                        f"[m], got {shown(where)}")
        return angles.astype(float), where.astype(float)

    # ------------------------------------------------------------ joint kinematics
    def slider_rows(self, steer_angles: FloatArray,
                    positions: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Drive rows ``D`` and slider rows ``L`` (each (..., n, 3)) at steer angles and
        slider positions (..., n): ``phidot = D u``, ``ldot = L u``. Unchecked."""
        return slider_rows.joint_rows(self, np.asarray(steer_angles, dtype=float),
                                      np.asarray(positions, dtype=float))

    def steer_schedule(self, steer_angles: FloatArray, positions: FloatArray,
                       twists: FloatArray, durations: FloatArray,
                       aims: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
        """The plan's steer angles at the stages' ends and slider positions at their starts,
        each (N+1, n) (:func:`.rows.steer_schedule`)."""
        return slider_rows.steer_schedule(self, steer_angles, positions, twists, durations,
                                          aims)

    def predict_steer_angles(self, steer_angles: FloatArray, twists: FloatArray,
                             durations: FloatArray) -> FloatArray:
        """Commanded steer angles do not follow the motion: held, (k+1, n)."""
        return np.tile(np.asarray(steer_angles, dtype=float), (len(durations) + 1, 1))

    # ------------------------------------------------------------ steady-state kinematics
    def wheel_speeds(self, twist: ArrayLike) -> FloatArray:
        """Drive rates [rad/s] >= 0 of units at mid-stroke rolling along their contacts'
        motion (sliders at rest), shape (n,) or (k, n)."""
        return np.linalg.norm(self.wheel_velocities(twist), axis=-1)

    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        velocity = self.flat_wheel_blocks @ twist
        return np.hypot(velocity[0::2], velocity[1::2])

    def forward_kinematics(self, wheel_speeds: FloatArray,
                           steer_angles: FloatArray | None) -> FloatArray:
        """Sliders at mid-stroke and at rest: each contact moving at ``r phidot`` along its
        rolling direction; least squares (the joint-state map is
        :func:`.kinematics.slider_twist`)."""
        angles = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        heading = self.rail_angles + angles
        velocities = np.empty(2 * self.n_wheels)
        velocities[0::2] = -wheel_speeds * np.sin(heading)
        velocities[1::2] = wheel_speeds * np.cos(heading)
        return self._flat_pinv @ velocities

    def commands_from_velocities(self, velocities: FloatArray,
                                 steer_angles: FloatArray | None) -> WheelCommands:
        """Sliders at mid-stroke and at rest: each unit's steer angle (of the two that roll
        it along its velocity (n, 2) / r, the one nearer the present angle, the drive
        signed to match); a unit at rest keeps its angle."""
        current = np.zeros(self.n_wheels) if steer_angles is None else steer_angles
        aim = np.arctan2(velocities[:, 1], velocities[:, 0]) - 0.5 * math.pi - self.rail_angles
        aim = current + np.mod(aim - current + 0.5 * math.pi, math.pi) - 0.5 * math.pi
        moving = np.hypot(velocities[:, 0], velocities[:, 1]) * self.radii > 1e-9
        angles = np.where(moving, aim, current)
        heading = self.rail_angles + angles
        speeds = -np.sin(heading) * velocities[:, 0] + np.cos(heading) * velocities[:, 1]
        return WheelCommands(np.where(moving, speeds, 0.0), angles)

    # ------------------------------------------------------------ limits for the solvers
    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        """Joint-free stand-in (the solvers use :meth:`stage_limits`): each contact's speed
        disk at mid-stroke, ``|v(C)| <= r max_wheel_speed``, as an inscribed polygon."""
        return disk_speed_rows(self.wheel_blocks, polygon_sides)

    def casadi_limits(self, twist: ca.SX, bounds: FloatArray) -> tuple[ca.SX, FloatArray,
                                                                         FloatArray]:
        """Joint-free stand-in: each contact's speed disk at mid-stroke (squared)."""
        return disk_casadi_limits(self.flat_wheel_blocks, twist, bounds)

    def stage_limits(self, change_times: FloatArray,
                     polygon_sides: int | None) -> StageLimits:
        return slider_limits.stage_limits(self, change_times)

    def update_stage_limits(self, limits: StageLimits, guess: FloatArray, last: FloatArray,
                            steer_angles: FloatArray | None) -> None:
        """``steer_angles``: the joint parameter vector (:mod:`.rows`)."""
        slider_limits.update_stage_limits(self, limits, guess, steer_angles)

    def nlp_stage_limits(self, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                         change_times: FloatArray
                         ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
        """``steer_angles``: the joint parameter vector as a symbol (:mod:`.rows`)."""
        return slider_limits.nlp_stage_limits(self, twists, steer_angles, change_times)

    def clamp_joints(self, target: FloatArray, last: FloatArray, dt: float,
                     steer_angles: FloatArray) -> FloatArray | None:
        """``steer_angles``: the joint parameter vector; the target scaled into stage 0's
        rows (:func:`.limits.clamp_at`)."""
        if np.size(steer_angles) < 3 * self.n_wheels:
            raise RobotError(f"robot {self.name!r} (slider) clamps at its joint parameters "
                             f"(steer angles, slider positions, steer schedule), got "
                             f"{np.size(steer_angles)} numbers")
        return slider_limits.clamp_at(self, as_twists(target), np.asarray(steer_angles), dt)[0]

    # ------------------------------------------------------------ what the type says
    def description(self) -> dict[str, Any]:
        return {"type": "slider", "name": self.name, **listed(
            rail_angles=self.rail_angles, stroke=self.stroke, wheel_radius=self.wheel_radius,
            max_wheel_speed=self.max_speed, max_steer_rate=self.max_steer_rate,
            max_slider_speed=self.max_slider_speed)}

    def mobility_wheels(self) -> list[dict[str, Any]]:
        return [{"type": "slider", "x": float(x), "y": float(y)}
                for x, y in self.wheel_positions.tolist()]

    def _with_derating(self, derating: tuple[float, ...]) -> SliderRobot:
        return replace(self, derating=derating)


@checked_arguments(RobotError)
def slider(
    *,
    rail_angles: ArrayLike,
    stroke: ArrayLike,
    wheel_radius: ArrayLike,
    max_wheel_speed: ArrayLike,
    max_steer_rate: ArrayLike,
    max_slider_speed: ArrayLike,
    name: str = "slider",
    allow_unusual: bool = False,
) -> SliderRobot:
    """A robot of steered wheels on radial sliders (see the module docstring).

    Args:
        rail_angles: (n,) each rail's angle from the body x axis [rad], n >= 2.
        stroke: ``(l_min, l_max)`` [m], ``0 < l_min < l_max``: the contact point's distance
            from the body origin, one pair or one per unit.
        wheel_radius: [m], one value or one per unit.
        max_wheel_speed: drive-rate limit [rad/s], one value or one per unit.
        max_steer_rate: steer-rate limit [rad/s], one value or one per unit.
        max_slider_speed: slider-rate limit [m/s], one value or one per unit.
        name: a label.
        allow_unusual: accept sizes and limits beyond any real robot's
            (:mod:`mpc.plausibility`); otherwise they raise RobotError naming the likely
            unit mistake.
    """
    robot = SliderRobot(rail_angles, name=name, stroke=stroke, wheel_radius=wheel_radius,
                        max_speed=max_wheel_speed, max_steer_rate=max_steer_rate,
                        max_slider_speed=max_slider_speed)
    check_plausible({"stroke": (SIZE, robot.strokes),
                     "wheel_radius": (WHEEL_RADIUS, robot.radii),
                     "max_wheel_speed": (WHEEL_SPEED, robot.max_speed),
                     "max_steer_rate": (STEER_RATE, robot.max_steer_rates)}, allow_unusual)
    return robot


register("slider", slider)
# In the mobility analysis: the slider takes up the axle's motion, so a unit whose slider
# is free adds no sliding constraint (at an end of its stroke it is a steered wheel).
register_wheel_kind("slider", WheelKind(frozenset({"x", "y"}), frozenset({"heading"})))
