"""An independent plant for slider robots: it integrates each unit's joint states from the
commanded joint rates with its own code, and the body's motion from them.

Each tick the commanded drive, steer and slider rates are held (a motor cannot run past
its limit: a rate over it runs at the limit, and the plant counts it). Within the tick, in
:attr:`SliderPlant.substeps` steps, every steer angle turns at its rate, every slider moves
at its rate until a stop at either end of its stroke holds it there (the plant counts the
units that met a stop and reports how far past the end the command would have carried
them), and the body moves at the least-squares twist of the wheels' rolling and no-slip
equations at the joints' present values (the residual is slip; the plant records the
largest). The pose is integrated exactly for a twist held over a substep.

It shares no code with the controller's model: the equations are written out here, the
joints move within the tick while the controller holds its rows at mid-tick values, and
the stops are hard.

:class:`SliderSimPlant` puts it behind :func:`mpc.sim.simulate`'s plant (registered for
slider robots: ``simulate`` and ``mpc-bench`` runs use it).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.command import Command
from mpc.errors import SimulationError
from mpc.robots.wheels.slider.robot import SliderRobot
from mpc.sim.plant import PlantConfig
from mpc.sim.simulate import register_plant
from trajectories import Trajectory
from trajectories.base import body_twist

#: Relative slack under which a commanded rate counts as within its limit (rounding).
RATE_SLACK = 1e-9
#: How far past a stroke's end [m] a command may carry a slider and count as within it.
STROKE_SLACK = 1e-9


def _twist_step(pose: FloatArray, twist: FloatArray, h: float) -> FloatArray:
    """The pose after a body twist held for ``h`` [s] (exact arc)."""
    x, y, theta = pose
    vx, vy, omega = twist
    turn = omega * h
    if abs(turn) < 1e-9:
        a, b = h * (1.0 - turn * turn / 6.0), h * turn / 2.0
    else:
        a, b = math.sin(turn) / omega, (1.0 - math.cos(turn)) / omega
    dx, dy = a * vx - b * vy, b * vx + a * vy
    c, s = math.cos(theta), math.sin(theta)
    return np.array([x + c * dx - s * dy, y + s * dx + c * dy, theta + turn])


class SliderPlant:
    """The true slider robot (module docstring).

    Args:
        robot: its units and limits.
        pose: the start pose (x, y, theta) [m, m, rad].
        steer_angles: each unit's start steer angle [rad] (default 0).
        slider_positions: each slider's start position [m] (default mid-stroke).
        substeps: integration steps a tick.
    """

    def __init__(self, robot: SliderRobot, pose: ArrayLike = (0.0, 0.0, 0.0),
                 steer_angles: ArrayLike | None = None,
                 slider_positions: ArrayLike | None = None, substeps: int = 10) -> None:
        if not isinstance(robot, SliderRobot):
            raise SimulationError(f"SliderPlant takes a slider robot, got {type(robot).__name__}")
        self.robot = robot
        n = robot.n_wheels
        self.pose = np.array(pose, dtype=float).reshape(3)
        self.steer_angles = (np.zeros(n) if steer_angles is None
                             else np.array(steer_angles, dtype=float).reshape(n))
        self.slider_positions = (robot.strokes.mean(axis=1) if slider_positions is None
                                 else np.array(slider_positions, dtype=float).reshape(n))
        if not isinstance(substeps, int) or substeps < 1:
            raise SimulationError(f"substeps must be an integer >= 1, got {substeps!r}")
        self.substeps = substeps
        self.twist = np.zeros(3)
        #: ticks on which some commanded rate was over its limit (run at the limit).
        self.rate_violations = 0
        #: the largest commanded rate over its limit seen: (drive, steer, slider) ratios.
        self.peak_ratios = np.zeros(3)
        #: ticks on which a command would have carried some slider past its stroke (the stop
        #: held it).
        self.stroke_violations = 0
        #: how far past its stroke's end a command would have carried a slider, at most [m].
        self.overtravel = 0.0
        #: the largest slip speed at a contact [m/s] (the least-squares residual).
        self.peak_slip = 0.0

    def step(self, drive_rates: ArrayLike, steer_rates: ArrayLike, slider_rates: ArrayLike,
             dt: float) -> FloatArray:
        """Hold the commanded rates [rad/s, rad/s, m/s] (n,) for ``dt`` [s]; the new pose."""
        robot = self.robot
        limits = (robot.max_wheel_speed, robot.max_steer_rates, robot.max_slider_speeds)
        rates = []
        over = False
        for index, (value, limit) in enumerate(zip((drive_rates, steer_rates, slider_rates),
                                                   limits, strict=True)):
            rate = np.array(value, dtype=float).reshape(robot.n_wheels)
            if not np.all(np.isfinite(rate)):
                raise SimulationError(f"commanded joint rates must be finite, got {rate}")
            ratio = float(np.max(np.abs(rate) / limit))
            self.peak_ratios[index] = max(self.peak_ratios[index], ratio)
            if ratio > 1.0 + RATE_SLACK:
                over = True
            rates.append(np.clip(rate, -limit, limit))
        self.rate_violations += over
        drive, steer, slide = rates
        h = dt / self.substeps
        low, high = robot.strokes[:, 0], robot.strokes[:, 1]
        unstopped = self.slider_positions + slide * dt
        past = float(np.max(np.maximum(unstopped - high, low - unstopped)))
        if past > STROKE_SLACK:
            self.stroke_violations += 1
            self.overtravel = max(self.overtravel, past)
        for _ in range(self.substeps):
            moved = np.clip(self.slider_positions + slide * h, low, high)
            actual = (moved - self.slider_positions) / h
            middle_angles = self.steer_angles + 0.5 * h * steer
            middle_positions = 0.5 * (self.slider_positions + moved)
            self.twist = self.body_twist(drive, actual, middle_angles, middle_positions)
            self.pose = _twist_step(self.pose, self.twist, h)
            self.steer_angles = self.steer_angles + h * steer
            self.slider_positions = moved
        return self.pose.copy()

    def body_twist(self, drive: FloatArray, slide: FloatArray, angles: FloatArray,
                    positions: FloatArray) -> FloatArray:
        """The least-squares twist of each wheel's rolling and no-slip equations: the
        contact point (at ``positions`` along its rail) moves with the body plus the slider,
        and the wheel's ground velocity is ``r phidot`` along its rolling direction."""
        robot = self.robot
        a = robot.rail_angles
        heading = a + angles
        n = robot.n_wheels
        rows = np.zeros((2 * n, 3))
        right = np.empty(2 * n)
        for i in range(n):
            rail = np.array([math.cos(a[i]), math.sin(a[i])])
            contact = positions[i] * rail
            # body velocity at the contact: [[1, 0, -cy], [0, 1, cx]] u
            moment = np.array([[1.0, 0.0, -contact[1]], [0.0, 1.0, contact[0]]])
            rolling = np.array([-math.sin(heading[i]), math.cos(heading[i])])
            axle = np.array([math.cos(heading[i]), math.sin(heading[i])])
            # (v(C) + ldot rail) . rolling = r phidot;  (v(C) + ldot rail) . axle = 0
            rows[2 * i] = rolling @ moment
            rows[2 * i + 1] = axle @ moment
            right[2 * i] = robot.radii[i] * drive[i] - slide[i] * float(rolling @ rail)
            right[2 * i + 1] = -slide[i] * float(axle @ rail)
        twist, *_ = np.linalg.lstsq(rows, right, rcond=None)
        residual = rows @ twist - right
        slip = float(np.max(np.hypot(residual[0::2], residual[1::2])))
        self.peak_slip = max(self.peak_slip, slip)
        return np.asarray(twist, dtype=float)


def start_angles(robot: SliderRobot, twist: FloatArray) -> FloatArray:
    """Steer angles [rad] (n,) that roll each wheel along its contact's motion for body
    ``twist`` with every slider at mid-stroke and at rest (0 for a contact at rest)."""
    _, angles = robot.wheel_commands(np.asarray(twist, dtype=float), None)
    return np.asarray(angles, dtype=float)


class SliderSimPlant:
    """:class:`SliderPlant` as :func:`mpc.sim.simulate`'s plant: built as
    :class:`~mpc.sim.plant.Plant` is (``config``: its substeps and measurement noise; a
    motor lag, delay or slip is not modelled for slider robots and raises)."""

    def __init__(self, robot: SliderRobot, dt: float, pose: FloatArray, config: PlantConfig,
                 rng: np.random.Generator) -> None:
        unmodelled = [name for name in ("motor_lag", "delay_ticks", "slip")
                      if getattr(config, name) != 0]
        if unmodelled:
            raise SimulationError(f"the slider plant does not model {', '.join(unmodelled)}; "
                                  "use the ideal plant or noise only")
        self.robot = robot
        self.dt = dt
        self.config = config
        self.rng = rng
        self.plant = SliderPlant(robot, pose, substeps=int(config.substeps))

    @property
    def pose(self) -> FloatArray:
        return self.plant.pose

    @property
    def steer_angles(self) -> FloatArray:
        return self.plant.steer_angles

    @steer_angles.setter
    def steer_angles(self, angles: FloatArray) -> None:
        self.plant.steer_angles = np.array(angles, dtype=float)

    def start_along(self, trajectory: Trajectory) -> None:
        """Every wheel aimed along its contact's motion at the reference's start."""
        self.steer_angles = start_angles(self.robot,
                                         body_twist(trajectory.sample(trajectory.start_time)))

    def measure(self) -> FloatArray:
        """The pose a localisation system would report (with the config's noise)."""
        config = self.config
        if config.position_noise == 0.0 and config.heading_noise == 0.0:
            return self.plant.pose.copy()
        noise = self.rng.normal(size=3) * np.array(
            [config.position_noise, config.position_noise, config.heading_noise])
        return self.plant.pose + noise

    def joint_states(self) -> dict[str, FloatArray]:
        """What the controller measures each tick besides the pose."""
        return {"steer_angles": self.plant.steer_angles.copy(),
                "slider_positions": self.plant.slider_positions.copy()}

    def apply(self, command: Command) -> FloatArray:
        """Run one tick under ``command`` (drive, steer and slider rates); the drive rates
        reached [rad/s] (each within its limit)."""
        slide = getattr(command, "slider_rates", None)
        if command.steer_rates is None or slide is None:
            raise SimulationError("a slider robot's command needs steer_rates and "
                                  "slider_rates (a SliderController's or the reactive "
                                  "baseline's)")
        self.plant.step(command.wheel_speeds, command.steer_rates, slide, self.dt)
        limit = self.robot.max_wheel_speed
        return np.clip(np.asarray(command.wheel_speeds, dtype=float), -limit, limit)


register_plant("slider", SliderSimPlant)
