"""A slider robot's closed loop on the independent plant (:mod:`.slider_plant`): any
controller whose ``step(pose, t, steer_angles=, slider_positions=)`` returns drive, steer
and slider rates (:class:`~mpc.control.slider.SliderController`, the reactive baseline
:class:`~mpc.sim.slider_baseline.ReactiveSliderController`), and what it did."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mpc.arrays import FloatArray
from mpc.control.command import Status
from mpc.errors import SimulationError
from mpc.sim.slider_plant import SliderPlant, start_angles
from trajectories.base import body_twist


@dataclass(frozen=True)
class SliderRun:
    """One closed-loop run.

    Attributes:
        times: (K+1,) [s]. poses, references: (K+1, 3) actual and reference poses.
        steer_angles, slider_positions: (K+1, n) the plant's joint states [rad], [m].
        rms_error, max_error: position error's RMS and peak over the run [m].
        rate_violations: ticks with a commanded rate over its limit (the plant's count).
        peak_ratios: the largest commanded |rate| / limit, (drive, steer, slider).
        stroke_violations: ticks on which a command carried a slider into a stop.
        overtravel: how far past its stroke a command would have carried a slider [m].
        failures: ticks whose plan failed (the fallback's command).
        mean_tick: mean controller time a tick [s].
        peak_slip: largest slip speed at a contact [m/s].
    """

    times: FloatArray
    poses: FloatArray
    references: FloatArray
    steer_angles: FloatArray
    slider_positions: FloatArray
    rms_error: float
    max_error: float
    rate_violations: int
    peak_ratios: FloatArray
    stroke_violations: int
    overtravel: float
    failures: int
    mean_tick: float
    peak_slip: float


def run_slider(controller: Any, duration: float, plant: SliderPlant | None = None) -> SliderRun:
    """Run ``controller`` (with ``robot``, ``trajectory`` and ``dt``) for ``duration`` [s] on
    ``plant`` (default: a :class:`SliderPlant` of its robot at the reference's start pose,
    sliders at mid-stroke, each wheel aimed to roll along its contact's motion at the
    reference's start: :func:`start_angles`)."""
    dt = float(controller.dt)
    if not math.isfinite(duration) or duration <= 0:
        raise SimulationError(f"duration must be a finite number of seconds > 0, got {duration}")
    trajectory = controller.trajectory
    if plant is None:
        start = trajectory.sample(0.0)
        plant = SliderPlant(controller.robot, start.pose,
                            steer_angles=start_angles(controller.robot, body_twist(start)))
    ticks = int(round(duration / dt))
    times = dt * np.arange(ticks + 1, dtype=float)
    poses = [plant.pose.copy()]
    angles = [plant.steer_angles.copy()]
    positions = [plant.slider_positions.copy()]
    failures = 0
    spent = 0.0
    for k in range(ticks):
        command = controller.step(plant.pose.copy(), float(times[k]),
                                  steer_angles=plant.steer_angles.copy(),
                                  slider_positions=plant.slider_positions.copy())
        failures += command.status is not Status.SOLVED
        spent += command.tick_time
        plant.step(command.wheel_speeds, command.steer_rates, command.slider_rates, dt)
        poses.append(plant.pose.copy())
        angles.append(plant.steer_angles.copy())
        positions.append(plant.slider_positions.copy())
    pose_array = np.array(poses)
    references = np.asarray(trajectory.sample(times).pose, dtype=float)
    error = np.hypot(*(pose_array[:, :2] - references[:, :2]).T)
    return SliderRun(
        times=times, poses=pose_array, references=references, steer_angles=np.array(angles),
        slider_positions=np.array(positions), rms_error=float(np.sqrt(np.mean(error**2))),
        max_error=float(error.max()), rate_violations=plant.rate_violations,
        peak_ratios=plant.peak_ratios.copy(), stroke_violations=plant.stroke_violations,
        overtravel=plant.overtravel, failures=failures, mean_tick=spent / max(ticks, 1),
        peak_slip=plant.peak_slip)
