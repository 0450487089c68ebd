"""``mpc-bench tune``: tune the MPC's cost weights for one robot (Optuna, seeded TPE).

Objective J, lower is better: the mean over the scenarios s of

    time mode:  c_s = sqrt((e_pos / 10 mm)^2 + (e_head / H)^2)
    path mode:  c_s = sqrt((e_path / 10 mm)^2 + (e_head / H)^2 + (max(0, lap/target - 1) / 5%)^2)

where c_s also gains 100 if the run commands a wheel beyond a speed or acceleration
limit and 100 x the fraction of its ticks not solved (fallbacks), and is 1000 for a run
that raises. e_pos is the RMS distance to the time-indexed reference, e_path the RMS
distance to the path (cross-track), e_head the RMS heading error [deg], all after
--skip seconds; H is --heading-scale (default 2 deg: 1 deg of heading costs as much as
5 mm of position); lap / target is the steady lap over the fastest lap a path follower
can keep (2 when no lap completes). Being a pose error in one metric, c_s has its
minimum where trading heading for position stops paying, not at either extreme.

--objective baseline (time mode) scores each scenario against the baseline with the
lowest position RMS there, b (ff-p-clip, ff-p-desat, ff-p-setpoint for swerve):

    c_s = max(e_pos, 1 mm) / max(e_pos_b, 1 mm) + max(0, e_head - e_head_b - 1 deg) / 1 deg

(the same penalties), below 1 where the MPC has the lower position RMS with a heading RMS
at most 1 deg above the baseline's: the benchmark's criterion of a win.

Scenarios (default): the robot's circle and figure-eight, fixed and tangent heading,
inside (0.8 x) and 1.3 x beyond the wheel limits, with mpc-daqp (time mode) or
mpc-path (--modes path). Search space, log-uniform (defaults in brackets): heading
weight pose_theta in [1, 500] (50), terminal = terminal_scale x pose with terminal_scale
in [0.5, 10] (2), twist xy [0.01, 10] (1) and theta [0.001, 1] (0.1), rate xy
[0.01, 5] (0.2) and theta [0.001, 0.5] (0.02); path mode adds contour [200, 20000]
(2000), progress [0.01, 1] (0.1), progress_reward [0.02, 2] (0.2), progress_rate
[0.001, 0.1] (0.01); --tune-horizon adds the horizon in 10..40 step 5. The position
weight stays 200: time mode's cost is quadratic, so only ratios matter. Trial 0 is the
defaults. Writes weights.toml (``mpc.model.weights.load_weights``), study.json,
summary.md (before/after against the baselines), history.png and importance.png (PED-ANOVA).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks.cli import add_pool_arguments
from benchmarks.executor import RunPool, RunSpec, check_pool_options, optimal_lap
from benchmarks.options import add_list_option
from benchmarks.outdir import add_force_argument, claim
from benchmarks.progress import Progress
from benchmarks.runner import build_scenarios, describe_robot, run_pace
from benchmarks.scenarios import (
    HEADINGS,
    PRESETS,
    TRAJECTORIES,
    Parser,
    ScenarioError,
    Settings,
    applies,
    choose,
    parse_speeds,
    seed,
)
from mpc.errors import MpcError
from mpc.model.weights import Weights
from mpc.robots import Robot, load, preset

#: (low, high) of each tuned parameter, log-uniform; path-mode parameters last.
SPACE: dict[str, tuple[float, float]] = {
    "heading": (1.0, 500.0), "terminal_scale": (0.5, 10.0), "twist_xy": (0.01, 10.0),
    "twist_theta": (0.001, 1.0), "rate_xy": (0.01, 5.0), "rate_theta": (0.001, 0.5),
    "contour": (200.0, 20000.0), "progress": (0.01, 1.0), "progress_reward": (0.02, 2.0),
    "progress_rate": (0.001, 0.1),
}
PATH_ONLY = ("contour", "progress", "progress_reward", "progress_rate")
BASELINES = ("ff-p-clip", "ff-p-desat", "ff-p-setpoint")
POSITION_SCALE = 0.010  # [m] of position (or path) RMS that count 1
LAP_SCALE = 0.05  # lap 5% over the target counts 1
VIOLATION_PENALTY, FAILURE_PENALTY, ERROR_COST = 100.0, 100.0, 1000.0


def default_params(mode: str, horizon: int | None = None) -> dict[str, float]:
    """The parameters of the default weights (trial 0)."""
    w = Weights()
    params = {"heading": w.pose[2], "terminal_scale": w.terminal[0] / w.pose[0],
              "twist_xy": w.twist[0], "twist_theta": w.twist[2], "rate_xy": w.rate[0],
              "rate_theta": w.rate[2], "contour": w.contour, "progress": w.progress,
              "progress_reward": w.progress_reward, "progress_rate": w.progress_rate}
    params = {k: float(v) for k, v in params.items() if mode == "path" or k not in PATH_ONLY}
    return params if horizon is None else {**params, "horizon": horizon}


def weights_of(params: dict[str, float]) -> dict[str, Any]:
    """Controller weights (``Controller(weights=...)``) from a trial's parameters."""
    xy = float(Weights().pose[0])
    pose = [xy, xy, params["heading"]]
    weights: dict[str, Any] = {
        "pose": pose, "terminal": [params["terminal_scale"] * v for v in pose],
        "twist": [params["twist_xy"], params["twist_xy"], params["twist_theta"]],
        "rate": [params["rate_xy"], params["rate_xy"], params["rate_theta"]]}
    return {**weights, **{k: params[k] for k in PATH_ONLY if k in params}}


def scenario_cost(run: dict[str, Any], mode: str, heading_scale: float,
                  baseline: dict[str, Any] | None = None) -> float:
    """c_s of one run (see the module docstring); ``run`` as the executor returns it, with
    ``target_lap`` added for path mode; ``baseline``: that scenario's best baseline run
    (``--objective baseline``)."""
    if "error" in run:
        return ERROR_COST
    m = run["metrics"]
    if baseline is not None:
        b = baseline.get("metrics") or {"rms_position_error": math.inf,
                                        "rms_heading_error": math.inf}
        excess = math.degrees(m["rms_heading_error"] - b["rms_heading_error"]) - 1.0
        cost = (max(m["rms_position_error"], 1e-3) / max(b["rms_position_error"], 1e-3)
                + max(0.0, excess))
    else:
        error = m["rms_cross_track_error"] if mode == "path" else m["rms_position_error"]
        terms = [error / POSITION_SCALE, math.degrees(m["rms_heading_error"]) / heading_scale]
        if mode == "path":
            pace = run_pace(run)
            terms.append(max(0.0, (2.0 if pace is None else pace) - 1.0) / LAP_SCALE)
        cost = math.hypot(*terms)
    penalty = VIOLATION_PENALTY * (m["limit_violations"] + m["accel_violations"] > 0)
    return cost + penalty + FAILURE_PENALTY * m["failures"] / max(1, run["ticks"])


def tuned_robot(name: str) -> Robot:
    """``--robot``: a preset name or a robot file, or ScenarioError naming the flag."""
    try:
        return load(name) if name.endswith(".toml") else preset(name)
    except MpcError as error:
        raise ScenarioError(f"--robot: {error}") from None


class Tuner:
    """The study's runs: one spec per scenario for a parameter set, costs per trial."""

    def __init__(self, args: Any, pool: RunPool, log: Any) -> None:
        robot = tuned_robot(args.robot)
        self.robot_spec = args.robot if args.robot in PRESETS else describe_robot(robot)
        self.mode, self.args, self.pool = args.mode, args, pool
        trajectories = choose("--trajectories", "trajectory", args.trajectories, TRAJECTORIES)
        headings = choose("--headings", "heading", args.headings, HEADINGS, ("fixed", "tangent"))
        self.scenarios = build_scenarios({robot.name: robot}, trajectories,
                                         parse_speeds(args.speeds), headings, None)
        self.trajectories = [{"shape": s.trajectory_name, "heading": s.heading,
                              "period": s.trajectory.period} for s in self.scenarios]
        log(f"tune: {robot.name}, {len(self.scenarios)} scenarios, {args.mode} mode, "
            f"on {pool.description}")
        self.laps = pool.map(optimal_lap, [(self.robot_spec, t) for t in self.trajectories])
        self.references: list[dict[str, Any]] | None = None  # best baseline per scenario
        names = [] if args.mode == "path" else [n for n in BASELINES if applies(n, robot)]
        runs = self.pool.run([spec for name in names for spec in self.specs(name, None)])
        size = len(self.scenarios)
        self.baseline_runs = {name: runs[i * size:(i + 1) * size] for i, name in enumerate(names)}
        if args.objective == "baseline":
            self.references = [min((r[i] for r in self.baseline_runs.values()), key=_position)
                               for i in range(size)]

    def specs(self, controller: str, params: dict[str, float] | None) -> list[RunSpec]:
        horizon = int(params.get("horizon", self.args.horizon)) if params else self.args.horizon
        return [RunSpec(robot=self.robot_spec, trajectory=trajectory, controller=controller,
                        labels={"layout": s.layout, "trajectory": s.trajectory_name,
                                "heading": s.heading, "speed": s.speed},
                        settings=Settings(horizon=horizon, dt=self.args.dt),
                        duration=self.args.duration, skip=self.args.skip,
                        weights=None if params is None else weights_of(params),
                        optimal_lap=lap)
                for s, trajectory, lap in zip(self.scenarios, self.trajectories, self.laps,
                                              strict=True)]

    def evaluate(self, batch: list[tuple[str, dict[str, float] | None]]
                 ) -> list[tuple[float, list[dict[str, Any]]]]:
        """(J, runs) of each (controller, parameters), all runs in one go on the pool."""
        specs = [spec for name, params in batch for spec in self.specs(name, params)]
        results = self.pool.run(specs)
        size = len(self.scenarios)
        return [self.cost(results[i * size:(i + 1) * size]) for i in range(len(batch))]

    def cost(self, runs: list[dict[str, Any]]) -> tuple[float, list[dict[str, Any]]]:
        """J of one run per scenario, and the runs."""
        references: list[dict[str, Any] | None] = [None] * len(runs)
        if self.references is not None:
            references = list(self.references)
        for run, lap in zip(runs, self.laps, strict=True):
            run["target_lap"] = lap
        costs = [scenario_cost(run, self.mode, self.args.heading_scale, reference)
                 for run, reference in zip(runs, references, strict=True)]
        return sum(costs) / len(costs), runs


def _position(run: dict[str, Any]) -> float:
    return float(run["metrics"]["rms_position_error"]) if "metrics" in run else math.inf


def study(tuner: Tuner, trials: int, progress: Callable[[int, int, str], None]) -> Any:
    """Run the seeded study; trial 0 is the defaults. Returns the Optuna study.
    ``progress(done, trials, line)`` after each batch of trials."""
    try:
        import optuna
    except ImportError:
        raise ScenarioError("mpc-bench tune needs optuna: "
                            "pip install 'holonomic-mpc[sweeps]'") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    args = tuner.args
    sampler = optuna.samplers.TPESampler(seed=args.seed, constant_liar=True)
    result = optuna.create_study(direction="minimize", sampler=sampler)
    result.enqueue_trial(default_params(args.mode, args.horizon if args.tune_horizon else None))
    started = time.perf_counter()
    while len(result.trials) < trials:
        asked = [result.ask() for _ in range(min(args.batch, trials - len(result.trials)))]
        params = [_suggest(trial, args) for trial in asked]
        controller = "mpc-path" if args.mode == "path" else "mpc-daqp"
        for trial, (cost, runs) in zip(asked, tuner.evaluate(
                [(controller, p) for p in params]), strict=True):
            trial.set_user_attr("runs", [_compact(run) for run in runs])
            result.tell(trial, cost)
        done = len(result.trials)
        eta = (time.perf_counter() - started) / done * (trials - done)
        progress(done, trials, f"trial {done:3d}/{trials}  J {result.trials[-1].value:8.4g}  "
                               f"best {result.best_value:8.4g} (trial "
                               f"{result.best_trial.number})  eta {eta:.0f} s")
    return result


def _suggest(trial: Any, args: Any) -> dict[str, float]:
    params = {name: trial.suggest_float(name, low, high, log=True)
              for name, (low, high) in SPACE.items()
              if args.mode == "path" or name not in PATH_ONLY}
    if args.tune_horizon:
        params["horizon"] = trial.suggest_int("horizon", 10, 40, step=5)
    return params


def _compact(run: dict[str, Any]) -> dict[str, Any]:
    """What the study keeps of a run: its labels and its tracking numbers."""
    if "error" in run:
        return {k: run[k] for k in ("trajectory", "heading", "speed", "error")}
    m = run["metrics"]
    keep = ("rms_position_error", "rms_heading_error", "rms_cross_track_error",
            "max_cross_track_error", "limit_violations", "accel_violations", "failures")
    return {"trajectory": run["trajectory"], "heading": run["heading"], "speed": run["speed"],
            **{k: m[k] for k in keep}, "lap_ratio": run_pace(run)}


def write_weights(result: Any, args: Any, command: str, out: Path) -> dict[str, Any]:
    """Write the best weights as TOML; return the study as plain data."""
    best, defaults = result.best_trial, result.trials[0]
    weights = weights_of(best.params)
    lines = [f"# MPC cost weights for {args.robot}, {args.mode} mode, tuned by", f"#   {command}",
             f"# J ({args.objective} objective, mpc-bench tune --help): defaults "
             f"{defaults.value:.4g}, these "
             f"{best.value:.4g} (trial {best.number} of {len(result.trials)}).",
             "# Load: Controller(..., weights=mpc.model.weights.load_weights(path))"]
    if "horizon" in best.params:
        lines.append(f"# Tuned with Controller(horizon={best.params['horizon']}).")
    lines += [f"{name} = {list(value) if isinstance(value, list) else value!r}"
              for name, value in weights.items()]  # repr: the exact tuned numbers
    (out / "weights.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return {"command": command, "robot": args.robot, "mode": args.mode,
            "objective": args.objective, "heading_scale": args.heading_scale,
            "defaults": {"J": defaults.value, "params": defaults.params,
                         "runs": defaults.user_attrs["runs"]},
            "best": {"J": best.value, "trial": best.number, "params": best.params,
                     "weights": weights, "runs": best.user_attrs["runs"]},
            "trials": [{"number": t.number, "J": t.value, "params": t.params}
                       for t in result.trials]}


def _cell(run: dict[str, Any], mode: str) -> str:
    if "error" in run:
        return "failed"
    head = math.degrees(run["rms_heading_error"])
    if mode == "path":
        lap = "-" if run["lap_ratio"] is None else f"{run['lap_ratio']:.3f}"
        return f"{run['rms_cross_track_error'] * 1e3:.3g} / {head:.2f} / {lap}"
    return f"{run['rms_position_error'] * 1e3:.3g} / {head:.2f}"


def _beats(run: dict[str, Any], baseline: dict[str, Any]) -> bool:
    """Position RMS no more than 1 mm above the baseline's (lower, where errors are
    large), heading RMS no more than 1 deg above."""
    if "error" in run or "error" in baseline:
        return "error" not in run
    return bool(run["rms_position_error"] <= baseline["rms_position_error"] + 1e-3
                and run["rms_heading_error"] <= baseline["rms_heading_error"]
                + math.radians(1.0))


def before_after(document: dict[str, Any]) -> str:
    """Per scenario: defaults, tuned and (time mode) the best baseline, as Markdown."""
    mode = document["mode"]
    unit = "path [mm] / heading [deg] / lap/target" if mode == "path" else "RMS mm / deg"
    head = f"| scenario | defaults {unit} | tuned |"
    rows = [head + (" best baseline | defaults beat it | tuned beat it |" if mode == "time"
                    else ""), "|---" * (head.count("|") - 1 + 3 * (mode == "time")) + "|"]
    baselines = document.get("baselines", {})
    for i, (old, new) in enumerate(zip(document["defaults"]["runs"], document["best"]["runs"],
                                       strict=True)):
        row = (f"| {old['trajectory']} {old['heading']} {old['speed']} | {_cell(old, mode)} | "
               f"{_cell(new, mode)} |")
        if mode == "time" and baselines:
            name, best = min(((n, b["runs"][i]) for n, b in baselines.items()),
                             key=lambda item: item[1].get("rms_position_error", math.inf))
            row += (f" {_cell(best, mode)} ({name}) | {'yes' if _beats(old, best) else 'NO'} | "
                    f"{'yes' if _beats(new, best) else 'NO'} |")
        rows.append(row)
    return "\n".join(rows)


def write_figures(result: Any, document: dict[str, Any], out: Path) -> None:
    """history.png (J per trial, best so far, defaults) and importance.png (PED-ANOVA)."""
    import optuna
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    values = [t["J"] for t in document["trials"]]
    figure = Figure(figsize=(7, 4), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    axes.plot(range(len(values)), values, "o", ms=4, label="trial")
    axes.step(range(len(values)), [min(values[:i + 1]) for i in range(len(values))],
              where="post", label="best so far")
    axes.axhline(values[0], ls="--", color="grey", label="defaults (trial 0)")
    top = min(max(values), 1.5 * values[0])  # worse trials run off the top
    axes.set(xlabel="trial", ylabel="J (lower is better)", ylim=(0.95 * min(values), top),
             title=f"{document['robot']}, {document['mode']} mode")
    axes.legend()
    figure.savefig(out / "history.png", dpi=100)
    # PED-ANOVA (no scikit-learn, deterministic): which parameters set the best trials apart
    evaluator = optuna.importance.PedAnovaImportanceEvaluator()
    try:
        importances = optuna.importance.get_param_importances(result, evaluator=evaluator)
    except (ValueError, RuntimeError):  # too few distinct trials to tell
        return
    document["importances"] = {k: float(v) for k, v in importances.items()}
    figure = Figure(figsize=(6, 0.4 * len(importances) + 1), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    names = list(importances)[::-1]
    axes.barh(names, [importances[n] for n in names])
    axes.set(xlabel="importance (PED-ANOVA, normalised)", title="parameter importance")
    figure.savefig(out / "importance.png", dpi=100)


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench tune", description=__doc__.split("\n\n")[0],
                    epilog=__doc__.split("\n\n", 1)[1],
                    formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot", default="omni3",
                        help=f"a preset ({', '.join(PRESETS)}) or a robot TOML file (omni3)")
    add_list_option(parser, "--modes", dest="mode", metavar="MODE", choices=("time", "path"),
                    default="time",
                    help="the controller mode tuned, one of time, path (time)")
    parser.add_argument("--objective", choices=("pose", "baseline"), default="pose",
                        help="pose: the pose error in one metric; baseline: against the best "
                             "baseline per scenario (time mode; see below)")
    parser.add_argument("--trials", type=int, default=60, help="trials, the defaults first (60)")
    parser.add_argument("--batch", type=int, default=1,
                        help="trials evaluated at once (1; more for big clusters: the sampler "
                             "then proposes with fewer results, results depend on it)")
    parser.add_argument("--seed", type=seed, default=0, help="sampler seed (0)")
    add_list_option(parser, "--trajectories", help="comma list (default: circle,figure8)")
    add_list_option(parser, "--headings", help="comma list of headings (default: fixed,tangent)")
    add_list_option(parser, "--speeds", help="comma list (default: inside,beyond)")
    parser.add_argument("--heading-scale", type=float, default=2.0, metavar="DEG",
                        help="heading RMS that costs as much as 10 mm of position RMS (2)")
    parser.add_argument("--horizon", type=int, default=20, help="MPC horizon (20)")
    parser.add_argument("--tune-horizon", action="store_true", help="tune the horizon too")
    parser.add_argument("--dt", type=float, default=0.05, help="control tick [s] (0.05)")
    parser.add_argument("--duration", type=float,
                        help="simulated seconds per run (default: two laps at the target pace)")
    parser.add_argument("--skip", type=float, default=2.0, help="settling seconds (2)")
    parser.add_argument("--out", default="tune-out", metavar="DIR",
                        help="writes weights.toml, study.json, summary.md and the figures "
                             "here (tune-out)")
    add_force_argument(parser)
    add_pool_arguments(parser)
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if args.trials < 2 or args.batch < 1 or not args.heading_scale > 0:
        raise ScenarioError("--trials must be >= 2, --batch >= 1, --heading-scale > 0")
    if args.objective == "baseline" and args.mode == "path":
        raise ScenarioError("--objective baseline compares time-mode runs: use --modes time")
    if args.horizon < 1 or not args.dt > 0 or (args.duration is not None
                                               and not args.duration > args.skip >= 0):
        raise ScenarioError("--horizon must be >= 1, --dt > 0, --duration > --skip >= 0")
    tuned_robot(args.robot)  # every option checked before the output folder is made
    check_pool_options(args.workers, args.scheduler)
    out = claim(args.out, ("weights.toml", "study.json", "summary.md", "history.png",
                           "importance.png"), args.force)
    with RunPool(args.workers, args.scheduler) as pool, Progress(args.trials, "trials") as bar:
        tuner = Tuner(args, pool, bar.print)
        result = study(tuner, args.trials, bar.update)
        baselines = [(name, tuner.cost(runs)) for name, runs in tuner.baseline_runs.items()]
    command = " ".join(["mpc-bench", "tune", *argv])
    document = write_weights(result, args, command, out)
    document["baselines"] = {name: {"J": cost, "runs": [_compact(r) for r in runs]}
                             for name, (cost, runs) in baselines}
    table = before_after(document)
    (out / "summary.md").write_text(table + "\n", encoding="utf-8")
    write_figures(result, document, out)
    (out / "study.json").write_text(json.dumps(document, indent=1), encoding="utf-8")
    print(table)
    others = "".join(f", {name} {b['J']:.4g}" for name, b in document["baselines"].items())
    print(f"J: defaults {document['defaults']['J']:.4g}, tuned {document['best']['J']:.4g} "
          f"(trial {document['best']['trial']}){others}\nwrote {out / 'weights.toml'}, "
          f"study.json, summary.md, history.png, importance.png")
    return 0
