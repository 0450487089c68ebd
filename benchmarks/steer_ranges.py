"""Steering ranges measured: ``python -m benchmarks.steer_ranges`` prints a Markdown table.

Each row is one lap of a 1 m circle whose heading spins two full turns in the lap
(``SpinHeading``, either way), on the ideal plant, for a preset with a +-pi steering range
(``swerve-cable``, ``mpo700-cable``) under its three rules: no range (the same robot with
``steer_range=None``: today's commands), the per-tick flip rule kept inside the range
(``steer_plan="tick"``) and the flips planned over the horizon (``"horizon"``). Columns:
RMS and largest position error over the lap and its RMS after the first 2 s [mm], flips
(:meth:`~mpc.sim.result.SimResult.steer_flips`, all modules), the plant's own absolute
steer angles' extremes [rad] (without a range they are unwrapped from the plant's wrapped
ones) and the ticks any of them spent outside +-pi, wheel speed / acceleration / steering
rate violations and failed solves.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Sequence

import numpy as np

from mpc import Controller
from mpc.robots import SwerveRobot, preset
from mpc.sim.plant import Plant, PlantConfig
from mpc.sim.recorder import Recorder
from trajectories import Circle, SpinHeading

#: (preset, turns of the heading a lap (signed), path speed [m/s], solver)
CASES: tuple[tuple[str, float, float, str], ...] = (
    ("swerve-cable", 2.0, 0.4, "daqp"),
    ("swerve-cable", 2.0, 0.6, "daqp"),
    ("swerve-cable", 2.0, 0.8, "daqp"),
    ("swerve-cable", -2.0, 0.5, "daqp"),
    ("swerve-cable", -2.0, 0.6, "daqp"),
    ("swerve-cable", 2.0, 0.6, "ipopt"),
    ("swerve-cable", -2.0, 0.6, "ipopt"),
    ("mpo700-cable", 2.0, 0.4, "daqp"),
    ("mpo700-cable", 2.0, 0.6, "daqp"),
    ("mpo700-cable", -2.0, 0.5, "daqp"),
)
RULES = ("none", "tick", "horizon")
SKIP = 2.0  # [s] the start from rest left out of the second RMS


def spin_circle(turns: float, speed: float) -> Circle:
    """A 1 m circle at ``speed`` [m/s] whose heading turns ``turns`` times in the lap."""
    period = 2.0 * math.pi / speed
    return Circle(1.0, period, heading=SpinHeading(rate=turns * 2.0 * math.pi / period))


def rule_robot(robot: SwerveRobot, rule: str) -> SwerveRobot:
    """The preset without its range (``"none"``) or with the given ``steer_plan``."""
    if rule == "none":
        return dataclasses.replace(robot, steer_range=None)
    return dataclasses.replace(robot, steer_plan=rule)


def run(robot: SwerveRobot, turns: float, speed: float, solver: str) -> dict[str, object]:
    """One lap; the row's numbers."""
    reference = spin_circle(turns, speed)
    controller = Controller(robot, reference, solver=solver)
    plant = Plant(robot, controller.dt, reference.sample(0.0).pose, PlantConfig(),
                  np.random.default_rng(0))
    recorder = Recorder(robot, reference, controller.dt)
    angles = []
    for k in range(round(reference.period / controller.dt)):
        t = k * controller.dt
        command = controller.step(plant.measure(), t)
        pose = plant.pose
        recorder.record(t, pose, command, wheel_actual=plant.apply(command))
        assert plant.steer_angles is not None
        angles.append(plant.steer_angles.copy())
    result = recorder.result()
    turned = np.array(angles)
    if robot.steer_range is None:
        turned = np.unwrap(turned, axis=0)  # the wrapped plant: its absolute angles
    metrics, late = result.metrics(), result.metrics(skip=SKIP)
    flips = result.steer_flips()
    return {
        "rms": 1000 * metrics["rms_position_error"],
        "late": 1000 * late["rms_position_error"],
        "max": 1000 * metrics["max_position_error"],
        "flips": int(0 if flips is None else flips.sum()),
        "low": float(turned.min()), "high": float(turned.max()),
        "outside": int((np.abs(turned) > math.pi + 1e-9).any(axis=1).sum()),
        "violations": (f"{metrics['limit_violations']}/{metrics['accel_violations']}/"
                       f"{metrics['steer_violations']}"),
        "failures": metrics["failures"],
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.steer_ranges",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the swerve-cable daqp rows at 0.6 m/s only")
    args = parser.parse_args(argv)
    cases = [case for case in CASES
             if not args.quick or (case[0] == "swerve-cable" and case[2] == 0.6
                                   and case[3] == "daqp")]
    print("| preset | heading turns | speed [m/s] | solver | rule | RMS [mm] | RMS after "
          f"{SKIP:g} s [mm] | max [mm] | flips | plant angles [rad] | ticks outside +-pi | "
          "violations speed/accel/steer | failures |")
    print("|" + "---|" * 13)
    start = time.perf_counter()
    for name, turns, speed, solver in cases:
        robot = preset(name)
        assert isinstance(robot, SwerveRobot)
        for rule in RULES:
            row = run(rule_robot(robot, rule), turns, speed, solver)
            print(f"| {name} | {turns:+g} | {speed:g} | {solver} | {rule} | {row['rms']:.1f} | "
                  f"{row['late']:.1f} | {row['max']:.0f} | {row['flips']} | "
                  f"[{row['low']:.2f}, {row['high']:.2f}] | {row['outside']} | "
                  f"{row['violations']} | {row['failures']} |", flush=True)
    print(f"\n({time.perf_counter() - start:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
