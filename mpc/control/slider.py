"""The tracking controller for robots of steered wheels on radial sliders (SWOM).

:class:`SliderController` is :class:`~mpc.control.Controller` with the slider's joint
states: each tick it takes the measured steer angles and slider positions, chooses the
plan's steer schedule from the plan it starts from (:mod:`mpc.robots.wheels.slider.rows`:
within the steer-rate limit, aiming each unit along its contact point's coming motion with
its slider drifting back to mid-stroke), hands it with the positions to the solver (the
fast path and IPOPT alike plan the twists within the drive-rate, slider-rate and stroke
limits along it, :mod:`mpc.robots.wheels.slider.limits`), and commands each unit's drive,
steer and slider rates for the tick (:class:`SliderCommand`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.control.command import Command
from mpc.control.controller import Controller, register_controller
from mpc.control.measurements import check_pose, check_time
from mpc.errors import ControllerError
from mpc.model.layout import TickInput
from mpc.robots.wheels.slider.limits import clamp_at, command_rates
from mpc.robots.wheels.slider.robot import SliderRobot
from mpc.robots.wheels.slider.rows import joint_parameters
from mpc.validation import checked_arguments
from trajectories import Trajectory, TrajectoryError

__all__ = ["SliderCommand", "SliderController"]

#: What the steer schedule aims the units along: this share of the reference's twists and
#: the rest of the plan's (the shifted last plan). Aimed along the plan alone, a unit that
#: the plan's own rows hold (a wheel along its rail cannot move its contact across) keeps
#: the plan where it is, tick after tick.
AIM_MIX = 1.0


@dataclass(frozen=True, eq=False)
class SliderCommand(Command):
    """A :class:`~mpc.control.Command` for a slider robot: ``wheel_speeds`` are the drive
    rates [rad/s] (n,), ``steer_rates`` the steer rates [rad/s] (n,) and ``steer_angles``
    the angles they reach at the tick's end [rad]; besides:

    Attributes:
        slider_rates: each slider's rate to hold over the tick [m/s] (n,).
        planned_steer_angles: the steer schedule at the plan's stage ends (N+1, n) [rad].
        planned_slider_positions: the slider positions at the plan's stage starts
            (N+1, n) [m], along the plan the solver started from.
    """

    slider_rates: FloatArray | None = None
    planned_steer_angles: FloatArray | None = None
    planned_slider_positions: FloatArray | None = None


class _ScheduledWarmStart:
    """The controller's warm start, with the steer schedule filled into the tick's joint
    parameters whenever it fills the guess (the solvers then see the schedule of the guess
    they start from)."""

    def __init__(self, warm: Any, fill: Any) -> None:
        self._warm = warm
        self._fill = fill

    def fill(self, *args: Any, **kwargs: Any) -> None:
        self._warm.fill(*args, **kwargs)
        self._fill()

    def hold(self, *args: Any, **kwargs: Any) -> None:
        self._warm.hold(*args, **kwargs)
        self._fill()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._warm, name)


class SliderController(Controller):
    """Model-predictive tracking for a :class:`~mpc.robots.SliderRobot` (module docstring).

    Takes :class:`~mpc.control.Controller`'s arguments; :meth:`step` also takes the
    measured joint states and returns a :class:`SliderCommand`.
    """

    @checked_arguments(ControllerError)
    def __init__(self, robot: SliderRobot, trajectory: Trajectory, *args: Any,
                 **kwargs: Any) -> None:
        if not isinstance(robot, SliderRobot):
            raise ControllerError(f"SliderController drives slider robots "
                                  f"(mpc.robots.slider), got {type(robot).__name__}")
        self._angles = np.zeros(robot.n_wheels)
        self._positions = robot.initial_slider_positions()
        self._ends = np.tile(self._angles, (2, 1))
        self._where = np.tile(self._positions, (2, 1))
        super().__init__(robot, trajectory, *args, **kwargs)
        self.robot: SliderRobot = robot
        self._warm = _ScheduledWarmStart(self._warm, self._fill)  # type: ignore[assignment]

    def reset(self, last_twist: ArrayLike | None = None,
              steer_angles: ArrayLike | None = None) -> None:
        """As :meth:`Controller.reset`; the joint states come with each :meth:`step`."""
        if steer_angles is not None:
            raise ControllerError("a slider robot's steer angles come with each step(): "
                                  "step(pose, t, steer_angles=..., slider_positions=...)")
        super().reset(last_twist)
        self._steer = None  # the joint parameters are filled by the schedule, not here

    def _fill(self) -> None:
        """The steer schedule along the tick's guess, into its joint parameters."""
        tick = self._tick
        self._schedule(tick, tick.guess_twists, AIM_MIX * tick.twists_ref
                       + (1.0 - AIM_MIX) * tick.guess_twists)

    def _schedule(self, tick: TickInput, twists: FloatArray, aims: FloatArray) -> None:
        self._ends, self._where = self.robot.steer_schedule(
            self._angles, self._positions, twists, self.model.durations, aims)
        if tick.steer_angles is not None:
            tick.steer_angles[:] = joint_parameters(self._angles, self._positions, self._ends)

    @checked_arguments(ControllerError)
    def step(self, pose: ArrayLike, t: float,  # type: ignore[override]
             steer_angles: ArrayLike | None = None,
             slider_positions: ArrayLike | None = None) -> SliderCommand:
        """Plan from the measured pose and joint states at time ``t`` and return this
        tick's command.

        Args:
            pose: measured world pose (x, y, theta) [m, m, rad], shape (3,).
            t: the current time on the trajectory's clock [s].
            steer_angles: each unit's measured steer angle from its rail's normal [rad] (n,).
            slider_positions: each unit's measured slider position [m] (n,).
        """
        start = time.perf_counter()
        if steer_angles is None or slider_positions is None:
            raise ControllerError("a slider robot needs its measured joint states each tick: "
                                  "step(pose, t, steer_angles=<n angles [rad]>, "
                                  "slider_positions=<n positions [m]>)")
        robot = self.robot
        measured_pose = check_pose(pose, self.allow_unusual)
        x0 = self._delay.predict(measured_pose)
        t_now = check_time(t)
        angles, positions = robot.check_joints(steer_angles, slider_positions, ControllerError)
        self._angles = angles
        self._positions = np.clip(positions, robot.strokes[:, 0], robot.strokes[:, 1])
        tick = self._tick
        t_plan = t_now + self._delay.lead
        try:
            reference_time = self._timing.fill(t_now, t_plan, float(x0[2]))
        except TrajectoryError as error:
            reference_time, result = t_plan, self._unplanned(f"reference failed: {error}")
        else:
            if self._first_tick:
                self._check_heading(float(measured_pose[2]))
            result = self._solve(x0)
        status, target, plan = self._outcome(result, x0)
        if not result.success:  # the schedule along the command held
            held = np.tile(np.nan_to_num(target), (self.horizon, 1))
            self._schedule(tick, held, held)
        joints = joint_parameters(self._angles, self._positions, self._ends)
        twist, clamped = clamp_at(robot, np.nan_to_num(target), joints, self.dt)
        drive, slide = command_rates(robot, twist, joints, self.dt)
        steer_rates = (self._ends[1] - self._ends[0]) / self.dt
        self._last = twist
        self._delay.sent(twist)
        return SliderCommand(
            wheel_speeds=drive, twist=twist, steer_angles=self._ends[1].copy(),
            predicted_poses=plan, status=status, solver_status=result.status,
            solve_time=result.solve_time, tick_time=time.perf_counter() - start,
            iterations=result.iterations, consecutive_failures=self._fallback.failures,
            clamped=clamped, reference_time=reference_time, lag=t_plan - reference_time,
            steer_rates=steer_rates, slider_rates=slide,
            planned_steer_angles=self._ends.copy(), planned_slider_positions=self._where.copy())


register_controller("slider", SliderController)
