"""The reactive baseline for slider robots: feedforward plus P pose feedback, each unit
steered toward its contact point's commanded motion at the steer-rate limit, and every
joint rate clipped to its limit, the slider's also at the ends of its stroke
(``saturation="clip"``, the default); or, with ``"desaturate"``, the whole twist scaled
until every drive and slider rate is within those bounds (WPILib-style).
:class:`~mpc.sim.FeedforwardPController` of a slider robot builds this one.

It sees only rates, one tick at a time: a slider that runs to an end stops there (its
rate clipped to zero outward) while its wheel still points where the steering had got
to, so the wheels disagree on one rigid motion and the robot leaves its course. That is
what a plan over the joint states avoids (:class:`mpc.control.slider.SliderController`).
"""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import ArrayLike

from mpc.angles import wrap_angle
from mpc.control.command import Status
from mpc.control.slider import SliderCommand
from mpc.errors import ControllerError
from mpc.robots.wheels.slider.robot import SliderRobot
from mpc.robots.wheels.slider.rows import contact_velocities, middle_angles
from mpc.sim.baselines import SATURATIONS, register_baseline
from mpc.validation import is_finite_number, shown
from trajectories import Trajectory


class ReactiveSliderController:
    """The reactive baseline (module docstring).

    Args:
        robot: the slider robot and its limits.
        trajectory: the reference.
        dt: control tick [s].
        gains: (K_xy, K_theta) [1/s], as :class:`~mpc.sim.FeedforwardPController`'s.
        saturation: ``"clip"`` (each joint rate into its bounds) or ``"desaturate"`` (the
            twist scaled until every one is within them).
    """

    def __init__(self, robot: SliderRobot, trajectory: Trajectory, dt: float = 0.05,
                 gains: tuple[float, float] = (4.0, 4.0), saturation: str = "clip") -> None:
        if not isinstance(robot, SliderRobot):
            raise ControllerError(f"ReactiveSliderController drives slider robots, got "
                                  f"{type(robot).__name__}")
        if not isinstance(trajectory, Trajectory):
            raise ControllerError(f"trajectory must be a trajectories.Trajectory, got "
                                  f"{type(trajectory).__name__}")
        if not is_finite_number(dt) or dt <= 0:
            raise ControllerError(f"dt must be a finite number of seconds > 0, got {shown(dt)}")
        if saturation not in SATURATIONS:
            raise ControllerError(f"unknown saturation {shown(saturation)}; expected one of "
                                  f"{list(SATURATIONS)}")
        self.robot = robot
        self.trajectory = trajectory
        self.dt = float(dt)
        self.gains = np.asarray(gains, dtype=float)
        self.saturation = saturation

    def reset(self) -> None:
        """Nothing to forget: each tick stands alone."""

    def step(self, pose: ArrayLike, t: float, steer_angles: ArrayLike | None = None,
             slider_positions: ArrayLike | None = None) -> SliderCommand:
        """The command for the measured pose and joint states at time ``t`` [s]."""
        start = time.perf_counter()
        robot = self.robot
        x = np.asarray(pose, dtype=float)
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise ControllerError(f"pose must be a finite (3,) pose, got {shown(pose)}")
        if steer_angles is None or slider_positions is None:
            raise ControllerError("a slider robot needs its measured steer_angles and "
                                  "slider_positions each tick")
        angles, positions = robot.check_joints(steer_angles, slider_positions, ControllerError)
        positions = np.clip(positions, robot.strokes[:, 0], robot.strokes[:, 1])
        reference = self.trajectory.sample(t)
        ahead = self.trajectory.sample(t + 0.5 * self.dt)  # the command is held over the tick
        error = reference.pose - x
        error[2] = float(wrap_angle(error[2]))
        world = ahead.velocity[:2] + self.gains[0] * error[:2]
        c, s = math.cos(x[2]), math.sin(x[2])
        target = np.array([c * world[0] + s * world[1], -s * world[0] + c * world[1],
                           ahead.velocity[2] + self.gains[1] * error[2]])
        # steer toward rolling along the contact's commanded motion, at the rate limit
        ground = contact_velocities(robot, target, positions)
        aim = np.arctan2(ground[:, 1], ground[:, 0]) - 0.5 * math.pi - robot.rail_angles
        aim = angles + np.mod(aim - angles + 0.5 * math.pi, math.pi) - 0.5 * math.pi
        aim = np.where(np.hypot(ground[:, 0], ground[:, 1]) > 1e-6, aim, angles)
        steer = np.clip((aim - angles) / self.dt, -robot.max_steer_rates, robot.max_steer_rates)
        middle = middle_angles(np.stack([angles, angles + self.dt * steer]))[0]
        drive_rows, slide_rows = robot.slider_rows(middle, positions)
        speed = robot.max_slider_speeds
        low = np.concatenate([-robot.max_wheel_speed,
                              np.maximum(-speed, (robot.strokes[:, 0] - positions) / self.dt)])
        high = np.concatenate([robot.max_wheel_speed,
                               np.minimum(speed, (robot.strokes[:, 1] - positions) / self.dt)])
        rows = np.concatenate([drive_rows, slide_rows])
        wanted = rows @ target
        if self.saturation == "desaturate":
            with np.errstate(divide="ignore", invalid="ignore"):
                ratios = np.where(wanted > high, high / wanted,
                                  np.where(wanted < low, low / wanted, 1.0))
            twist = target * max(0.0, min(1.0, float(ratios.min())))
            rates = np.clip(rows @ twist, low, high)  # rounding only
        else:
            twist = target
            rates = np.clip(wanted, low, high)
        n = robot.n_wheels
        drive, slide = rates[:n], rates[n:]
        return SliderCommand(
            wheel_speeds=drive, twist=twist, steer_angles=angles + steer * self.dt,
            predicted_poses=reference.pose[None, :], status=Status.SOLVED,
            solver_status="none", solve_time=0.0, tick_time=time.perf_counter() - start,
            iterations=0, consecutive_failures=0,
            clamped=not np.allclose(rates, wanted), reference_time=float(t),
            steer_rates=steer, slider_rates=slide)


register_baseline("slider", ReactiveSliderController)
