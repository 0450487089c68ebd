"""The motor-aware controller against its kinematic stand-in, on a robot driven by motors.

Shows:

- :func:`mpc.robots.motor_preset`: a Mecanum robot with DC motors, a current limit, a
  sagging battery and wheel traction (:class:`mpc.robots.RobotDynamics`); a
  :class:`mpc.Controller` given it plans within the motors' voltage, current and traction
  and reports each motor's current feedforward (``Command.motor_currents`` [A]);
- the same MPC given the kinematic stand-in a team would derive from those motors
  (speed limit = free speed, acceleration limit = the current- or traction-limited
  torque over the wheel's share of the mass: ``benchmarks.motors.kinematic_stand_in``);
- both tracking a figure-eight timed to need 100 % of the motor model
  (``benchmarks.motors.motor_reference``) on the motor plant (``plant="motor"``: each
  wheel's velocity loop, voltage clipped to the bus, the current limit, slip), whose
  loops ramp each command over the tick (``command_ramp=True`` tells the MPCs).

Run::

    python examples/motor_aware.py                   # two laps of the figure-eight
    python examples/motor_aware.py --duration 4 --out figures/

Prints, for each controller, the RMS position error after the first second and the ticks
on which a wheel loop asked for more voltage than the bus had, more current than the
limit, or a wheel slid.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import mpc
from benchmarks.motors import kinematic_stand_in, motor_reference
from mpc.robots import motor_preset
from mpc.sim import SimResult, simulate

SKIP = 1.0  # [s] start-up left out of the metrics


def run(duration: float | None, out: Path) -> dict[str, dict[str, float]]:
    """Both controllers on the motor plant; write ``out/motor_aware.png``; return each
    one's metrics plus ``peak_motor_current`` [A] (of the commands' feedforward)."""
    robot = motor_preset("mecanum")
    reference = motor_reference("figure8", robot, ratio=1.0)  # needs all the motors give
    period = reference.period                  # [s] of one lap
    assert period is not None
    seconds = 2 * period if duration is None else duration
    robots = {"motor-aware": robot, "kinematic stand-in": kinematic_stand_in(robot)}
    results: dict[str, SimResult] = {}
    numbers: dict[str, dict[str, float]] = {}
    for name, model in robots.items():
        controller = mpc.Controller(model, reference, horizon=20, dt=0.05, command_ramp=True)
        results[name] = simulate(controller, duration=seconds, plant="motor", robot=robot)
        numbers[name] = results[name].metrics(skip=min(SKIP, seconds / 2))
        numbers[name]["period"] = period
    command = mpc.Controller(robot, reference, horizon=20, dt=0.05).step(
        reference.sample(0.0).pose, 0.0)
    assert command.motor_currents is not None  # [A] per motor: a robot with dynamics has them
    numbers["motor-aware"]["first_motor_currents"] = float(np.abs(command.motor_currents).max())

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    dense = reference.sample(np.linspace(0.0, period, 400)).pose
    axes[0].plot(dense[:, 0], dense[:, 1], "--", color="grey", label="reference")
    for index, (name, result) in enumerate(results.items()):
        color = f"C{index}"
        axes[0].plot(result.pose[:, 0], result.pose[:, 1], color=color, lw=1, label=name)
        axes[1].plot(result.time, 1e3 * result.position_error(), color=color, label=name)
        events = result.plant_events or {}
        axes[2].plot(result.time, events["peak_current_ratio"], color=color, lw=1, label=name)
    axes[0].set(xlabel="x [m]", ylabel="y [m]", aspect="equal", ylim=(-0.7, 1.2),
                title=f"(a) figure-eight at 100 % of the motors ({period:.2f} s)")
    axes[1].set(xlabel="time [s]", ylabel="position error [mm]", yscale="log",
                title="(b) tracking error")
    axes[2].axhline(1.0, color="k", ls="--", lw=1, label="current limit")
    axes[2].set(xlabel="time [s]", ylabel="largest |I| / limit over the wheels",
                title="(c) motor current on the plant")
    for ax in axes:
        ax.legend(fontsize=8, loc="upper right")
    figure.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    figure.savefig(out / "motor_aware.png", dpi=100)
    plt.close(figure)
    return numbers


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=None,
                        help="seconds to run (default: two laps)")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the figure")
    args = parser.parse_args(argv)
    numbers = run(args.duration, args.out)
    print(f"figure-eight lap: {numbers['motor-aware']['period']:.2f} s; first command's "
          f"largest motor current: {numbers['motor-aware']['first_motor_currents']:.1f} A")
    for name, metrics in numbers.items():
        print(f"{name}: rms position error {metrics['rms_position_error'] * 1e3:.1f} mm, "
              f"voltage violations {metrics['voltage_violations']}, current violations "
              f"{metrics['current_violations']}, slip events {metrics['slip_events']}")
    print(f"figure: {args.out / 'motor_aware.png'}")


if __name__ == "__main__":
    main()
