"""``mpc-bench perf``: tick time against horizon for both solver paths.

Mecanum, figure-eight inside the limits (peak wheel speed 0.8 x limit), fixed
heading, dt 0.05 s, ideal plant. Every figure is a median over the run's
ticks, and the comparisons are ratios within this one run, because the
machines are shared and noisy. ``solve`` is the solver's own time (OSQP: the
KKT refactorisation done by ``update`` plus the iterations; IPOPT: its wall
time); ``overhead`` is the rest of ``step()``: Python, NumPy and CasADi.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.runner import machine
from benchmarks.scenarios import Parser, ScenarioError, reference
from mpc import Controller
from mpc.robots import preset
from mpc.sim import simulate


def measure(solver: str, horizon: int, ticks: int, dt: float = 0.05) -> dict[str, Any]:
    """Median tick, solve and overhead times [s] of one closed-loop run."""
    robot = preset("mecanum")
    trajectory = reference("figure8", "fixed", robot, 0.8)
    control = Controller(robot, trajectory, horizon=horizon, dt=dt, solver=solver)
    result = simulate(control, ticks * dt)
    settle = min(10, ticks // 5)  # the first ticks converge from a cold start
    tick, solve = result.tick_time[settle:], result.solve_time[settle:]
    return {
        "solver": solver, "horizon": horizon, "ticks": len(tick),
        "tick_p50": float(np.median(tick)), "tick_p99": float(np.percentile(tick, 99)),
        "solve_p50": float(np.median(solve)),
        "overhead_p50": float(np.median(tick - solve)),
        "iterations_p50": float(np.median(result.iterations[settle:])),
        "rms_position_error": result.metrics(skip=2.0 if ticks * dt > 4 else 0.0)[
            "rms_position_error"],
    }


def main(argv: list[str]) -> int:
    parser = Parser(prog="mpc-bench perf", description=__doc__.split("\n")[0])
    parser.add_argument("--horizons", default="10,20,50,100",
                        help="OSQP horizons (10,20,50,100)")
    parser.add_argument("--ticks", type=int, default=400, help="ticks per OSQP run (400)")
    parser.add_argument("--ipopt-ticks", type=int, default=120, help="ticks per IPOPT run (120)")
    parser.add_argument("--out", default="bench-out", metavar="DIR", help="writes perf.json here")
    args = parser.parse_args(argv)
    try:
        horizons = [int(h) for h in args.horizons.split(",")]
    except ValueError:
        raise ScenarioError(
            f"--horizons must be a comma list of integers, got {args.horizons!r}") from None
    if not horizons or min(horizons) < 1 or args.ticks < 20 or args.ipopt_ticks < 20:
        raise ScenarioError("horizons must be >= 1 and --ticks, --ipopt-ticks >= 20")

    rows = []
    print(f"{'solver':6s} {'N':>4s} {'tick p50':>9s} {'solve p50':>9s} {'overhead':>9s} "
          f"{'tick/solve':>10s} {'iters':>6s} {'rms err':>9s}")
    print(f"{'':6s} {'':>4s} {'[ms]':>9s} {'[ms]':>9s} {'[ms]':>9s} {'':>10s} {'':>6s} "
          f"{'[mm]':>9s}")
    plan = [("osqp", h, args.ticks) for h in horizons] + [("ipopt", 20, args.ipopt_ticks)]
    for solver, horizon, ticks in plan:
        row = measure(solver, horizon, ticks)
        rows.append(row)
        print(f"{solver:6s} {horizon:4d} {row['tick_p50'] * 1e3:9.3f} "
              f"{row['solve_p50'] * 1e3:9.3f} "
              f"{row['overhead_p50'] * 1e3:9.3f} {row['tick_p50'] / row['solve_p50']:10.2f} "
              f"{row['iterations_p50']:6.0f} {row['rms_position_error'] * 1e3:9.4f}", flush=True)
    osqp = {r["horizon"]: r for r in rows if r["solver"] == "osqp"}
    ipopt = next(r for r in rows if r["solver"] == "ipopt")
    summary: dict[str, Any] = {}
    if 20 in osqp:
        summary["osqp_tick_over_solve_N20"] = osqp[20]["tick_p50"] / osqp[20]["solve_p50"]
        summary["ipopt_over_osqp_tick_N20"] = ipopt["tick_p50"] / osqp[20]["tick_p50"]
    low, high = min(osqp), max(osqp)
    if high > low:
        summary["tick_growth"] = {"from": low, "to": high,
                                  "horizon_ratio": high / low,
                                  "tick_ratio": osqp[high]["tick_p50"] / osqp[low]["tick_p50"]}
    print()
    for key, value in summary.items():
        print(f"{key}: {value if isinstance(value, dict) else round(value, 2)}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "perf.json").write_text(json.dumps({"machine": machine(), "rows": rows,
                                               "summary": summary}, indent=1))
    print(f"wrote {out / 'perf.json'}")
    return 0
