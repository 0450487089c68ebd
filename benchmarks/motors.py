"""``mpc-bench motors``: what motor-aware limits buy, on the motor plant.

Every layout with motors (:func:`mpc.robots.motor_preset`), circle and figure-eight, the
reference timed so that it needs **100 % of the motor model, not derated**: its peak,
over a lap, of wheel speed / free speed, drive torque / current-limited torque and
contact force / ``mu N`` is exactly 1 (the box Choreo plans in: full free speed and full
torque, each on its own; the DC motor cannot give both at once, back-EMF takes the
torque away as the speed rises, and the battery sags under load). Controllers:

==================  ==========================================================================
``mpc-motors``      this project with the motor rows (daqp fast path); ``-osqp``, ``-ipopt``
``mpc-kinematic``   the same MPC given the kinematic stand-in a team would derive from the
                    motors: speed limit = free speed, acceleration limit = the one a wheel's
                    force limit (current or traction) gives its share of the mass
``ff-p-clip``       feedforward + P, per-wheel clipping into the stand-in's limits
``ff-p-desat``      feedforward + P, WPILib-style desaturation into them
``ff-p-setpoint``   swerve: feedforward + P through a Team 254-style setpoint generator
==================  ==========================================================================

All run on :class:`~mpc.sim.motor_plant.MotorPlant` (the motors' voltage, current,
back-EMF, battery sag, traction and slip; the same wheel velocity loop with acceleration
feedforward for every controller) from rest on the reference. Reported per run: RMS
position error after the settling time, ticks with a battery-voltage or current-limit
violation (a wheel loop asked for more than the bus or the limit gives), slip events
(ticks on which a wheel slid), and tick times.

``--traction`` instead compares the motor-aware MPC under planner variants (headroom,
battery sag, traction polygon) with the kinematic MPC on fixed-heading figure-eights timed
to ratios of the geared free speed (:func:`traction`; docs/guide/traction.md).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from benchmarks.options import add_list_option
from benchmarks.outdir import add_force_argument, claim
from benchmarks.runner import machine
from benchmarks.scenarios import Parser, ScenarioError, choose, seed
from benchmarks.scenarios import reference as scenario_reference
from mpc import Controller
from mpc.arrays import FloatArray
from mpc.errors import MpcError, RobotError
from mpc.robots import (
    MOTOR_ROBOT_PRESETS,
    Robot,
    motor_preset,
)
from mpc.robots.drive import motor_rows
from mpc.robots.drive.force_map import force_map
from mpc.sim import (
    FeedforwardPController,
    FeedforwardPSetpointController,
    TrackingController,
    simulate,
)
from trajectories import Circle, FigureEight, Trajectory

CONTROLLERS: tuple[str, ...] = ("mpc-motors", "mpc-motors-osqp", "mpc-motors-ipopt",
                                "mpc-kinematic", "ff-p-clip", "ff-p-desat", "ff-p-setpoint")
DEFAULT_CONTROLLERS: tuple[str, ...] = ("mpc-motors", "mpc-kinematic", "ff-p-clip",
                                        "ff-p-desat", "ff-p-setpoint")
TRAJECTORIES: tuple[str, ...] = ("circle", "figure8")
_PROBE_PERIOD = 10.0


def kinematic_stand_in(robot: Robot) -> Robot:
    """``robot`` without dynamics, with the kinematic limits a team would derive from its
    motors (Choreo's view): the speed limit is the free speed at the battery voltage; the
    acceleration limit of wheel ``i`` is its largest torque over its share of the mass at
    its rim, ``tau_max / (J + m_i r_i^2)`` [rad/s^2] (the wheel's rim acceleration
    ``tau_max / (r_i m_i)`` over ``r_i``), with ``tau_max`` the smaller of the
    current-limited torque and the torque that reaches traction when the wheel pushes
    alone (``mu N / |W_i|``, ``|W_i|`` its rolling map's planar norm: ``1 / r`` for a plain
    wheel or a swerve module, ``1 / (r cos gamma)`` for a Swedish wheel, whose force lies
    along its rollers), and ``m_i`` its contact's share of the mass."""
    forces = force_map(robot)
    dyn = forces.dynamics
    blocks = robot.wheel_blocks
    reach = np.linalg.norm(blocks[:, :, :2], axis=2).max(axis=1)  # |W_i[:2]| (n,)
    share = dyn.mass / forces.n_contacts
    limit = np.full(robot.n_wheels, forces.torque_limit)
    traction = forces.friction_limits
    if traction is not None:
        limit = np.minimum(limit, traction[forces.contact_of] / reach)
    accel = limit / (dyn.wheel_inertia + share * forces.radii**2)
    speed = dyn.free_speed
    try:
        return robot.with_wheel_limits(speed, accel)
    except RobotError as error:
        raise ScenarioError(f"no kinematic stand-in for robot {robot.name!r}: {error}") from None


def motor_demand(trajectory: Trajectory, robot: Robot, samples: int = 1201) -> float:
    """The peak over one lap of the reference's need against the motor model, no headroom:
    ``max(|wheel speed| / free speed, |drive torque| / torque limit, |F_c| / (mu N_c))``
    (drive torque with the wheel inertia; a swerve module's along its wheel)."""
    forces = force_map(robot)
    dyn = forces.dynamics
    period = trajectory.period or trajectory.duration or 10.0
    times = np.linspace(0.0, period, samples)
    sample = trajectory.sample(times)
    twist = trajectory.body_twist(times)
    theta = sample.pose[:, 2]
    c, s = np.cos(theta), np.sin(theta)
    accel = np.stack([c * sample.acceleration[:, 0] + s * sample.acceleration[:, 1],
                      -s * sample.acceleration[:, 0] + c * sample.acceleration[:, 1],
                      sample.acceleration[:, 2]], axis=1)  # body-frame acceleration
    twist_rate = accel.copy()  # du/dt = a - coriolis(u)
    twist_rate[:, 0] += twist[:, 2] * twist[:, 1]
    twist_rate[:, 1] -= twist[:, 2] * twist[:, 0]
    velocity = np.einsum("ndj,kj->knd", robot.wheel_blocks, twist)
    torque = (np.einsum("ndj,kj->knd", forces.effort_map, accel)
              + dyn.wheel_inertia * np.einsum("ndj,kj->knd", robot.wheel_blocks, twist_rate))
    speed = np.linalg.norm(velocity, axis=2)
    if robot.wheel_dim == 2:
        direction = velocity / np.maximum(speed, 1e-9)[:, :, None]
        drive = np.abs(np.einsum("knd,knd->kn", torque, direction))
    else:
        drive = np.abs(torque[:, :, 0])
    ratios = [speed.max() / dyn.free_speed, drive.max() / forces.torque_limit]
    traction = forces.friction_limits
    if traction is not None:
        contact = np.linalg.norm(np.einsum("cij,kj->kci", forces.contact_maps, accel), axis=2)
        ratios.append(float((contact / traction).max()))
    return float(max(ratios))


def motor_reference(name: str, robot: Robot, ratio: float = 1.0, size: float = 1.0,
                    heading: str = "fixed") -> Trajectory:
    """The named shape (``size`` [m]) timed so that :func:`motor_demand` is ``ratio``."""

    def make(period: float) -> Trajectory:
        spec: Any = 0.0 if heading == "fixed" else "tangent"
        if name == "circle":
            return Circle(size, period, heading=spec)
        return FigureEight(size, period, heading=spec)

    low, high = 0.05, 200.0  # demand falls as the period grows
    for _ in range(60):
        middle = math.sqrt(low * high)
        if motor_demand(make(middle), robot) > ratio:
            low = middle
        else:
            high = middle
    return make(high)


def free_speed_reference(name: str, robot: Robot, ratio: float = 1.0, size: float = 1.0,
                         heading: str = "fixed") -> Trajectory:
    """The named shape (``size`` [m]) timed so that its peak wheel speed over a lap is
    ``ratio`` times the geared free speed (``robot.max_wheel_speed``: the motor's free
    speed over the gearing); beyond 1 the reference asks for more than the robot can do."""
    spec: Any = 0.0 if heading == "fixed" else "tangent"
    shape = Circle if name == "circle" else FigureEight
    probe_period = 10.0
    probe = shape(size, probe_period, heading=spec)
    times = np.linspace(0.0, probe_period, 2001)
    wheel = np.einsum("ndj,kj->knd", robot.wheel_blocks, probe.body_twist(times))
    peak = float(np.linalg.norm(wheel, axis=2).max())
    return shape(size, probe_period * peak / (ratio * float(robot.max_wheel_speed.max())),
                 heading=spec)


#: The planner settings ``mpc-bench motors --traction`` compares by default (the shipped
#: ones first): the headroom kept for the wheel loops, the battery's sag and the sides of
#: the traction polygon.
TRACTION_VARIANTS: tuple[str, ...] = ("default", "headroom=0.025", "headroom=0",
                                      "no-sag", "headroom=0.025+no-sag", "sides=16")


def variant_robot(robot: Robot, spec: str) -> tuple[Robot, int]:
    """The robot the motor-aware MPC plans with under a planner variant ``spec`` (terms
    joined by ``+``: ``default``, ``headroom=X`` (current and traction),
    ``voltage_headroom=X``, ``no-sag`` (plan with an unsagged battery), ``sides=N`` (the
    traction polygon's sides)) and the polygon's sides; the plant keeps the true robot."""
    dyn = robot.dynamics
    if dyn is None:
        raise ScenarioError(f"robot {robot.name!r} has no dynamics")
    sides = motor_rows.TRACTION_SIDES
    changes: dict[str, Any] = {}
    for term in spec.split("+"):
        key, _, value = term.partition("=")
        try:
            if term == "default":
                continue
            if term == "no-sag":
                changes["battery_resistance"] = 0.0
            elif key in ("headroom", "voltage_headroom") and value:
                changes[key] = float(value)
            elif key == "sides" and value:
                sides = int(value)
                if sides < 4 or sides % 2:
                    raise ValueError
            else:
                raise ValueError
        except ValueError:
            raise ScenarioError(f"planner variant {term!r}: expected default, headroom=X, "
                                f"voltage_headroom=X, no-sag or sides=N (N even, >= 4)"
                                ) from None
    try:
        return robot.with_dynamics(dataclasses.replace(dyn, **changes)), sides
    except RobotError as error:
        raise ScenarioError(f"planner variant {spec!r}: {error}") from None


@contextlib.contextmanager
def _polygon_sides(sides: int) -> Iterator[None]:
    """The traction polygon's sides while a controller builds its rows."""
    before = motor_rows.TRACTION_SIDES
    motor_rows.TRACTION_SIDES = sides
    try:
        yield
    finally:
        motor_rows.TRACTION_SIDES = before


def traction(layouts: list[str], sizes: list[float], ratios: list[float],
             variants: list[str], *, duration: float = 12.0, skip: float = 2.0,
             dt: float = 0.05, horizon: int = 20, seed: int = 0,
             log: Any = print) -> list[dict[str, Any]]:
    """Fixed-heading figure-eights of each size [m] timed to each ratio of the geared free
    speed (:func:`free_speed_reference`), ``duration`` seconds on the motor plant from
    rest: the kinematic MPC (its stand-in) and the motor-aware MPC under each planner
    variant (:func:`variant_robot`). One row per run; ``variant`` is None for the
    kinematic MPC."""
    rows = []
    for layout in layouts:
        robot = motor_preset(layout)
        for size in sizes:
            for ratio in ratios:
                reference = free_speed_reference("figure8", robot, ratio, size)
                runs: list[tuple[str, str | None]] = [("mpc-kinematic", None)]
                runs += [("mpc-motors", v) for v in variants]
                for name, variant in runs:
                    started = time.perf_counter()
                    if variant is None:
                        control = controller(name, robot, reference, dt, horizon)
                    else:
                        planner, sides = variant_robot(robot, variant)
                        with _polygon_sides(sides):
                            control = Controller(planner, reference, horizon, dt,
                                                 command_ramp=True)
                    result = simulate(control, duration, plant="motor", robot=robot,
                                      seed=seed)
                    m = result.metrics(skip=skip)
                    events = result.plant_events or {}
                    planned = events.get("planned_traction_ratio", np.zeros(1))
                    row = {"layout": layout, "size": size, "speed_ratio": ratio,
                           "period": float(reference.period or 0.0), "controller": name,
                           "variant": variant,
                           **{key: m[key] for key in (
                               "rms_position_error", "max_position_error",
                               "voltage_violations", "current_violations", "slip_events",
                               "unplanned_slip_events", "failures")},
                           "planned_beyond_traction": int(np.sum(planned > 1.0)),
                           "unplanned_slip_steering": _unplanned_steering(events)}
                    rows.append(row)
                    log(f"{layout:8s} {size:3.1f} m x{ratio:.1f} {name:13s} "
                        f"{variant or '':22s} rms {row['rms_position_error'] * 1e3:6.1f} mm  "
                        f"V {row['voltage_violations']:3d}  I {row['current_violations']:3d}  "
                        f"slip {row['slip_events']:3d} (unplanned "
                        f"{row['unplanned_slip_events']:3d}, steering "
                        f"{row['unplanned_slip_steering']:3d})  failures {row['failures']:2d} "
                        f"({time.perf_counter() - started:.1f} s)")
    return rows


def _unplanned_steering(events: dict[str, FloatArray]) -> int:
    """Slip ticks within the plan's traction on which a module's steering was at its
    rate limit (the motor plant's events)."""
    if "steer_saturated" not in events:
        return 0
    return int(np.sum((events["slip"] > 0) & (events["planned_traction_ratio"] <= 1.0)
                      & (events["steer_saturated"] > 0)))


def traction_table(rows: list[dict[str, Any]], variants: list[str]) -> str:
    """Markdown: per scenario the kinematic MPC's RMS error [mm], and per planner variant
    the motor-aware MPC's RMS error [mm] with its ratio to the kinematic MPC's; slip
    ticks (in brackets: those where the command's own step stayed within ``mu N``, and of
    them those where a module's steering was at its rate limit) and voltage / current
    violation ticks after ``/``."""
    head = ("| layout | size [m] | x free speed | mpc-kinematic | "
            + " | ".join(f"mpc-motors {v}" for v in variants) + " |")
    lines = [head, "|" + "---|" * (len(variants) + 4)]
    scenarios = dict.fromkeys((r["layout"], r["size"], r["speed_ratio"]) for r in rows)

    def cell(r: dict[str, Any], base: float | None) -> str:
        ratio = "" if base is None else f" ({r['rms_position_error'] / base:.2f}x)"
        return (f"{r['rms_position_error'] * 1e3:.1f}{ratio}; slip {r['slip_events']} "
                f"({r['unplanned_slip_events']}, {r.get('unplanned_slip_steering', 0)}) / "
                f"{r['voltage_violations']} / {r['current_violations']}")

    for layout, size, ratio in scenarios:
        mine = [r for r in rows if (r["layout"], r["size"], r["speed_ratio"])
                == (layout, size, ratio)]
        kinematic = next(r for r in mine if r["variant"] is None)
        base = kinematic["rms_position_error"]
        cells = [cell(kinematic, None)]
        for v in variants:
            found = [r for r in mine if r["variant"] == v]
            cells.append(cell(found[0], base) if found else "-")
        lines.append(f"| {layout} | {size:g} | {ratio:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def controller(name: str, robot: Robot, trajectory: Trajectory, dt: float,
               horizon: int, command_ramp: bool = True) -> TrackingController:
    """A controller by name (:data:`CONTROLLERS`) for the motor robot ``robot``; the MPCs
    told that the wheel loops ramp each command over the tick (``command_ramp``), as the
    motor plant's do."""
    if name.startswith("mpc-motors"):
        solver = {"mpc-motors": "daqp", "mpc-motors-osqp": "osqp",
                  "mpc-motors-ipopt": "ipopt"}[name]
        return Controller(robot, trajectory, horizon, dt, solver=solver,
                          command_ramp=command_ramp)
    stand_in = kinematic_stand_in(robot)
    if name == "mpc-kinematic":
        return Controller(stand_in, trajectory, horizon, dt, command_ramp=command_ramp)
    if name == "ff-p-setpoint":
        return FeedforwardPSetpointController(stand_in, trajectory, dt)
    return FeedforwardPController(stand_in, trajectory, dt,
                                  saturation="clip" if name == "ff-p-clip" else "desaturate")


def run(layouts: list[str], trajectories: list[str], controllers: list[str], *,
        ratio: float = 1.0, size: float = 1.0, heading: str = "fixed", dt: float = 0.05,
        horizon: int = 20, laps: float = 2.0, skip: float = 2.0, seed: int = 0,
        command_ramp: bool = True, log: Any = print) -> list[dict[str, Any]]:
    """Every layout x trajectory x controller on the motor plant; one row per run."""
    rows = []
    for layout in layouts:
        robot = motor_preset(layout)
        for shape in trajectories:
            reference = motor_reference(shape, robot, ratio, size, heading)
            period = float(reference.period or 10.0)
            for name in controllers:
                if name == "ff-p-setpoint" and not robot.steered:
                    continue
                started = time.perf_counter()
                control = controller(name, robot, reference, dt, horizon, command_ramp)
                result = simulate(control, laps * period + skip, plant="motor", robot=robot,
                                  seed=seed)
                m = result.metrics(skip=skip)
                row = {"layout": layout, "trajectory": shape, "heading": heading,
                       "period": period, "controller": name,
                       **{key: m[key] for key in (
                           "rms_position_error", "max_position_error", "max_cross_track_error",
                           "voltage_violations", "current_violations", "slip_events",
                           "limit_violations", "accel_violations", "failures",
                           "peak_voltage_ratio", "peak_current_ratio", "min_bus_voltage",
                           "tick_time_p50", "tick_time_p99")}}
                rows.append(row)
                log(f"{layout:8s} {shape:8s} T {period:5.2f} s {name:16s} "
                    f"rms {row['rms_position_error'] * 1e3:7.1f} mm  "
                    f"V {row['voltage_violations']:3d}  I {row['current_violations']:3d}  "
                    f"slip {row['slip_events']:3d}  failures {row['failures']:3d}  "
                    f"tick p50 {row['tick_time_p50'] * 1e3:.3f} "
                    f"p99 {row['tick_time_p99'] * 1e3:.3f} ms "
                    f"({time.perf_counter() - started:.1f} s)")
    return rows


def table(rows: list[dict[str, Any]], controllers: list[str]) -> str:
    """Markdown: per scenario, each controller's RMS error [mm] / V / I / slip ticks."""
    head = "| scenario | period [s] | " + " | ".join(controllers) + " |"
    lines = [head, "|" + "---|" * (len(controllers) + 2)]
    scenarios = dict.fromkeys((r["layout"], r["trajectory"]) for r in rows)
    for layout, shape in scenarios:
        cells = []
        period = 0.0
        for name in controllers:
            found = [r for r in rows if (r["layout"], r["trajectory"], r["controller"])
                     == (layout, shape, name)]
            if not found:
                cells.append("-")
                continue
            r = found[0]
            period = r["period"]
            failed = f" ({r['failures']} failed)" if r.get("failures") else ""
            cells.append(f"{r['rms_position_error'] * 1e3:.1f} / {r['voltage_violations']} / "
                         f"{r['current_violations']} / {r['slip_events']}{failed}")
        lines.append(f"| {layout} {shape} | {period:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def perf(layouts: list[str], ticks: int, repeats: int, horizon: int = 20,
         log: Any = print) -> list[dict[str, Any]]:
    """Tick times of the daqp fast path with and without the motor rows, per layout, on
    ``mpc-bench perf``'s scenario (figure-eight at 0.8 x the wheel speed limit, fixed
    heading, dt 0.05 s, ideal plant), the two runs interleaved ``repeats`` times so that
    their ratio is measured under the same load."""
    rows = []
    for layout in layouts:
        robot = motor_preset(layout)
        kinematic = robot.with_dynamics(None)
        reference = scenario_reference("figure8", "fixed", kinematic, 0.8)
        samples: dict[str, list[FloatArray]] = {"kinematic": [], "motors": []}
        solved_rows = []
        for _ in range(repeats):
            for label, which in (("kinematic", kinematic), ("motors", robot)):
                control = Controller(which, reference, horizon, 0.05)
                result = simulate(control, ticks * 0.05)
                samples[label].append(result.tick_time[min(10, ticks // 5):])
            solved_rows.append(control.solver.stage_rows_solved)  # type: ignore[attr-defined]
        row: dict[str, Any] = {"layout": layout}
        for label, parts in samples.items():
            times = np.concatenate(parts)
            row[f"{label}_p50"] = float(np.median(times))
            row[f"{label}_p99"] = float(np.percentile(times, 99))
        row["rows"] = control.solver.limits.rows  # type: ignore[attr-defined]
        row["rows_solved_at_end"] = solved_rows  # in daqp's problem after each motors run
        rows.append(row)
        log(f"{layout:8s} kinematic p50 {row['kinematic_p50'] * 1e3:.3f} p99 "
            f"{row['kinematic_p99'] * 1e3:.3f} ms   motors p50 {row['motors_p50'] * 1e3:.3f} "
            f"p99 {row['motors_p99'] * 1e3:.3f} ms   p50 ratio "
            f"{row['motors_p50'] / row['kinematic_p50']:.2f}  rows/stage {row['rows']} "
            f"(in daqp's problem at the end: {max(solved_rows)})")
    return rows


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench motors", description=__doc__.split("\n")[0])
    add_list_option(parser, "--layouts",
                    help=f"comma list of {', '.join(MOTOR_ROBOT_PRESETS)} (default: all)")
    add_list_option(parser, "--trajectories", help="comma list of circle, figure8 (default: both)")
    add_list_option(parser, "--controllers",
                    help=f"comma list of {', '.join(CONTROLLERS)} "
                         f"(default: {', '.join(DEFAULT_CONTROLLERS)})")
    add_list_option(parser, "--headings", metavar="HEADING", default="fixed",
                    choices=("fixed", "tangent"),
                    help="the reference's heading, one of fixed, tangent (fixed)")
    parser.add_argument("--ratio", type=float, default=1.0,
                        help="the reference's peak need / the motor model (1.0)")
    parser.add_argument("--size", type=float, default=1.0, help="shape size [m] (1.0)")
    parser.add_argument("--laps", type=float, default=2.0, help="laps per run (2)")
    parser.add_argument("--skip", type=float, default=2.0,
                        help="seconds left out of the errors (2.0)")
    parser.add_argument("--seed", type=seed, default=0,
                        help="seed of the motor plant's randomness (0)")
    parser.add_argument("--command-ramp", action=argparse.BooleanOptionalAction, default=True,
                        help="tell the MPCs that the wheel loops ramp each command over the "
                             "tick, as the motor plant's do (Controller(command_ramp=True); "
                             "default on)")
    parser.add_argument("--perf", action="store_true",
                        help="instead: tick times with and without the motor rows per layout "
                             "(mpc-bench perf's scenario, runs interleaved)")
    parser.add_argument("--traction", action="store_true",
                        help="instead: the motor-aware MPC under planner variants against the "
                             "kinematic MPC on fixed-heading figure-eights timed to ratios of "
                             "the geared free speed (--sizes, --speed-ratios, --variants, "
                             "--duration; layouts default swerve, mecanum)")
    parser.add_argument("--sizes", default="1,2,3", help="--traction: sizes [m] (1,2,3)")
    parser.add_argument("--speed-ratios", default="1.0,1.2,1.3",
                        help="--traction: peak wheel speed / geared free speed (1.0,1.2,1.3)")
    parser.add_argument("--variants", default=",".join(TRACTION_VARIANTS),
                        help="--traction: planner variants, comma list of terms joined by + "
                             "(default, headroom=X, voltage_headroom=X, no-sag, sides=N); "
                             f"default {','.join(TRACTION_VARIANTS)}")
    parser.add_argument("--duration", type=float, default=12.0,
                        help="--traction: seconds a run (12)")
    parser.add_argument("--ticks", type=int, default=400, help="--perf: ticks per run (400)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="--perf: interleaved runs of each (3)")
    parser.add_argument("--out", default="bench-out", metavar="DIR",
                        help="writes motors.json (--perf: motors-perf.json) here (bench-out)")
    add_force_argument(parser)
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if not (args.ratio > 0 and args.size > 0 and args.laps > 0 and args.skip >= 0):
        raise ScenarioError("--ratio, --size and --laps must be > 0, --skip >= 0")
    for flag, value, high in (("--ratio", args.ratio, 100.0), ("--size", args.size, 1e3),
                              ("--laps", args.laps, 1e3), ("--skip", args.skip, 1e4)):
        if not value <= high:
            raise ScenarioError(f"{flag} must be at most {high:g} (a bound of this command), "
                                f"got {value:g}")
    if args.traction:
        return _traction_main(args, argv)
    layouts = choose("--layouts", "layout", args.layouts, MOTOR_ROBOT_PRESETS)
    if not args.perf and (args.ticks != 400 or args.repeats != 3):
        raise ScenarioError("--ticks and --repeats apply to --perf only")
    if args.perf and not args.command_ramp:
        raise ScenarioError("--no-command-ramp applies to runs on the motor plant, not --perf")
    out = claim(args.out, ("motors-perf.json" if args.perf else "motors.json",), args.force)
    if args.perf:
        if args.ticks < 20 or args.repeats < 1:
            raise ScenarioError("--ticks must be >= 20 and --repeats >= 1")
        measured = perf(layouts, args.ticks, args.repeats,
                        log=lambda line: print(line, flush=True))
        (out / "motors-perf.json").write_text(json.dumps(
            {"command": " ".join(["mpc-bench", "motors", *argv]), "machine": machine(),
             "rows": measured}, indent=1))
        print(f"wrote {out / 'motors-perf.json'}")
        return 0
    trajectories = choose("--trajectories", "trajectory", args.trajectories, TRAJECTORIES)
    controllers = choose("--controllers", "controller", args.controllers, CONTROLLERS,
                         DEFAULT_CONTROLLERS)
    started = time.perf_counter()
    try:
        rows = run(layouts, trajectories, controllers, ratio=args.ratio, size=args.size,
                   heading=args.headings, laps=args.laps, skip=args.skip, seed=args.seed,
                   command_ramp=args.command_ramp, log=lambda line: print(line, flush=True))
    except MpcError as error:  # e.g. a run too long: name the flags that set it
        raise ScenarioError(f"--size {args.size:g} m, --laps {args.laps:g}, --ratio "
                            f"{args.ratio:g}: {error}") from None
    print()
    print("RMS position error [mm] / voltage-violation ticks / current-violation ticks / "
          "slip ticks (failed ticks, where any, in brackets)")
    print(table(rows, controllers))
    (out / "motors.json").write_text(json.dumps(
        {"command": " ".join(["mpc-bench", "motors", *argv]), "machine": machine(),
         "settings": {"ratio": args.ratio, "size": args.size, "laps": args.laps,
                      "skip": args.skip, "seed": args.seed, "heading": args.headings,
                      "command_ramp": args.command_ramp},
         "rows": rows}, indent=1))
    print(f"\nwrote {out / 'motors.json'} ({time.perf_counter() - started:.0f} s)")
    return 0


def _numbers(flag: str, text: str, high: float) -> list[float]:
    try:
        values = [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise ScenarioError(f"{flag}: expected a comma list of numbers, got {text!r}") from None
    if not values or not all(0.0 < v <= high for v in values):
        raise ScenarioError(f"{flag}: expected numbers in (0, {high:g}], got {text!r}")
    return values


def _traction_main(args: argparse.Namespace, argv: list[str]) -> int:
    """``mpc-bench motors --traction``: :func:`traction`, its table and motors-traction.json."""
    layouts = choose("--layouts", "layout", args.layouts, MOTOR_ROBOT_PRESETS,
                     ("swerve", "mecanum"))
    sizes = _numbers("--sizes", args.sizes, 1e3)
    ratios = _numbers("--speed-ratios", args.speed_ratios, 10.0)
    variants = list(dict.fromkeys(v.strip() for v in args.variants.split(",") if v.strip()))
    if not variants:
        raise ScenarioError("--variants: expected at least one planner variant")
    robot = motor_preset(layouts[0])
    for variant in variants:
        variant_robot(robot, variant)  # a bad variant fails before any run
    if not 0.0 < args.duration <= 600.0 or args.skip >= args.duration:
        raise ScenarioError("--duration must be in (0, 600] s and longer than --skip")
    out = claim(args.out, ("motors-traction.json",), args.force)
    started = time.perf_counter()
    rows = traction(layouts, sizes, ratios, variants, duration=args.duration,
                    skip=args.skip, seed=args.seed, log=lambda line: print(line, flush=True))
    print()
    print("RMS position error [mm] (ratio to the kinematic MPC's); slip ticks (in brackets: "
          "those whose command needed at most mu N, and of them those with a module's "
          "steering at its rate limit) / voltage / current violation ticks")
    print(traction_table(rows, variants))
    (out / "motors-traction.json").write_text(json.dumps(
        {"command": " ".join(["mpc-bench", "motors", *argv]), "machine": machine(),
         "settings": {"sizes": sizes, "speed_ratios": ratios, "variants": variants,
                      "duration": args.duration, "skip": args.skip, "seed": args.seed},
         "rows": rows}, indent=1))
    print(f"\nwrote {out / 'motors-traction.json'} ({time.perf_counter() - started:.0f} s)")
    return 0
