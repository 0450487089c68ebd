"""Your own control loop, recorded and plotted.

Shows: :class:`mpc.Controller` stepped by a loop you write (here a small stand-in for a
real robot: the wheels reach each command through a first-order lag and odometry reads
the pose with a little noise), :class:`mpc.sim.Recorder` keeping every tick, and
:func:`mpc.plot.plot_run` drawing the run: the path with the plans the controller
predicted, the errors, each wheel's command against its limit and the tick times.

Run::

    python examples/own_loop.py                      # 12 s, writes own_loop.png here
    python examples/own_loop.py --duration 30 --out figures/

Prints the RMS position and heading errors after the first second, the peak wheel speed
as a fraction of its limit and the worst tick time.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import mpc
import mpc.plot
from mpc.model import integrate
from mpc.robots import preset
from mpc.sim import Recorder
from trajectories import FigureEight

SKIP = 1.0  # [s] start-up left out of the metrics (shaded in the figure)


def run(duration: float, out: Path) -> dict[str, float]:
    """Track a figure-eight with a Mecanum robot for ``duration`` seconds; write
    ``out/own_loop.png``; return the run's metrics (SI units)."""
    robot = preset("mecanum")
    reference = FigureEight(amplitude=1.0, period=12.0, heading="tangent")
    controller = mpc.Controller(robot, reference, horizon=20, dt=0.05)
    recorder = Recorder(robot, controller.trajectory, controller.dt)

    rng = np.random.default_rng(0)                 # seeded odometry noise
    pose = reference.sample(0.0).pose + np.array([0.05, -0.05, 0.1])  # starts off the path
    twist = np.zeros(3)                            # what the wheels actually do
    lag = 0.03                                     # [s] the drive's time constant
    for k in range(int(round(duration / controller.dt))):
        t = k * controller.dt
        measured = pose + rng.normal(0.0, [0.002, 0.002, 0.005])  # your odometry
        command = controller.step(measured, t)     # send command.wheel_speeds [rad/s]
        recorder.record(t, pose, command, measured=measured)
        # Your robot moves: the twist approaches the command, then the pose follows it.
        twist += (command.twist - twist) * (1.0 - math.exp(-controller.dt / lag))
        pose = integrate(pose, twist, controller.dt)

    result = recorder.result()
    out.mkdir(parents=True, exist_ok=True)
    mpc.plot.plot_run(result, skip=SKIP).savefig(out / "own_loop.png", dpi=100)
    return result.metrics(skip=SKIP)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=12.0, help="seconds to run")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the figure")
    args = parser.parse_args(argv)
    metrics = run(args.duration, args.out)
    print(f"rms position error: {metrics['rms_position_error'] * 1e3:.1f} mm")
    print(f"rms heading error: {math.degrees(metrics['rms_heading_error']):.2f} deg")
    print(f"peak wheel speed: {metrics['max_wheel_speed_ratio']:.2f} of the limit")
    print(f"worst tick: {metrics['tick_time_max'] * 1e3:.1f} ms")
    print(f"figure: {args.out / 'own_loop.png'}")


if __name__ == "__main__":
    main()
