"""``mpc-bench soak``: memory and tick time over a long run of the fast path.

Runs the default controller (the daqp fast path, horizon 20, dt 0.05 s) for many
consecutive ticks on the Mecanum preset tracking a figure-eight (the plant
integrates the commanded twist exactly, to keep the loop itself cheap) and
prints, per block of ticks, the resident
memory and the median tick time. Flat columns mean no leak and no drift.
"""

from __future__ import annotations

import resource
import time

import numpy as np

from benchmarks.scenarios import Parser, ScenarioError, reference
from mpc import Controller
from mpc.model import integrate
from mpc.robots import preset
from mpc.validation import MAX_SIMULATION_TICKS


def _rss_mib() -> float:
    """Current resident set size [MiB] (Linux /proc; peak RSS elsewhere)."""
    try:
        with open("/proc/self/statm") as handle:
            pages = int(handle.read().split()[1])
        return pages * resource.getpagesize() / 2**20
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench soak", description=__doc__.split("\n")[0])
    parser.add_argument("--ticks", type=int, default=100_000, help="ticks in all (100000)")
    parser.add_argument("--blocks", type=int, default=10, help="report lines (10)")
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if args.ticks < args.blocks or args.blocks < 1:
        raise ScenarioError("--ticks must be >= --blocks >= 1")
    if args.ticks > MAX_SIMULATION_TICKS:
        raise ScenarioError(f"--ticks must be at most {MAX_SIMULATION_TICKS} (a bound of this "
                            f"library), got {args.ticks}")
    robot = preset("mecanum")
    trajectory = reference("figure8", "fixed", robot, 0.8)
    control = Controller(robot, trajectory)
    dt = control.dt
    pose = trajectory.sample(0.0).pose
    block = args.ticks // args.blocks
    times = np.empty(block)
    print(f"{'ticks':>8s} {'rss [MiB]':>10s} {'tick p50 [ms]':>14s} {'tick p99 [ms]':>14s} "
          f"{'wall [s]':>9s}")
    started = time.perf_counter()
    first_rss = None
    for b in range(args.blocks):
        for i in range(block):
            k = b * block + i
            command = control.step(pose, k * dt)
            times[i] = command.tick_time
            pose = integrate(pose, command.twist, dt)
        rss = _rss_mib()
        first_rss = first_rss or rss
        print(f"{(b + 1) * block:8d} {rss:10.1f} {np.median(times) * 1e3:14.3f} "
              f"{np.percentile(times, 99) * 1e3:14.3f} {time.perf_counter() - started:9.0f}",
              flush=True)
    print(f"memory growth after the first block: {_rss_mib() - (first_rss or 0):.1f} MiB")
    return 0
