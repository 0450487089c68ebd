"""A slider robot's joint rows and the steer schedule its plans are built on.

For unit ``i`` (rail angle ``a``, wheel radius ``r``) at steer angle ``b`` and slider
position ``l`` the joint rates are linear in the twist ``u`` (:mod:`.kinematics`)::

    ldot   = L(b, l) u,  L = -[cos(a+b), sin(a+b), l sin b] / cos b
    phidot = D(b, l) u,  D = ([-sin(a+b), cos(a+b), l cos b] - sin b L) / r

The steer angles are commanded, not set by the motion: each tick the controller chooses
a schedule of them over the plan (:func:`steer_schedule`) from the plan it starts from
(the shifted last one), turning each unit at most ``max_steer_rate`` towards the angle
at which it rolls along the motion its contact point needs next, with its slider drifting
back towards mid-stroke (:data:`CENTRING_RATE`). A unit may turn through 90 degrees from
the rail's normal (the wheel along the rail: a steered wheel whose slider is redundant);
its rows are never taken within :data:`MIN_COS_STEER` of it. Both solvers then choose
the twists with every joint limit at the schedule's angles: drive rate, slider rate, and
the stroke.

The joint parameter vector each tick (:func:`joint_parameters`) is ``(b_0 (n), l_0 (n),
M (N, n))``: the measured steer angles [rad] and slider positions [m], and each stage's
mid-stage steer angle [rad] (the schedule's angle is linear over a stage; its rows are
taken at the middle, as the command's rates are).
"""

from __future__ import annotations

import math
from typing import Protocol

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray

#: Smallest ``|cos b|`` a row is taken at: at ``b = +-90 deg`` the slider runs along the
#: rolling direction and the rows ``~ 1 / cos b`` are not defined; a stage whose mid
#: angle is nearer is taken at this distance (0.6 deg: the slider row then lets the
#: contact move across the wheel at most ``max_slider_speed / 100``: a steered wheel).
MIN_COS_STEER = 0.01
#: How fast a schedule steers the slider back towards mid-stroke, per metre off it [1/s],
#: and at most this fraction of the slider's rate limit.
CENTRING_RATE = 2.0
CENTRING_SHARE = 0.5
#: Contact-point speed [m/s] below which a unit keeps its angle (no direction to aim at).
AIM_SPEED = 0.02


class SliderGeometry(Protocol):
    """What the helpers read of a slider robot (:class:`.robot.SliderRobot`)."""

    @property
    def n_wheels(self) -> int: ...
    @property
    def rail_angles(self) -> FloatArray: ...  # (n,) [rad]
    @property
    def strokes(self) -> FloatArray: ...  # (n, 2) [m]
    @property
    def radii(self) -> FloatArray: ...  # (n,) [m]
    @property
    def max_wheel_speed(self) -> FloatArray: ...  # (n,) [rad/s], derated
    @property
    def max_steer_rates(self) -> FloatArray: ...  # (n,) [rad/s]
    @property
    def max_slider_speeds(self) -> FloatArray: ...  # (n,) [m/s]


def joint_rows(robot: SliderGeometry, angles: FloatArray,
               positions: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Drive rows ``D`` [rad/s per twist unit] and slider rows ``L`` [m/s per twist unit],
    each (..., n, 3), at steer angles and slider positions (..., n) (module docstring)."""
    a = robot.rail_angles
    heading = a + angles
    ch, sh = np.cos(heading), np.sin(heading)
    cb, sb = np.cos(angles), np.sin(angles)
    slide = np.stack([-ch / cb, -sh / cb, -positions * sb / cb], axis=-1)
    roll = np.stack([-sh, ch, positions * cb], axis=-1)
    drive = (roll - sb[..., None] * slide) / robot.radii[:, None]
    return drive, slide


def symbolic_rows(robot: SliderGeometry, angle: ca.SX, position: ca.SX,
                  i: int) -> tuple[ca.SX, ca.SX]:
    """Unit ``i``'s drive and slider rows (1 x 3) at a symbolic steer angle [rad] and
    slider position [m]."""
    a = float(robot.rail_angles[i])
    r = float(robot.radii[i])
    ch, sh = ca.cos(a + angle), ca.sin(a + angle)
    cb, sb = ca.cos(angle), ca.sin(angle)
    slide = ca.horzcat(-ch / cb, -sh / cb, -position * sb / cb)
    roll = ca.horzcat(-sh, ch, position * cb)
    return (roll - sb * slide) / r, slide


def contact_velocities(robot: SliderGeometry, twist: FloatArray,
                       positions: FloatArray) -> FloatArray:
    """The body's velocity at each contact point (n, 2) [m/s] for ``twist`` (3,)."""
    a = robot.rail_angles
    vx, vy, omega = (float(v) for v in twist)
    return np.stack([vx - omega * positions * np.sin(a), vy + omega * positions * np.cos(a)],
                    axis=-1)


def aim_angles(robot: SliderGeometry, twist: FloatArray, positions: FloatArray,
               current: FloatArray) -> FloatArray:
    """Steer angles (n,) [rad] at which each unit rolls along its contact point's motion
    for ``twist`` plus a slider drift back towards mid-stroke, the representative (mod pi)
    nearest ``current``; a unit whose contact barely
    moves keeps ``current``."""
    a = robot.rail_angles
    middle = robot.strokes.mean(axis=1)
    centring = np.clip(CENTRING_RATE * (middle - positions),
                       -CENTRING_SHARE * robot.max_slider_speeds,
                       CENTRING_SHARE * robot.max_slider_speeds)
    # the wheel's ground velocity v(C) + ldot * rail must lie along the rolling direction
    ground = contact_velocities(robot, twist, positions)
    ground[:, 0] += centring * np.cos(a)
    ground[:, 1] += centring * np.sin(a)
    aim = np.arctan2(ground[:, 1], ground[:, 0]) - 0.5 * math.pi - a
    aim = current + np.mod(aim - current + 0.5 * math.pi, math.pi) - 0.5 * math.pi
    moving = np.hypot(ground[:, 0], ground[:, 1]) > AIM_SPEED
    return np.where(moving, aim, current)


def stage_durations(change_times: FloatArray) -> FloatArray:
    """Each stage's duration (N,) [s] from the model's change times ``(tick, h_0, ..,
    h_{N-2})``: ``(h_0, .., h_{N-2}, h_{N-2})`` (the last stage as long as the one before;
    a one-stage plan lasts the tick)."""
    times = np.asarray(change_times, dtype=float)
    if len(times) == 1:
        return times.copy()
    return np.concatenate([times[1:], times[-1:]])


def steer_schedule(robot: SliderGeometry, angles: FloatArray, positions: FloatArray,
                   twists: FloatArray, durations: FloatArray,
                   aims: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """The steer angles at the stages' ends (N+1, n) [rad] and the slider positions at
    their starts (N+1, n) [m] along a plan of ``twists`` (N, 3) held for ``durations``
    (N,) [s], from the measured ``angles`` and ``positions`` (n,): each stage turns each unit
    at most ``max_steer_rate * h`` towards :func:`aim_angles` of the next stage's twist in
    ``aims`` (N, 3) (default ``twists``); the sliders move at the rates ``twists`` then ask,
    stopped at their stroke's ends."""
    aims = twists if aims is None else aims
    horizon = len(durations)
    n = robot.n_wheels
    low, high = robot.strokes[:, 0], robot.strokes[:, 1]
    ends = np.empty((horizon + 1, n))
    where = np.empty((horizon + 1, n))
    ends[0], where[0] = angles, np.clip(positions, low, high)
    reach = robot.max_steer_rates * (1.0 - 1e-9)
    for k in range(horizon):
        ahead = aims[min(k + 1, horizon - 1)]
        aim = aim_angles(robot, ahead, where[k], ends[k])
        turn = np.clip(aim - ends[k], -reach * durations[k], reach * durations[k])
        ends[k + 1] = ends[k] + turn
        middle = middle_angles(ends[k:k + 2])[0]
        _, slide = joint_rows(robot, middle, where[k])
        where[k + 1] = np.clip(where[k] + durations[k] * (slide @ twists[k]), low, high)
    return ends, where


def middle_angles(ends: FloatArray) -> FloatArray:
    """Each stage's mid angle (N, n) [rad] of stage-end angles (N+1, n), moved to
    :data:`MIN_COS_STEER` from +-90 deg where nearer (the angle the stage's rows and the
    command's rates are taken at)."""
    middle = 0.5 * (ends[:-1] + ends[1:])
    # the angle from the nearest +-90 deg, in (-pi/2, pi/2]
    off = np.mod(middle, math.pi) - 0.5 * math.pi
    gap = math.asin(MIN_COS_STEER)
    near = np.abs(off) < gap
    return np.where(near, middle - off + np.where(off >= 0.0, gap, -gap), middle)


def joint_parameters(angles: FloatArray, positions: FloatArray, ends: FloatArray) -> FloatArray:
    """The joint parameter vector (module docstring) of measured ``angles``, ``positions``
    (n,) and a schedule's stage-end angles (N+1, n)."""
    return np.concatenate([angles, positions, middle_angles(ends).ravel()])


def split_parameters(vector: FloatArray, n: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(b_0 (n,), l_0 (n,), M (N, n))`` of a joint parameter vector."""
    return vector[:n], vector[n:2 * n], vector[2 * n:].reshape(-1, n)
