"""``mpc-bench export``: one controller's tick written as a self-contained C library.

Builds ``Controller(preset(ROBOT), ..., compiled="virtual-machine")`` with the options
given and writes :func:`mpc.export_c` of it into ``--out``: the generated sources,
``tick.c``, ``mpc_tick.h``, a ``CMakeLists.txt``, a README of the interface and an example
``main.c`` (nothing is compiled here: ``cmake -S OUT -B OUT/build && cmake --build
OUT/build`` builds it). The reference is the caller's at run time (each step takes its
poses and velocities at the stage times; ``--path``: at the times the library gives),
so no trajectory is chosen here.
"""

from __future__ import annotations

import math

import mpc
import mpc.tick.reuse as reuse
from benchmarks.outdir import add_force_argument, claim
from benchmarks.scenarios import Parser, ScenarioError
from mpc import Controller
from mpc.robots import preset
from trajectories import FigureEight

#: What ``export`` writes into ``--out`` (refused without ``--force`` if there already).
WRITES = ("mpc_tick.h", "mpc_tick_config.h", "mpc_tick_graphs.c", "mpc_tick_graphs.h",
          "tick.c", "CMakeLists.txt", "README.md", "main.c")


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench export", description=__doc__.split("\n")[0])
    parser.add_argument("robot", help="a shipped robot preset with constant wheel Jacobians "
                                      "(omni3, omni4, mecanum, ball3, ...)")
    parser.add_argument("--out", required=True, help="folder to write the library into")
    parser.add_argument("--horizon", type=int, default=20, help="MPC horizon in ticks (20)")
    parser.add_argument("--dt", type=float, default=0.05, help="control tick [s] (0.05)")
    parser.add_argument("--path", action="store_true",
                        help="path mode (the progress planned: the library says where to "
                             "sample the reference); default time mode (the reference at "
                             "t + the stage offsets)")
    parser.add_argument("--max-iter", type=int,
                        help="daqp iterations per solve at most (default 1000, with the "
                             "second solve from the last command after a failed cold start; "
                             "given: a budget, no second solve)")
    parser.add_argument("--rebuild-drift", type=float, default=reuse.REBUILD_DRIFT,
                        help="rebuild the kept Hessian when the linearisation moved beyond "
                             "this multiple of its tolerance; below 0: every tick "
                             f"({reuse.REBUILD_DRIFT:g})")
    add_force_argument(parser)
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if args.max_iter is not None and args.max_iter < 1:
        raise ScenarioError(f"--max-iter must be >= 1, got {args.max_iter}")
    if not math.isfinite(args.rebuild_drift):
        raise ScenarioError(f"--rebuild-drift must be finite, got {args.rebuild_drift}")
    robot = preset(args.robot)
    mode = "path" if args.path else "time"
    saved = reuse.REBUILD_DRIFT
    reuse.REBUILD_DRIFT = args.rebuild_drift
    try:
        # any trajectory: the exported step takes the caller's reference
        controller = Controller(robot, FigureEight(1.0, 16.0), horizon=args.horizon,
                                dt=args.dt, max_iter=args.max_iter, mode=mode,
                                compiled="virtual-machine")
    finally:
        reuse.REBUILD_DRIFT = saved
    out = claim(args.out, WRITES, args.force)  # (after the options are known good)
    mpc.export_c(controller, out)
    print(f"wrote {robot.name!r} (N={args.horizon}, dt={args.dt:g} s, {mode} mode) as "
          f"C into {out}; "
          f"build: cmake -S {out} -B {out}/build && cmake --build {out}/build")
    return 0
