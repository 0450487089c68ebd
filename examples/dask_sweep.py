"""A Monte-Carlo sweep on a local Dask cluster.

Shows, with Dask (``pip install 'holonomic-mpc[sweeps]'``):

- a ``distributed.LocalCluster`` of two single-threaded worker processes started here (a
  real cluster's ``tcp://host:port`` works the same: ``mpc-bench sweep --scheduler ...``);
- ``benchmarks.sweep.sample_cases``: random robots (omni, Mecanum, swerve, ball),
  references, starts off the path and plant faults (motor lag, delay told to the MPC, pose
  noise, slip), all from one seed, each case run by every controller (paired);
- ``benchmarks.executor.RunPool(scheduler=...)`` running them on the cluster: workers
  rebuild robots, references and controllers from plain data, so the numbers are the
  same as in this process;
- the summary table ``mpc-bench sweep`` prints, and a figure of each case's RMS position
  error, the MPC against per-wheel clipping.

Run::

    python examples/dask_sweep.py                    # 12 cases of 6 s each
    python examples/dask_sweep.py --runs 40 --duration 10 --out figures/

Prints the cluster, the summary table and how many cases the MPC tracked better.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from distributed import LocalCluster

from benchmarks.executor import RunPool
from benchmarks.sweep import sample_cases, summarise, table

CONTROLLERS = ["mpc-daqp", "ff-p-clip"]
KINDS = ["omni", "mecanum", "swerve", "ball"]


def run(runs: int, duration: float, out: Path) -> dict[str, object]:
    """Sweep ``runs`` random cases of ``duration`` seconds each on a local Dask cluster;
    write ``out/dask_sweep.png``; return the results, their summary and the cluster."""
    skip = min(2.0, duration / 3)
    specs = sample_cases(runs, KINDS, CONTROLLERS, seed=7, duration=duration, skip=skip)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      host="127.0.0.1", dashboard_address=None) as cluster:
        with RunPool(scheduler=cluster.scheduler_address) as pool:
            where, workers = pool.description, pool.workers
            results = pool.run(specs)
    rows = summarise(results)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mpc_runs, clip_runs = results[0::2], results[1::2]     # paired: case by case
    figure, axes = plt.subplots(figsize=(6.4, 5.6))
    for index, kind in enumerate(KINDS):
        pairs = [(m["metrics"]["rms_position_error"], c["metrics"]["rms_position_error"])
                 for m, c in zip(mpc_runs, clip_runs, strict=True)
                 if m.get("layout") == kind and "error" not in m and "error" not in c]
        if pairs:
            values = 1e3 * np.array(pairs)
            axes.scatter(values[:, 1], values[:, 0], color=f"C{index}", label=kind)
    top = max(1e3 * r["metrics"]["rms_position_error"] for r in results if "error" not in r)
    axes.plot([1, 2 * top], [1, 2 * top], "k--", lw=1, label="equal")
    axes.set(xscale="log", yscale="log", xlabel="ff-p-clip: RMS position error [mm]",
             ylabel="mpc-daqp: RMS position error [mm]",
             title=f"{runs} random cases on a local Dask cluster ({workers} workers)\n"
                   "below the line: the MPC tracked better")
    axes.legend(fontsize=8)
    figure.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    figure.savefig(out / "dask_sweep.png", dpi=100)
    plt.close(figure)
    return {"results": results, "rows": rows, "where": where,
            "better": sum(m["metrics"]["rms_position_error"] < c["metrics"]["rms_position_error"]
                          for m, c in zip(mpc_runs, clip_runs, strict=True)
                          if "error" not in m and "error" not in c)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=6.0, help="seconds of each run")
    parser.add_argument("--runs", type=int, default=12, help="random cases")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the figure")
    args = parser.parse_args(argv)
    outcome = run(args.runs, args.duration, args.out)
    print(f"ran on: {outcome['where']}")
    print(table(outcome["rows"]))  # type: ignore[arg-type]
    print(f"mpc-daqp tracked better than ff-p-clip in {outcome['better']} of {args.runs} cases")
    print(f"figure: {args.out / 'dask_sweep.png'}")


if __name__ == "__main__":  # the cluster's worker processes import this file: keep the guard
    main()
