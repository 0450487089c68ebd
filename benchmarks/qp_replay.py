"""mpc-bench qp-replay: the fast path's QPs from one run, solved again by every QP solver
that is installed, tick after tick as the controller would (warm started where the solver
can be), to see whether another solver would make the tick cheaper.

Each tick the dense solver (:class:`mpc.solvers.dense.DenseSolver`) hands daqp a QP in
whitened steps ``y``: Hessian the identity, ``gradient``, and rows with bounds ``lower <=
rows y <= upper`` (:class:`~mpc.solvers.dense.WhitenedQp`). The run records them (the
solver's ``record`` list), then each solver solves the whole sequence in order; the table
gives its wall time a tick (median and p99, the first :data:`SETTLE` ticks left out), how
far its step is from daqp's (the largest entry over the ticks, in whitened units) and the
ticks it did not solve. daqp is a core dependency and is always run, given new rows only
on the ticks whose rows changed (as the controller gives them). The others run when
installed and are listed as missing otherwise (``pip install ".[solvers]"``; one that
raises, a newer release with another interface, is listed with its error): proxsuite's
dense ProxQP and qpalm warm started from their last answer, both at ``eps_abs`` 1e-7
(proxsuite with its infeasibility checks off: at their defaults it called these feasible
QPs infeasible), quadprog and piqp's dense solver cold each tick (neither takes a warm
start). Their times include what each needs to take the QP in.
"""

from __future__ import annotations

import importlib.util
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import daqp
import numpy as np

from benchmarks.options import add_list_option
from benchmarks.outdir import add_force_argument, claim
from benchmarks.runner import machine
from benchmarks.scenarios import (
    HEADINGS,
    LAYOUTS,
    SPEEDS,
    TRAJECTORIES,
    Parser,
    ScenarioError,
    choose,
    reference,
)
from mpc import Controller
from mpc.arrays import FloatArray
from mpc.control.controller import MODES
from mpc.robots import preset
from mpc.sim import simulate
from mpc.solvers.dense import DenseSolver, WhitenedQp

#: Solvers in the order they run, each named as its package; daqp (a core dependency) always
#: runs first: the others' steps are measured against its.
SOLVERS: tuple[str, ...] = ("daqp", "proxsuite", "quadprog", "piqp", "qpalm")
#: Ticks left out of the timing at the start of a replay (a warm start needs a first solve).
SETTLE = 5
#: Most ticks recorded: every tick's QP is kept (swerve's 560 x 60 rows: 0.27 MB a tick).
MAX_TICKS = 500
DT = 0.05  # [s], the control tick
HORIZON = 20

Replay = Callable[[list[WhitenedQp]], tuple[list[float], list[FloatArray], int]]


def record(layout: str, shape: str, heading: str, ratio: float, mode: str,
           ticks: int) -> list[WhitenedQp]:
    """The QPs of ``ticks`` ticks of the daqp fast path (N = 20, dt 0.05 s, ideal plant) on
    the named reference, timed to ``ratio`` of the robot's wheel limits."""
    robot = preset(layout)
    control = Controller(robot, reference(shape, heading, robot, ratio), horizon=HORIZON,
                         dt=DT, solver="daqp", mode=mode)
    solver = control.solver
    if not isinstance(solver, DenseSolver):  # pragma: no cover - daqp is the dense solver
        raise RuntimeError("the daqp controller has no dense solver")
    solver.record = []
    simulate(control, ticks * DT)
    return solver.record


def replay_daqp(qps: list[WhitenedQp]) -> tuple[list[float], list[FloatArray], int]:
    """daqp as the dense solver drives it: one model, new rows only when they changed."""
    n = qps[0].rows.shape[1]
    model = daqp.Model()
    first = qps[0]
    model.setup(np.eye(n), first.gradient, first.rows, first.upper, first.lower,
                np.zeros(first.upper.size, dtype=np.intc))
    times, steps, failed, rows = [], [], 0, first.rows
    for qp in qps:
        update: dict[str, FloatArray] = {"f": qp.gradient, "bupper": qp.upper,
                                         "blower": qp.lower}
        changed = not np.array_equal(qp.rows, rows)
        if changed:
            update["A"] = qp.rows
            rows = qp.rows
        started = time.perf_counter()
        model.update(**update)
        step, _, flag, _ = model.solve()
        times.append(time.perf_counter() - started)
        steps.append(step)
        failed += flag <= 0
    return times, steps, failed


def replay_proxsuite(qps: list[WhitenedQp]) -> tuple[list[float], list[FloatArray], int]:
    """proxsuite's dense ProxQP, warm started from its last answer."""
    import proxsuite

    n, m = qps[0].rows.shape[1], qps[0].rows.shape[0]
    solver = proxsuite.proxqp.dense.QP(n, 0, m)
    settings = solver.settings
    settings.eps_abs, settings.eps_rel, settings.verbose = 1e-7, 0.0, False
    settings.eps_primal_inf = settings.eps_dual_inf = 1e-14
    settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
    solved = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
    times, steps, failed = [], [], 0
    for k, qp in enumerate(qps):
        started = time.perf_counter()
        if k == 0:
            solver.init(np.eye(n), qp.gradient, None, None, qp.rows, qp.lower, qp.upper)
        else:
            solver.update(g=qp.gradient, C=qp.rows, l=qp.lower, u=qp.upper)
        solver.solve()
        times.append(time.perf_counter() - started)
        steps.append(np.array(solver.results.x))
        failed += solver.results.info.status != solved
    return times, steps, failed


def replay_quadprog(qps: list[WhitenedQp]) -> tuple[list[float], list[FloatArray], int]:
    """quadprog (Goldfarb-Idnani), cold each tick, the two-sided rows as two one-sided."""
    import quadprog

    n = qps[0].rows.shape[1]
    hessian = np.eye(n)
    times, steps, failed = [], [], 0
    for qp in qps:
        started = time.perf_counter()
        upper, lower = np.isfinite(qp.upper), np.isfinite(qp.lower)
        rows = np.vstack([-qp.rows[upper], qp.rows[lower]]).T
        bounds = np.concatenate([-qp.upper[upper], qp.lower[lower]])
        try:
            step = quadprog.solve_qp(hessian, -qp.gradient, rows, bounds, 0)[0]
        except ValueError:  # its only way of saying it did not solve
            step, failed = np.full(n, np.nan), failed + 1
        times.append(time.perf_counter() - started)
        steps.append(step)
    return times, steps, failed


def replay_piqp(qps: list[WhitenedQp]) -> tuple[list[float], list[FloatArray], int]:
    """piqp's dense interior-point solver, cold each tick (it takes no warm start)."""
    import piqp

    n = qps[0].rows.shape[1]
    times, steps, failed = [], [], 0
    for qp in qps:
        started = time.perf_counter()
        solver = piqp.DenseSolver()
        solver.setup(np.eye(n), qp.gradient, None, None, qp.rows, qp.lower, qp.upper,
                     None, None)
        status = solver.solve()
        times.append(time.perf_counter() - started)
        steps.append(np.array(solver.result.x))
        failed += status != piqp.PIQP_SOLVED
    return times, steps, failed


def replay_qpalm(qps: list[WhitenedQp]) -> tuple[list[float], list[FloatArray], int]:
    """qpalm (sparse proximal augmented Lagrangian), warm started from its last answer."""
    import qpalm
    from scipy import sparse

    n, m = qps[0].rows.shape[1], qps[0].rows.shape[0]
    hessian = sparse.csc_matrix(np.eye(n))
    full = sparse.csc_matrix(np.ones((m, n)))  # every entry stored: one pattern every tick
    big = 1e20  # qpalm's infinity
    times, steps, failed = [], [], 0
    solver = None
    for qp in qps:
        started = time.perf_counter()
        lower, upper = np.maximum(qp.lower, -big), np.minimum(qp.upper, big)
        rows = sparse.csc_matrix((qp.rows.ravel(order="F"), full.indices, full.indptr),
                                 shape=(m, n))
        if solver is None:
            data = qpalm.Data(n, m)
            data.Q, data.q, data.A = hessian, qp.gradient, rows
            data.bmin, data.bmax = lower, upper
            settings = qpalm.Settings()
            settings.eps_abs, settings.eps_rel, settings.verbose = 1e-7, 0.0, 0
            solver = qpalm.Solver(data, settings)
        else:
            solver.update_q(qp.gradient)
            solver.update_bounds(lower, upper)
            solver.update_Q_A(hessian.data, rows.data)
            solver.warm_start(solver.solution.x, solver.solution.y)
        solver.solve()
        times.append(time.perf_counter() - started)
        steps.append(np.array(solver.solution.x))
        failed += solver.info.status_val != 1
    return times, steps, failed


REPLAYS: dict[str, Replay] = {"daqp": replay_daqp, "proxsuite": replay_proxsuite,
                              "quadprog": replay_quadprog, "piqp": replay_piqp,
                              "qpalm": replay_qpalm}


def installed(name: str) -> bool:
    """Whether the solver's package can be imported."""
    return importlib.util.find_spec(name) is not None


def replay(qps: list[WhitenedQp], solvers: list[str]) -> list[dict[str, Any]]:
    """daqp, then each other of ``solvers``, on the recorded ``qps``: a row each (times [s],
    the step's largest distance from daqp's), ``missing`` for a solver not installed,
    ``error`` for one that raised."""
    if len(qps) <= SETTLE:
        raise ScenarioError(f"qp-replay needs more than {SETTLE} recorded ticks, got "
                            f"{len(qps)}")
    if len({qp.rows.shape for qp in qps}) > 1:  # (rows a screen leaves out: motor models)
        raise ScenarioError("qp-replay needs QPs of one size; these change their rows "
                            "from tick to tick")
    times, daqp_steps, failed = replay_daqp(qps)
    rows = [_row("daqp", times, daqp_steps, failed, daqp_steps)]
    for name in solvers:
        if name == "daqp":
            continue
        if not installed(name):
            rows.append({"solver": name, "missing": True})
            continue
        try:
            times, steps, failed = REPLAYS[name](qps)
        except Exception as error:  # another solver's release: say so, go on
            rows.append({"solver": name, "missing": False, "error": f"{type(error).__name__}: "
                                                                    f"{error}"})
            continue
        rows.append(_row(name, times, steps, failed, daqp_steps))
    return rows


def _row(name: str, times: list[float], steps: list[FloatArray], failed: int,
         daqp_steps: list[FloatArray]) -> dict[str, Any]:
    kept = np.asarray(times[SETTLE:])
    distance = max(float(np.abs(step - daqp_step).max())
                   for step, daqp_step in zip(steps, daqp_steps, strict=True))
    return {"solver": name, "missing": False, "ticks": len(times),
            "tick_p50": float(np.median(kept)), "tick_p99": float(np.percentile(kept, 99)),
            "max_step_distance": distance, "failed": int(failed)}


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as text, times [ms] and ratios to daqp's median."""
    base = rows[0]["tick_p50"]  # daqp's (replay puts it first)
    lines = [f"{'solver':10s} {'p50 [ms]':>9s} {'p99 [ms]':>9s} {'/ daqp':>7s} "
             f"{'max |y - y_daqp|':>17s} {'failed':>6s}"]
    for row in rows:
        if row["missing"]:
            lines.append(f"{row['solver']:10s} not installed (pip install {row['solver']})")
            continue
        if "error" in row:
            lines.append(f"{row['solver']:10s} failed to run: {row['error']}")
            continue
        lines.append(f"{row['solver']:10s} {row['tick_p50'] * 1e3:9.3f} "
                     f"{row['tick_p99'] * 1e3:9.3f} {row['tick_p50'] / base:7.1f} "
                     f"{row['max_step_distance']:17.2e} {row['failed']:6d}")
    return "\n".join(lines)


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench qp-replay", description=__doc__.split("\n")[0])
    # one scenario is recorded: each list option takes one name here
    add_list_option(parser, "--layouts", metavar="LAYOUT", default="swerve",
                    help=f"one of {', '.join(LAYOUTS)} (swerve)")
    add_list_option(parser, "--trajectories", old=("--trajectory",), metavar="TRAJECTORY",
                    default="figure8",
                    help=f"one of {', '.join(TRAJECTORIES)} (figure8)")
    add_list_option(parser, "--headings", metavar="HEADING", default="fixed",
                    help=f"one of {', '.join(HEADINGS)} (fixed)")
    add_list_option(parser, "--speeds", metavar="SPEED", default="beyond",
                    help="inside (0.8 x the wheel limits) or beyond (1.3 x) (beyond)")
    add_list_option(parser, "--modes", metavar="MODE", default="time",
                    help=f"one of {', '.join(MODES)} (time)")
    parser.add_argument("--ticks", type=int, default=200,
                        help=f"ticks recorded (200, at most {MAX_TICKS})")
    add_list_option(parser, "--solvers", help=f"comma list of {', '.join(SOLVERS)} (default: all)")
    parser.add_argument("--out", default="bench-out", metavar="DIR",
                        help="writes qp_replay.json here (bench-out)")
    add_force_argument(parser)
    return parser


def _one(flag: str, kind: str, value: str, valid: tuple[str, ...] | list[str]) -> str:
    names = choose(flag, kind, value, valid)
    if len(names) != 1:
        raise ScenarioError(f"{flag} takes one {kind} here (qp-replay records one scenario), "
                            f"got {value!r}")
    return names[0]


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    layout = _one("--layouts", "layout", args.layouts, LAYOUTS)
    shape = _one("--trajectories", "trajectory", args.trajectories, TRAJECTORIES)
    heading = _one("--headings", "heading", args.headings, HEADINGS)
    speed = _one("--speeds", "speed", args.speeds, list(SPEEDS))
    mode = _one("--modes", "mode", args.modes, list(MODES))
    solvers = list(dict.fromkeys(["daqp", *choose("--solvers", "solver", args.solvers,
                                                  SOLVERS)]))  # daqp first, as replay runs
    if not SETTLE < args.ticks <= MAX_TICKS:
        raise ScenarioError(f"--ticks must be in {SETTLE + 1}..{MAX_TICKS}, got {args.ticks}")
    out = claim(args.out, ("qp_replay.json",), args.force)
    command = " ".join(["mpc-bench", "qp-replay", *argv])
    started = time.perf_counter()
    print(f"{command}: recording {args.ticks} ticks of {layout} {shape}, {heading} heading, "
          f"{speed} ({SPEEDS[speed]} x the limits), {mode} mode, N = {HORIZON}", flush=True)
    qps = record(layout, shape, heading, SPEEDS[speed], mode, args.ticks)
    rows_shape = qps[0].rows.shape
    print(f"{len(qps)} QPs of {rows_shape[0]} rows and {rows_shape[1]} columns; replaying "
          f"with {', '.join(solvers)}", flush=True)
    rows = replay(qps, solvers)
    print(table(rows))
    document = {"command": command, "machine": machine(),
                "scenario": {"layout": layout, "trajectory": shape, "heading": heading,
                             "speed": speed, "peak_ratio": SPEEDS[speed], "mode": mode,
                             "horizon": HORIZON, "dt": DT, "ticks": len(qps),
                             "rows": rows_shape[0], "columns": rows_shape[1]},
                "settle": SETTLE, "solvers": rows}
    path = Path(out) / "qp_replay.json"
    path.write_text(json.dumps(document, indent=2) + "\n")
    print(f"wrote {path} ({time.perf_counter() - started:.0f} s)")
    return 0
