"""``python -m benchmarks.retiming_cases``: the time-optimal retimer's hard cases, measured.

Prints, each with how it was made:

1. ``goal``: a 3 m line that ends by turning in place to its goal yaw, through
   :func:`~trajectories.path_reference` (the position held while it only turns) against the
   plain natural splines through the same poses: how far past the goal each goes [mm].
2. ``repairs``: paths whose curvature jumps inside a grid cell, timed with the repairs
   (:func:`~trajectories.time_optimal`'s ``max_repairs``, default) and without
   (``max_repairs=0``: the whole lap slowed for the worst cell): lap / first solution's lap.
   A monotone (PCHIP) line that ends turning, a caster's spinning figure-eight, a
   figure-eight through 21 samples without accelerations (and its wheel accelerations by
   finite differences, over their limits), a 400- and a 1000-pose path snapped to a 5 cm
   grid through ``path_reference`` with one repair (``Nav2Controller``'s) and none, with
   the time each took to time.
3. ``smoothing``: the snapped paths of 2. through ``path_reference`` smoothed within half a
   cell and 0.4 rad (``position_tolerance``, ``yaw_tolerance``) against as given, and the
   path before it was snapped: laps [s] and the time each took.
4. ``steering``: a 0.3 m figure-eight on ``caster4`` timed with its steering rate and
   without (the wheels' speed and acceleration limits only), and the turn rate the latter
   asks of the casters against their limit.
5. ``tracking``: ``caster4`` on a 2 m out-and-back of width 0.2 m retimed (400 cells),
   three laps in time mode, RMS position error after 1 s, at the time-optimal timing and
   at 80 % of its top speed.
"""

from __future__ import annotations

import math
import sys
import time
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline, PchipInterpolator

from mpc import Controller
from mpc.robots import preset
from mpc.sim import simulate
from trajectories import (
    FigureEight,
    OutAndBack,
    SampledTrajectory,
    SpinHeading,
    Trajectory,
    path_reference,
    time_optimal,
)


def _goal_line(gap: float = 0.0) -> np.ndarray:
    line = np.stack([np.linspace(0.0, 3.0 - gap, 61), np.zeros(61), np.zeros(61)], axis=1)
    return np.vstack([line, [3.0, 0.0, math.pi / 2]])


def _path_times(poses: np.ndarray, turn_length: float) -> np.ndarray:
    steps = np.diff(poses, axis=0)
    lengths = np.hypot(np.hypot(steps[:, 0], steps[:, 1]), turn_length * steps[:, 2])
    return np.concatenate(([0.0], np.cumsum(lengths)))


def goal_overshoot(log: Any = print) -> dict[str, float]:
    """How far past the goal [m] each join of :func:`_goal_line` goes (x beyond 3 m)."""
    poses = _goal_line()
    times = _path_times(poses, 0.5)
    natural = SampledTrajectory(times, poses, CubicSpline(times, poses, bc_type="natural",
                                                          axis=0)(times, 1))
    held = path_reference(poses, speed=1.0)
    out = {}
    for name, path in (("natural splines", natural), ("path_reference", held)):
        end = path.end_time
        assert end is not None
        x = path.sample(np.linspace(0.0, end, 20001)).pose[:, 0]
        out[name] = float(max(x.max() - 3.0, 0.0))
        log(f"goal     {name:18s} past the goal {out[name] * 1e3:7.1f} mm")
    return out


def _stretch(path: Trajectory, robot: Any, **options: Any) -> tuple[float, float, float]:
    """(lap / first solution's lap with the repairs, the same without, seconds timing it)."""
    started = time.perf_counter()
    repaired = time_optimal(path, robot, **options)
    seconds = time.perf_counter() - started
    scaled = time_optimal(path, robot, **{**options, "max_repairs": 0})
    assert repaired.info is not None and scaled.info is not None
    return repaired.info.stretch, scaled.info.stretch, seconds


def _snapped(count: int, cell: float = 0.05) -> np.ndarray:
    """``count`` poses 5 cm apart along a gentle S, snapped to a grid of ``cell`` [m] (0:
    not snapped), yaw along the snapped poses' differences."""
    s = np.arange(count) * 0.05
    xy = np.stack([s, 0.8 * np.sin(s / 3.0) + 0.3 * np.sin(s / 1.1)], axis=1)
    if cell:
        xy = np.round(xy / cell) * cell
    yaw = np.arctan2(np.gradient(xy[:, 1]), np.gradient(xy[:, 0]))
    return np.column_stack([xy, yaw])


def smoothing(log: Any = print, counts: tuple[int, ...] = (400, 1000)
              ) -> dict[int, tuple[float, float, float]]:
    """Per path length: (lap as given, lap smoothed, lap of the path before the snap) [s]."""
    mecanum = preset("mecanum")
    out = {}
    for count in counts:
        samples = int(np.clip(2 * count, 128, 1000))
        laps, seconds = [], []
        for poses, tolerances in ((_snapped(count), (0.0, 0.0)),
                                  (_snapped(count), (0.025, 0.4)),
                                  (_snapped(count, 0.0), (0.0, 0.0))):
            started = time.perf_counter()
            reference = path_reference(poses, robot=mecanum, max_speed=1.0, samples=samples,
                                       max_repairs=1, position_tolerance=tolerances[0],
                                       yaw_tolerance=tolerances[1])
            seconds.append(time.perf_counter() - started)
            assert reference.duration is not None  # timed rest to rest
            laps.append(reference.duration)
        out[count] = (laps[0], laps[1], laps[2])
        log(f"smoothing {count} poses on a 5 cm grid: lap {laps[0]:.2f} s as given "
            f"({seconds[0]:.2f} s to time), {laps[1]:.2f} s smoothed within 0.025 m and "
            f"0.4 rad ({seconds[1]:.2f} s), {laps[2]:.2f} s before the snap")
    return out


def peak_wheel_accel_ratio(timed: Any, robot: Any, points: int = 200001) -> float:
    """The largest wheel acceleration over its limit along ``timed`` (a retimed trajectory
    with ``lap_time``), by finite differences of the wheel velocities at ``points`` times:
    an answer independent of the retimer's own check."""
    t = np.linspace(0.0, timed.lap_time, points)
    velocities = np.einsum("ndj,kj->knd", robot.wheel_blocks, timed.body_twist(t))
    accel = np.linalg.norm(np.diff(velocities, axis=0), axis=2) / np.diff(t)[:, None]
    assert robot.max_wheel_accel is not None
    return float((accel / robot.max_wheel_accel).max())


def repairs(log: Any = print) -> dict[str, tuple[float, ...]]:
    """Lap / first lap with and without repairs on the paths of the module docstring."""
    out: dict[str, tuple[float, ...]] = {}
    mecanum = preset("mecanum")
    poses = _goal_line()
    times = _path_times(poses, 0.3)
    pchip = SampledTrajectory(times, poses, PchipInterpolator(times, poses, axis=0)(times, 1))
    out["pchip line and turn"] = _stretch(pchip, mecanum, periodic=False, max_speed=1.0)
    out["caster spinning 8"] = _stretch(FigureEight(0.5, 10.0, heading=SpinHeading(0.75)),
                                        preset("caster4"))
    source = FigureEight(1.0, 10.0, heading="tangent")
    sample_times = np.linspace(0.0, 10.0, 21)
    sample = source.sample(sample_times)
    sampled = SampledTrajectory(sample_times, sample.pose, sample.velocity)
    for name in ("mecanum", "swerve"):
        robot = preset(name)
        retimed = time_optimal(sampled, robot, periodic=False)
        ratio = peak_wheel_accel_ratio(retimed, robot)
        plain = time_optimal(sampled, robot, periodic=False, max_repairs=0)
        out[f"21 samples {name}"] = (retimed.lap_time / plain.lap_time, ratio)
        log(f"repairs  21 samples, {name:8s} lap {retimed.lap_time:.4f} s, without repairs "
            f"{plain.lap_time:.4f} s; peak wheel acceleration {ratio:.4f} x its limit")
    for name in ("pchip line and turn", "caster spinning 8"):
        with_, without, seconds = out[name]
        log(f"repairs  {name:24s} lap / first lap {with_:.4f} (without repairs {without:.4f})"
            f", {seconds:.2f} s")
    for count in (400, 1000):
        grid = _snapped(count)
        samples = int(np.clip(2 * count, 128, 1000))
        timed = {}
        for most in (1, 0):
            started = time.perf_counter()
            reference = path_reference(grid, robot=mecanum, max_speed=1.0, samples=samples,
                                       max_repairs=most)
            info = getattr(reference, "info", None)  # a RetimedTrajectory's
            assert info is not None
            timed[most] = (info.stretch, time.perf_counter() - started)
        out[f"snapped {count}"] = (*timed[1], *timed[0])
        log(f"repairs  {count} poses on a 5 cm grid: one repair {timed[1][0]:.3f} x the first "
            f"lap in {timed[1][1]:.2f} s; none {timed[0][0]:.3f} x in {timed[0][1]:.2f} s")
    return out


def steering(log: Any = print) -> tuple[float, float, float]:
    """(lap with the steering limit [s], lap without, peak steering demand without)."""
    from trajectories import feasibility

    robot = preset("caster4")
    path = FigureEight(0.3, 8.0)
    steered = time_optimal(path, robot)
    wheels_only = SimpleNamespace(wheel_blocks=robot.wheel_blocks,
                                  max_wheel_speed=robot.max_wheel_speed,
                                  max_wheel_accel=robot.max_wheel_accel)
    unsteered = time_optimal(path, wheels_only)
    demand = feasibility(unsteered, robot).steer_ratio
    log(f"steering caster4 0.3 m figure-eight: lap {steered.lap_time:.2f} s within the "
        f"steering rate, {unsteered.lap_time:.2f} s without it (which asks "
        f"{demand:.2f} x the rate)")
    return steered.lap_time, unsteered.lap_time, demand


def tracking(log: Any = print) -> dict[float, float]:
    """RMS position error [m] after 1 s tracking the caster's timed out-and-back."""
    robot = preset("caster4")
    path = OutAndBack(2.0, 8.0, width=0.2)
    fastest = time_optimal(path, robot, samples=400)
    assert fastest.period is not None
    top = float(np.hypot(*fastest.sample(np.linspace(0.0, fastest.period, 2000))
                         .velocity[:, :2].T).max())
    out = {}
    for share in (1.0, 0.8):
        timed = fastest if share == 1.0 else time_optimal(path, robot, samples=400,
                                                          max_speed=share * top)
        assert timed.period is not None
        result = simulate(Controller(robot, timed), 3 * timed.period)
        error = result.position_error()
        out[share] = float(np.sqrt(np.mean(error[result.time > 1.0] ** 2)))
        log(f"tracking caster4 out-and-back at {share:.0%} of the timing's top speed: lap "
            f"{timed.period:.2f} s, RMS error after 1 s {out[share] * 1e3:.1f} mm")
    return out


def main(argv: list[str] | None = None) -> int:
    if argv if argv is not None else sys.argv[1:]:
        print("usage: python -m benchmarks.retiming_cases (no options)", file=sys.stderr)
        return 2
    started = time.perf_counter()
    for part in (goal_overshoot, repairs, smoothing, steering, tracking):
        part(lambda line: print(line, flush=True))
    print(f"({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
