"""A Choreo ``.traj`` file to a tracked run.

Shows: :func:`trajectories.read_choreo` reading a Choreo trajectory (schema version 3,
swerve) together with the robot it was planned for (module positions, wheel radius, the
wheel speed limit ``vmax / gearing``), a :class:`mpc.Controller` at Choreo's usual 20 ms
tick tracking it on a simulated robot with motor lag, a tick of delay, odometry noise and
wheel slip (:func:`mpc.sim.simulate`, ``plant="realistic"``; the controller is told of the
delay), and the run's figure.

The default file, ``examples/data/s-curve.traj``, is an S-curve from rest to rest: 3 m
ahead, 0.6 m to the left and back, turning 1.2 rad on the way, in 3 s. Give your own with
``--traj``.

Run::

    python examples/choreo_run.py                           # the file and 1 s after it
    python examples/choreo_run.py --traj my.traj --duration 8 --out figures/

Prints the file's name and length, the RMS and final position errors and the peak wheel
speed as a fraction of the limit.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import mpc
import mpc.plot
from mpc.sim import simulate
from trajectories import read_choreo

HERE = Path(__file__).resolve().parent
SKIP = 0.2  # [s] start-up left out of the metrics


def run(traj: Path, duration: float | None, out: Path) -> dict[str, float]:
    """Track the Choreo file ``traj`` for ``duration`` seconds (default: to its end and 1 s
    beyond); write ``out/choreo_run.png``; return the metrics plus ``final_position_error``
    [m] and ``end_time`` [s] (the file's length)."""
    reference = read_choreo(traj)               # the samples and the robot they are for
    # The simulated drive answers one tick late; the controller is told (delay_ticks).
    controller = mpc.Controller(reference.robot, reference, horizon=25, dt=0.02,
                                delay_ticks=1)
    seconds = reference.end_time + 1.0 if duration is None else duration
    result = simulate(controller, duration=seconds, plant="realistic", seed=1)

    out.mkdir(parents=True, exist_ok=True)
    mpc.plot.plot_run(result, skip=SKIP).savefig(out / "choreo_run.png", dpi=100)
    metrics = result.metrics(skip=SKIP)
    final = reference.sample(min(result.time[-1], reference.end_time)).pose
    metrics["final_position_error"] = float(np.hypot(*(result.pose[-1, :2] - final[:2])))
    metrics["end_time"] = float(reference.end_time)
    return metrics


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--traj", type=Path, default=HERE / "data" / "s-curve.traj",
                        help="a Choreo .traj file (schema 3, swerve)")
    parser.add_argument("--duration", type=float, default=None,
                        help="seconds to run (default: the file's length + 1 s)")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the figure")
    args = parser.parse_args(argv)
    metrics = run(args.traj, args.duration, args.out)
    print(f"trajectory: {args.traj.name}, {metrics['end_time']:.2f} s")
    print(f"rms position error: {metrics['rms_position_error'] * 1e3:.1f} mm")
    print(f"rms heading error: {math.degrees(metrics['rms_heading_error']):.2f} deg")
    print(f"final position error: {metrics['final_position_error'] * 1e3:.1f} mm")
    print(f"peak wheel speed: {metrics['max_wheel_speed_ratio']:.2f} of the limit")
    print(f"figure: {args.out / 'choreo_run.png'}")


if __name__ == "__main__":
    main()
