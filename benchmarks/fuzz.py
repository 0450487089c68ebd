"""``mpc-bench fuzz``: seeded abuse of the controller, counting unsafe commands (must be 0).

Every preset robot, every solver path and the options that change the control path
(time and path mode, stage lengths, command delay, fewer polygon sides, a derated or dead
wheel, a tight iteration budget, the motor presets' motor rows) run in turn, tick after
tick, on a plant that is disturbed at random: pose jumps of up to 2 m and a full turn,
measurement noise, time that jumps forwards and backwards, references swapped mid-run,
resets. Every command is checked against what a robot may be told:

- finite wheel speeds, twist and steer angles;
- every wheel within its speed limit;
- every wheel's change since the last command within its acceleration limit over one tick
  (speed and acceleration as the robot measures them: the velocity vector for swerve);
- every swerve module turning at most ``max_steer_rate dt`` from its last commanded angle;
- casters: drive rates and steer rates within their limits (their steer angles, states,
  are fed back as measured: the angles the last command ends the tick at).

IPOPT gets a small share of the ticks (it is much slower: docs/design/fuzz-ipopt-share.md).
The summary counts ticks, fallbacks and violations per configuration; the exit code is 1 if
any command was unsafe.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from benchmarks.outdir import add_force_argument, claim
from benchmarks.runner import machine
from benchmarks.scenarios import Parser, ScenarioError, seed
from mpc import Command, Controller, Status
from mpc.model import integrate
from mpc.robots import MOTOR_ROBOT_PRESETS, PRESETS, Robot, motor_preset, preset
from mpc.validation import MAX_SIMULATION_TICKS
from trajectories import Circle, FigureEight, SpinHeading, Trajectory

DT = 0.05

#: (name, robot transform, controller options, share of the tick budget)
CONFIGURATIONS: tuple[tuple[str, str, dict[str, Any], float], ...] = (
    ("daqp", "", {}, 1.0),
    ("daqp path", "", {"mode": "path"}, 1.0),
    ("daqp stage=dt delay=2", "", {"stage_dt": DT, "delay_ticks": 2}, 0.5),
    ("daqp 3-iteration budget", "", {"max_iter": 3}, 0.5),
    ("daqp dead wheel 0", "dead", {"weights": {"pose": [200.0, 200.0, 0.0],
                                                "terminal": [400.0, 400.0, 0.0]}}, 0.5),
    ("daqp wheel 1 at half", "half", {}, 0.5),
    ("osqp", "", {"solver": "osqp"}, 0.5),
    ("osqp path 8 sides", "", {"solver": "osqp", "mode": "path", "polygon_sides": 8}, 0.3),
    ("ipopt", "", {"solver": "ipopt", "max_iter": 30}, 0.04),
    ("ipopt path", "", {"solver": "ipopt", "mode": "path", "max_iter": 30}, 0.03),
    ("daqp motors", "motors", {}, 0.3),
    ("daqp motors path", "motors", {"mode": "path"}, 0.2),
)


@dataclass
class Tally:
    """What one configuration on one robot did."""

    robot: str
    configuration: str
    ticks: int = 0
    non_finite: int = 0
    speed: int = 0
    acceleration: int = 0
    steering: int = 0
    statuses: dict[str, int] = field(default_factory=dict)
    worst: str = ""

    @property
    def unsafe(self) -> int:
        return self.non_finite + self.speed + self.acceleration + self.steering


def references(rng: np.random.Generator) -> list[Trajectory]:
    """References from slow to 3x too fast, with every kind of heading."""
    return [
        Circle(float(rng.uniform(0.3, 2.0)), float(rng.uniform(2.0, 20.0)),
               heading=str(rng.choice(["tangent", "fixed"])) if rng.random() < 0.5 else 0.0),
        FigureEight(float(rng.uniform(0.3, 2.0)), float(rng.uniform(2.0, 20.0)),
                    heading="tangent"),
        Circle(1.0, 8.0, heading=SpinHeading(float(rng.uniform(-6.0, 6.0)))),
    ]


def transformed(robot: Robot, how: str) -> Robot:
    if how == "motors":  # the layout's motor preset (motor rows, no acceleration limit)
        return motor_preset(robot.name)
    if how == "dead":
        return robot.derated({0: 0.0})
    if how == "half":
        return robot.derated({1: 0.5})
    return robot


def check(robot: Robot, command: Command, last: np.ndarray, last_steer: np.ndarray | None,
          tally: Tally) -> None:
    """Count what is wrong with ``command`` (see the module docstring)."""
    arrays = [command.wheel_speeds, command.twist]
    if command.steer_angles is not None:
        arrays.append(command.steer_angles)
    if not all(np.all(np.isfinite(a)) for a in arrays):
        tally.non_finite += 1
        tally.worst = f"non-finite command {command}"
        return
    speeds = np.abs(command.wheel_speeds)
    if np.any(speeds > robot.max_wheel_speed * (1 + 1e-6) + 1e-9):
        tally.speed += 1
        tally.worst = f"speed {speeds.tolist()} over {robot.max_wheel_speed.tolist()}"
    if robot.steer_states:  # casters: drive and steer rates held over the tick
        rates, limit = command.steer_rates, robot.max_steer_rates
        if rates is None or limit is None or not np.all(np.isfinite(rates)):
            tally.non_finite += 1
            tally.worst = f"caster command without finite steer rates {command}"
        elif np.any(np.abs(rates) > limit * (1 + 1e-6) + 1e-9):
            tally.steering += 1
            tally.worst = f"steer rates {rates.tolist()} over {limit.tolist()}"
        return
    accel = robot.max_wheel_accel
    if accel is not None:
        change = robot.wheel_magnitudes(command.twist - last)
        if np.any(change > accel * DT * (1 + 1e-6) + 1e-9):
            tally.acceleration += 1
            tally.worst = f"acceleration {(change / DT).tolist()} over {accel.tolist()}"
    rates = robot.max_steer_rates
    if command.steer_angles is not None and last_steer is not None and rates is not None:
        turn = np.abs(np.mod(command.steer_angles - last_steer + math.pi / 2, math.pi)
                      - math.pi / 2)
        if np.any(turn > rates * DT * (1 + 1e-6) + 1e-9):
            tally.steering += 1
            tally.worst = f"steering {turn.tolist()} in one tick"


def run(robot_name: str, configuration: tuple[str, str, dict[str, Any], float], ticks: int,
        seed: int) -> Tally:
    """``ticks`` disturbed ticks of one configuration on one robot."""
    name, how, options, _ = configuration
    rng = np.random.default_rng(seed)
    robot = transformed(preset(robot_name), how)
    pool = references(rng)
    # kidnaps, clock jumps and resets at rest put headings whole turns from the reference
    controller = Controller(robot, pool[0], dt=DT, allow_unusual=True, **options)
    tally = Tally(robot_name, name)
    pose = pool[0].sample(0.0).pose.copy()
    t = 0.0
    last = np.zeros(3)
    last_steer = robot.initial_steer_angles()
    angles = last_steer if robot.steer_states else None  # measured caster angles
    for _ in range(ticks):
        event = rng.random()
        if event < 0.01:
            pose = pose + rng.uniform([-2, -2, -math.pi], [2, 2, math.pi])  # kidnapped
        elif event < 0.02:
            t += float(rng.uniform(-5.0, 5.0))  # the clock jumps
        elif event < 0.025:
            controller.trajectory = pool[int(rng.integers(len(pool)))]
        elif event < 0.03:  # as a user would: the motion and the modules' angles
            steered = last_steer if robot.steered and not robot.steer_states else None
            controller.reset(last, steer_angles=steered)
        measured = pose + rng.normal(0.0, [0.002, 0.002, 0.002])
        command = controller.step(measured, t, steer_angles=angles)
        check(robot, command, last, last_steer, tally)
        tally.ticks += 1
        tally.statuses[command.status.value] = tally.statuses.get(command.status.value, 0) + 1
        if command.status is not Status.SOLVED and not tally.worst:
            tally.worst = f"{command.status.value}: {command.solver_status}"
        last, last_steer = command.twist, command.steer_angles
        if angles is not None and command.steer_angles is not None:
            angles = command.steer_angles
        if np.all(np.isfinite(command.twist)):
            pose = integrate(pose, command.twist, DT)
        t += DT
    return tally


def _parser() -> Parser:
    parser = Parser(prog="mpc-bench fuzz", description=__doc__.split("\n")[0])
    parser.add_argument("--ticks", type=int, default=100_000,
                        help="ticks in all, shared out over robots and configurations (100000)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of every disturbance (0)")
    parser.add_argument("--out", default=None, metavar="DIR", help="also write fuzz.json here")
    add_force_argument(parser)
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    if not 100 <= args.ticks <= MAX_SIMULATION_TICKS:
        raise ScenarioError(f"--ticks must be 100 to {MAX_SIMULATION_TICKS} (a bound of this "
                            f"library), got {args.ticks}")
    if not 0 <= args.seed <= 2**31:
        raise ScenarioError(f"--seed must be an integer 0 to {2**31}, got {args.seed}")
    out = None if args.out is None else claim(args.out, ("fuzz.json",), args.force)
    pairs = [(robot, config) for robot in PRESETS for config in CONFIGURATIONS
             if config[1] != "motors" or robot in MOTOR_ROBOT_PRESETS]
    shares = sum(config[3] for _, config in pairs)
    plan = [(robot, config, max(10, round(args.ticks * config[3] / shares)))
            for robot, config in pairs]
    total = sum(n for *_, n in plan)
    print(f"fuzz: {total} ticks over {len(plan)} runs ({len(PRESETS)} robots x "
          f"{len(CONFIGURATIONS)} configurations, the motor ones on the "
          f"{len(MOTOR_ROBOT_PRESETS)} motor presets), seed {args.seed}", flush=True)
    print(f"{'robot':8s} {'configuration':26s} {'ticks':>6s} {'unsafe':>6s} "
          f"{'fallbacks':>9s} {'wall [s]':>8s}")
    tallies = []
    started = time.perf_counter()
    for index, (robot, config, ticks) in enumerate(plan):
        began = time.perf_counter()
        tally = run(robot, config, ticks, seed=args.seed * 1000 + index)
        tallies.append(tally)
        fallbacks = tally.ticks - tally.statuses.get("solved", 0)
        print(f"{robot:8s} {config[0]:26s} {tally.ticks:6d} {tally.unsafe:6d} {fallbacks:9d} "
              f"{time.perf_counter() - began:8.1f}", flush=True)
        if tally.unsafe:
            print(f"         unsafe: {tally.worst}", flush=True)
    unsafe = sum(t.unsafe for t in tallies)
    ticks_run = sum(t.ticks for t in tallies)
    print(f"\n{ticks_run} ticks, {unsafe} unsafe commands "
          f"({sum(t.non_finite for t in tallies)} non-finite, "
          f"{sum(t.speed for t in tallies)} speed, {sum(t.acceleration for t in tallies)} "
          f"acceleration, {sum(t.steering for t in tallies)} steering) in "
          f"{time.perf_counter() - started:.0f} s")
    if out is not None:
        document = {"ticks": ticks_run, "unsafe": unsafe, "seed": args.seed,
                    "machine": machine(), "runs": [vars(t) for t in tallies]}
        (out / "fuzz.json").write_text(json.dumps(document, indent=1))
    return 1 if unsafe else 0
