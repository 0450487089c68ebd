"""A slider robot's joint limits for both solvers and the clamp, at the steer schedule's
angles (:mod:`.rows`).

Every stage ``k`` of a plan has, for every unit, its drive row ``|D(M_k, l_k) u_k| <=
max_wheel_speed`` and its slider row ``L(M_k, l_k) u_k`` within ``max_slider_speed`` and
within what keeps the slider in its stroke over the stage,
``l_min <= l_k + h_k L(M_k, l_k) u_k <= l_max``. The steer rate holds by the schedule's
construction (each stage turns a unit at most ``max_steer_rate h_k``).

- **Exact path** (IPOPT, :func:`nlp_stage_limits`): the slider positions ``l_k`` are
  integrated symbolically from the measured ones along the plan's own twists, and every
  row is exact at them.
- **Fast path** (QP, :func:`update_stage_limits`): ``l_k`` are predicted along the plan the
  solver starts from (the shifted last plan), the rows filled there: linear in ``u_k``.
  Stage 0 starts at the measured positions, so the command's own rows are exact; later
  stages' move with the plan from tick to tick (real-time iteration). The positions are
  predicted with the stroke's stops, so the plan at rest is always within every row.
- **Clamp** (:func:`clamp_at`): the command scaled into stage 0's rows.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.slider.rows import (
    SliderGeometry,
    joint_rows,
    split_parameters,
    stage_durations,
    symbolic_rows,
)


def stage_limits(robot: SliderGeometry, change_times: FloatArray) -> StageLimits:
    """``n`` drive rows and ``n`` slider rows a stage, filled with the units at mid-stroke
    and their steer angles 0 until the first tick refills them."""
    n = robot.n_wheels
    horizon = len(change_times)
    now = np.zeros((horizon, 2 * n, 3))
    bound = np.zeros((horizon, 2 * n))
    bound[:, :n] = robot.max_wheel_speed
    bound[:, n:] = robot.max_slider_speeds
    limits = StageLimits(now=now, before=np.zeros_like(now), lower=-bound, upper=bound.copy(),
                         constant=False, change_times=np.array(change_times, dtype=float))
    limits.memory["durations"] = stage_durations(change_times)
    middle = np.tile(robot.strokes.mean(axis=1), (horizon, 1))
    _fill(robot, limits, np.zeros((horizon, n)), middle)
    return limits


def predicted_positions(robot: SliderGeometry, positions: FloatArray, middles: FloatArray,
                        twists: FloatArray, durations: FloatArray) -> FloatArray:
    """Slider positions at the stages' starts (N, n) [m] along ``twists`` (N, 3) at the
    schedule's mid-stage angles ``middles`` (N, n), from ``positions`` (n,), stopped at the
    stroke's ends."""
    low, high = robot.strokes[:, 0], robot.strokes[:, 1]
    where = np.empty_like(middles)
    where[0] = np.clip(positions, low, high)
    for k in range(len(where) - 1):
        _, slide = joint_rows(robot, middles[k], where[k])
        where[k + 1] = np.clip(where[k] + durations[k] * (slide @ twists[k]), low, high)
    return where


def _fill(robot: SliderGeometry, limits: StageLimits, middles: FloatArray,
          where: FloatArray) -> None:
    n = robot.n_wheels
    drive, slide = joint_rows(robot, middles, where)  # (N, n, 3)
    limits.now[:, :n] = drive
    limits.now[:, n:] = slide
    durations = limits.memory["durations"][:, None]
    speed = robot.max_slider_speeds
    limits.lower[:, n:] = np.maximum(-speed, (robot.strokes[:, 0] - where) / durations)
    limits.upper[:, n:] = np.minimum(speed, (robot.strokes[:, 1] - where) / durations)
    limits.changed = True


def update_stage_limits(robot: SliderGeometry, limits: StageLimits, guess: FloatArray,
                        joints: FloatArray | None) -> None:
    """Refill every stage's rows at the schedule's angles and the slider positions the
    guess twists (N, 3) move the sliders to from the measured ones (``joints``: the joint
    parameter vector of :mod:`.rows`)."""
    if joints is None:
        raise RobotError("a slider robot's limits need its joint parameters (steer schedule "
                         "and slider positions)")
    _, positions, middles = split_parameters(joints, robot.n_wheels)
    where = predicted_positions(robot, positions, middles, guess,
                                limits.memory["durations"])
    limits.memory["positions"] = where
    _fill(robot, limits, middles, where)


def nlp_stage_limits(robot: SliderGeometry, twists: ca.SX, joints: ca.SX | None,
                     change_times: FloatArray
                     ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
    """Exact joint limits, the slider positions integrated symbolically from the measured
    ones along the plan's twists (3 x N) at the schedule's angles (``joints``: the joint
    parameter vector as a symbol)."""
    if joints is None:
        raise RobotError("a slider robot's NLP needs its joint parameters as a parameter")
    n = robot.n_wheels
    durations = stage_durations(change_times)
    speed, slide_max = robot.max_wheel_speed, robot.max_slider_speeds
    low, high = robot.strokes[:, 0].copy(), robot.strokes[:, 1].copy()
    values: list[ca.SX] = []
    lower: list[FloatArray] = []
    upper: list[FloatArray] = []
    positions = [joints[n + i] for i in range(n)]
    for k in range(twists.shape[1]):
        u = twists[:, k]
        rows = [symbolic_rows(robot, joints[2 * n + k * n + i], positions[i], i)
                for i in range(n)]
        drive = ca.vertcat(*[row[0] @ u for row in rows])
        slide = [row[1] @ u for row in rows]
        positions = [positions[i] + float(durations[k]) * slide[i] for i in range(n)]
        values += [drive, ca.vertcat(*slide), ca.vertcat(*positions)]
        lower += [-speed, -slide_max, low.copy()]
        upper += [speed.copy(), slide_max.copy(), high.copy()]
    return values, lower, upper


def stage_zero_rows(robot: SliderGeometry, joints: FloatArray,
                    dt: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Stage 0's rows (2n, 3) and bounds (2n,), (2n,) at the measured positions and the
    schedule's first mid-stage angles, for a stage of ``dt`` [s]."""
    _, positions, middles = split_parameters(joints, robot.n_wheels)
    where = np.clip(positions, robot.strokes[:, 0], robot.strokes[:, 1])
    drive, slide = joint_rows(robot, middles[0], where)
    speed = robot.max_slider_speeds
    lower = np.concatenate([-robot.max_wheel_speed,
                            np.maximum(-speed, (robot.strokes[:, 0] - where) / dt)])
    upper = np.concatenate([robot.max_wheel_speed,
                            np.minimum(speed, (robot.strokes[:, 1] - where) / dt)])
    return np.concatenate([drive, slide]), lower, upper


#: How far past a row's bound the clamp leaves a twist unscaled, relative to the row's rate
#: limit: a solver's rounding (IPOPT's bounds are relaxed by 1e-8 of their size), not a
#: broken row. The command's joint rates are then clipped into the bounds exactly.
CLAMP_TOLERANCE = 1e-6


def clamp_at(robot: SliderGeometry, target: FloatArray, joints: FloatArray,
             dt: float) -> tuple[FloatArray, bool]:
    """``target`` scaled by the largest factor in [0, 1] that keeps it within stage 0's
    rows (the rows are linear and hold at rest), and whether it was scaled. A row past its
    bound by at most :data:`CLAMP_TOLERANCE` of its rate limit does not scale it (a slider
    at a stroke's end has a bound of 0 there, and a solver's rounding past it would stop
    the robot)."""
    rows, lower, upper = stage_zero_rows(robot, joints, dt)
    values = rows @ target
    slack = CLAMP_TOLERANCE * np.concatenate([robot.max_wheel_speed, robot.max_slider_speeds])
    scale = 1.0
    over = values > upper + slack
    under = values < lower - slack
    if over.any():
        scale = min(scale, float((upper[over] / values[over]).min()))
    if under.any():
        scale = min(scale, float((lower[under] / values[under]).min()))
    if scale < 1.0:
        return target * max(0.0, scale * (1.0 - 1e-12)), True
    return target, False


def command_rates(robot: SliderGeometry, twist: FloatArray, joints: FloatArray,
                  dt: float) -> tuple[FloatArray, FloatArray]:
    """Drive rates [rad/s] and slider rates [m/s] (n,) for a clamped ``twist`` at stage 0's
    rows, clipped into their bounds (what is left past them is the solver's rounding)."""
    rows, lower, upper = stage_zero_rows(robot, joints, dt)
    rates = np.clip(rows @ twist, lower, upper)
    n = robot.n_wheels
    return rates[:n], rates[n:]
