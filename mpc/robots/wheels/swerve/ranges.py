"""Steering ranges: modules whose absolute steer angle must stay in ``[lo, hi]`` [rad].

A cable-wrapped module (or one with hard stops) cannot turn round and round: its steer
angle is an *absolute* angle, not one modulo a turn, and must stay within its range
(``(-pi, pi)`` for a module that may wrap half a turn either way). A module driving along
direction ``d`` may point at any ``b = d + m pi`` (``m`` even: driving forwards, odd:
backwards); with a range only the ``b`` inside it are allowed. Switching between them (a
*flip*: the drive reverses and the module turns by about ``pi`` instead of going on) is
free only when the module's ground speed passes near zero; otherwise the module drives
out of line while it turns.

Two rules choose each module's branch ``b``:

- ``"tick"`` (today's per-tick rule kept inside the range): the allowed ``b`` nearest the
  present angle, tick by tick, module by module; a module at a stop flips there.
- ``"horizon"`` (the default): a small dynamic programme per module over the plan's
  stages ``k = 0..N-1`` (the command sent, then the planned twists), candidates the
  allowed ``b`` of each stage's module direction, cost (see :class:`BranchWeights`) the
  turn, the turn beyond what the module can turn in the stage weighted by its speed
  around it (driving out of line; with an axle offset the turn takes drive rate, so a
  fast module turns slower: :func:`steer_reaches`), a flip (an offset module's by its
  speed too), and, for a module already wound towards a stop or winding fast towards
  it, too little room towards it at the plan's end (so it unwinds while it is slow,
  before it must). The module turns towards the first stage's choice, at most its
  steering rate; a turn under way is finished (no turning back half way).

The command: the module's angle steps from the present one towards the chosen ``b`` by at
most ``max_steer_rate dt`` (so it never leaves the range, an interval), and its signed
speed is its velocity projected on where it points (a module still turning drives the
part of its velocity it can).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from mpc.arrays import FloatArray
from mpc.errors import RobotError
from mpc.robots.wheels.swerve.limits import MOVING_MODULE_SPEED, STOPPED_MODULE_SPEED, flip_turn
from mpc.robots.wheels.swerve.modules import SwerveModules
from mpc.validation import shown

#: The rules :func:`check_steer_plan` accepts (see the module docstring).
STEER_PLANS = ("horizon", "tick")


def check_steer_range(value: object) -> tuple[float, float] | None:
    """``steer_range`` as ``(lo, hi)`` [rad] floats, or None: two finite numbers with
    ``hi - lo >= pi`` (every direction then has an allowed branch); else RobotError."""
    if value is None:
        return None
    expected = ("steer_range must be None or (lo, hi): two finite absolute steer angles "
                "[rad] with hi - lo >= pi")
    try:
        pair = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise RobotError(f"{expected}, got {shown(value)}") from None
    if isinstance(value, (str, bytes)) or pair.shape != (2,):
        raise RobotError(f"{expected}, got {shown(value)}")
    lo, hi = float(pair[0]), float(pair[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise RobotError(f"{expected}, got non-finite {shown(value)}")
    if not lo < hi:
        raise RobotError(f"{expected}, got lo {lo!r} >= hi {hi!r}")
    if hi - lo < math.pi * (1.0 - 1e-12):
        raise RobotError(f"{expected}, got a range of {hi - lo:.6g} rad < pi: some "
                         "directions could not be driven at all")
    return lo, hi


def check_steer_plan(value: object) -> str:
    """``steer_plan`` checked: one of :data:`STEER_PLANS`; else RobotError."""
    if not isinstance(value, str) or value not in STEER_PLANS:
        raise RobotError(f"steer_plan must be one of {list(STEER_PLANS)}, got {shown(value)}")
    return value


@dataclass(frozen=True)
class BranchWeights:
    """The horizon rule's costs (dimensionless, per module).

    Attributes:
        turn: per radian turned (prefers small turns) [1/rad].
        out_of_line: per radian turned beyond the stage's steering reach, times the
            module's speed over its limit (driving out of line while turning) [1/rad].
        flip: per flip (drive reversal) [1].
        flip_speed: per flip, times the module's speed over its limit around it and its
            steer-drive coupling (:func:`steer_coupling`: 0 without an axle offset): an
            offset module's turn takes drive rate, so its flips belong where it is slow [1].
        room: at the plan's end, per ``margin`` of room short of ``margin`` towards the
            stop the module is turning to over the plan (its direction's net turn along
            the plan), for a module already closer than ``margin``, or than ``spread``
            times that net turn, to that stop: unwinds a module before it reaches a stop,
            when it is slow [1].
        margin: the room asked for at the plan's end [rad].
        spread: a module whose direction turns fast over the plan (more than ``margin /
            spread`` in it) is asked for room while it is this many plans' turning away
            from its stop, not only ``margin`` (it would get there before it is slow
            again) [1].

    The defaults were chosen on the closed-loop runs of ``python -m
    benchmarks.steer_ranges`` (see ``docs/guide/steering-ranges.md``).
    """

    turn: float = 0.05
    out_of_line: float = 2.0
    flip: float = 0.3
    flip_speed: float = 2.0
    room: float = 2.0
    margin: float = math.pi
    spread: float = 2.0


DEFAULT_WEIGHTS = BranchWeights()


def candidates(direction: float, lo: float, hi: float) -> list[tuple[float, int]]:
    """The allowed branches of a module direction [rad]: ``(b, sign)`` with
    ``b = direction + m pi`` in ``[lo, hi]`` and ``sign`` +1 (m even) or -1 (m odd)."""
    first, last = math.ceil((lo - direction) / math.pi), math.floor((hi - direction) / math.pi)
    out = [(direction + m * math.pi, 1 if m % 2 == 0 else -1) for m in range(first, last + 1)]
    if not out:  # a range of exactly pi, rounding: the nearer end's branch
        m = round((0.5 * (lo + hi) - direction) / math.pi)
        out = [(min(max(direction + m * math.pi, lo), hi), 1 if m % 2 == 0 else -1)]
    return out


def nearest_branch(present: float, direction: float, lo: float, hi: float) -> float:
    """The ``"tick"`` rule: the allowed branch of ``direction`` nearest ``present`` [rad]."""
    return min(candidates(direction, lo, hi), key=lambda c: abs(c[0] - present))[0]


def plan_branch(present: float, directions: list[float | None], speeds: list[float],
                reaches: list[float], lo: float, hi: float,
                weights: BranchWeights = DEFAULT_WEIGHTS, coupling: float = 0.0) -> float:
    """The horizon rule for one module: the branch [rad] to turn towards now (the first
    of :func:`plan_path`'s; the arguments are its)."""
    return plan_path(present, directions, speeds, reaches, lo, hi, weights, coupling)[0]


def plan_path(present: float, directions: list[float | None], speeds: list[float],
              reaches: list[float], lo: float, hi: float,
              weights: BranchWeights = DEFAULT_WEIGHTS, coupling: float = 0.0
              ) -> list[float]:
    """The horizon rule for one module: its branch [rad] at every stage.

    Args:
        present: the module's absolute steer angle [rad].
        directions: its direction of travel at each stage [rad], None where at rest.
        speeds: its speed at each stage over its limit (0..1).
        reaches: how far it may turn in each stage [rad].
        lo, hi: its range [rad].
        weights: the costs.
        coupling: its steer-drive coupling (0..1, :func:`steer_coupling`).
    """
    filled = _filled(directions)
    if filled is None:  # at rest over the whole plan: stay (inside the range)
        return [min(max(present, lo), hi)] * len(directions)
    # The present angle has no sense: a turn to the other branch now costs its turning
    # only, not a flip (which the stages after it pay: no flipping back and forth along
    # the plan). So a module flips now when that is cheap now (slow) rather than later
    # at speed; charged here too, it waited for its stop as the per-tick rule does (see
    # docs/guide/steering-ranges.md).
    previous: list[tuple[float, int]] = [(present, 0)]
    costs = [0.0]
    choices: list[list[int]] = []
    stages: list[list[float]] = []
    for k, (direction, reach) in enumerate(zip(filled, reaches, strict=True)):
        here = candidates(direction, lo, hi)
        # out of line before, during or a little after the turn (a module at rest now but
        # soon fast costs its turning time too)
        moving = max(speeds[max(k - 1, 0):k + 4])
        new_costs, picks = [], []
        for b, sign in here:
            best, pick = math.inf, 0
            for j, ((a, before), cost) in enumerate(zip(previous, costs, strict=True)):
                turn = abs(b - a)
                total = (cost + weights.turn * turn
                         + weights.out_of_line * moving * max(0.0, turn - reach))
                if before and sign != before:
                    total += weights.flip + weights.flip_speed * coupling * moving
                if total < best:
                    best, pick = total, j
            new_costs.append(best)
            picks.append(pick)
        choices.append(picks)
        stages.append([b for b, _ in here])
        previous, costs = here, new_costs
    winding = _net_turn(filled)
    now = (hi - present) if winding > 0.0 else (present - lo)
    if winding != 0.0 and now < max(weights.margin, weights.spread * abs(winding)):
        # wound towards a stop already, or turning fast towards it
        for j, (b, _) in enumerate(previous):
            ahead = (hi - b) if winding > 0.0 else (b - lo)
            costs[j] += weights.room * max(0.0, weights.margin - ahead) / weights.margin
    index = min(range(len(costs)), key=costs.__getitem__)
    path = []
    for k in range(len(stages) - 1, -1, -1):
        path.append(stages[k][index])
        index = choices[k][index]
    return path[::-1]


def steer_coupling(robot: SwerveModules) -> FloatArray:
    """Per module (n,), how much of its drive a turn at its full steering rate takes
    (0..1): ``L max_steer_rate / max_wheel_speed`` with the axle offset's ``L / r``
    [1/m * m]; 0 without an offset."""
    lever = robot.axle_offset / robot.wheel_radius
    drive = np.maximum(np.asarray(robot.max_wheel_speed, dtype=float), 1e-12)
    return np.minimum(1.0, lever * robot.max_steer_rate / drive) * np.ones(robot.n_wheels)


def steer_reaches(robot: SwerveModules, magnitude: FloatArray, spins: FloatArray,
                  times: FloatArray) -> FloatArray:
    """How far [rad] each module may turn in each stage (K, n): its steering rate times
    the stage lengths ``times`` (K,) [s]; with an axle offset at most the rate its drive
    has left over its speed ``magnitude`` (K, n) [rad/s] and the body's rotation
    ``spins`` (K,) [rad/s] (its drive rate is ``speed + L (omega + turn rate) / r``)."""
    rate = np.full(magnitude.shape, float(robot.max_steer_rate))
    lever = robot.axle_offset / robot.wheel_radius
    if lever:
        spare = robot.max_wheel_speed - magnitude - lever * np.abs(spins)[:, None]
        rate = np.clip(spare / lever, 0.0, rate)
    return rate * np.asarray(times, dtype=float)[:, None]


def _net_turn(directions: list[float]) -> float:
    """The net turn [rad] of a direction along the stages (each step the short way)."""
    total = 0.0
    for before, after in itertools.pairwise(directions):
        total += math.remainder(after - before, 2.0 * math.pi)
    return total


def _filled(directions: list[float | None]) -> list[float] | None:
    """Directions with each stage at rest given the next moving stage's (the last moving
    one's after the last); None if the module never moves."""
    known = [d for d in directions if d is not None]
    if not known:
        return None
    out: list[float] = []
    following = known[-1]
    for direction in reversed(directions):
        if direction is not None:
            following = direction
        out.append(following)
    return out[::-1]


def ranged_commands(robot: SwerveModules, twist: FloatArray, steer_angles: FloatArray | None,
                    steer_range: tuple[float, float], rule: str, aim: FloatArray | None,
                    dt: float | None, plan: FloatArray | None, durations: FloatArray | None,
                    memory: dict[str, FloatArray] | None = None
                    ) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """Signed speeds [rad/s], absolute steer angles [rad] and the turn rates [rad/s] (None
    without ``dt``) for ``twist`` from the present absolute ``steer_angles`` (None: 0).

    ``plan`` (N, 3) and ``durations`` (N,) [s]: the plan's twists and stage lengths (the
    first stage is replaced by ``twist``, the command sent); the horizon rule looks along
    them, the tick rule (or no plan) at ``twist`` alone. A module ``twist`` leaves at rest
    turns towards its direction in the twist ``aim`` (if given; as without a range).
    Without ``dt`` a module points at its chosen branch at once (a reset).

    ``memory``: a dict the caller keeps from tick to tick (empty after a reset), holding
    ``"speeds"``, the signed speeds last sent at the present angles (with an acceleration
    limit each module's commanded velocity vector changes by at most ``max_wheel_accel
    dt`` from that), and ``"goals"``, the branch each module is turning to (NaN: none): a
    turn under way goes on to it (the branch of the direction nearest it) rather than
    back, whichever rule chose it (:func:`_module_step`: a module turning to another
    branch brakes along its heading before it turns).
    """
    lo, hi = steer_range
    n = robot.n_wheels
    memory = {} if memory is None else memory
    last_speeds = memory.get("speeds")
    goals = memory.get("goals", np.full(n, np.nan))
    present = np.zeros(n) if steer_angles is None else np.asarray(steer_angles, dtype=float)
    stages = twist[None, :] if plan is None or rule == "tick" else np.vstack([twist, plan[1:]])
    times = (np.full(len(stages), 0.0 if dt is None else dt) if durations is None
             or len(stages) == 1 else np.asarray(durations, dtype=float)[:len(stages)])
    velocities = np.einsum("ndj,kj->knd", robot.wheel_blocks, stages)  # (K, n, 2) [rad/s]
    magnitude = np.hypot(velocities[..., 0], velocities[..., 1])
    moving = magnitude * robot.wheel_radius >= STOPPED_MODULE_SPEED
    heading = np.arctan2(velocities[..., 1], velocities[..., 0])
    aimed = None if aim is None else robot.wheel_blocks @ aim  # (n, 2)
    limit = np.maximum(robot.nominal_max_wheel_speed, 1e-12)
    reaches = steer_reaches(robot, magnitude, stages[:, 2], times)  # (K, n) [rad]
    coupling = steer_coupling(robot)
    speeds, angles = np.zeros(n), np.empty(n)
    step = math.inf if dt is None else robot.max_steer_rate * dt * (1.0 - 1e-9)
    limit_accel = robot.max_wheel_accel
    drive_limit = robot.max_wheel_speed
    lever = robot.axle_offset / robot.wheel_radius
    spin = (float(twist[2]), 0.0 if dt is None else 1.0 / dt)  # (omega, 1 / dt)
    accel = ([math.inf] * n if limit_accel is None or dt is None
             else (limit_accel * dt * (1.0 - 1e-9)).tolist())
    for i in range(n):
        here = float(present[i])
        directions = [float(h) if m else None
                      for h, m in zip(heading[:, i].tolist(), moving[:, i].tolist(), strict=True)]
        driving = directions[0] is not None
        if not driving and aimed is not None and (
                math.hypot(*aimed[i].tolist()) * robot.wheel_radius >= STOPPED_MODULE_SPEED):
            directions[0] = math.atan2(aimed[i, 1], aimed[i, 0])
        if rule == "tick" or len(stages) == 1:
            goal = (min(max(here, lo), hi) if directions[0] is None
                    else nearest_branch(here, directions[0], lo, hi))
        else:
            goal = plan_branch(here, directions, (magnitude[:, i] / limit[i]).tolist(),
                               reaches[:, i].tolist(), lo, hi, coupling=float(coupling[i]))
        wanted = velocities[0, i].tolist() if driving else [0.0, 0.0]
        if directions[0] is not None and driving and not math.isnan(goals[i]):
            # a turn under way: on to the branch of the direction nearest its goal
            goal = nearest_branch(float(goals[i]), directions[0], lo, hi)
        turn = min(max(goal - here, -step), step)
        previous = None if last_speeds is None else float(last_speeds[i])
        angle, speed = _module_step(here, turn, wanted, previous, accel[i],
                                    (float(drive_limit[i]), lever, spin))
        speeds[i], angles[i] = speed, angle
        goals[i] = goal if abs(goal - angle) > 1e-9 and dt is not None else math.nan
    memory["speeds"], memory["goals"] = speeds.copy(), goals
    rates = None if dt is None else (angles - present) / dt
    return speeds, angles, rates


def _module_step(here: float, turn: float, wanted: list[float], previous: float | None,
                 accel: float, drive: tuple[float, float, tuple[float, float]]
                 ) -> tuple[float, float]:
    """One module's (angle [rad], signed speed [rad/s]): the angle ``here + f turn`` with
    the largest ``f`` of 1, 1/2, 1/4, ..., 0 at which some speed keeps the velocity vector
    within ``accel`` [rad/s] of the last one (``previous`` along ``here``; None: no bound)
    and the drive rate within its limit, the speed the projection of ``wanted`` (x, y)
    on the new heading clipped to those that do. ``drive``: (the drive limit [rad/s],
    the axle offset's ``L / r`` [1/m * m], ``(omega [rad/s], 1 / dt [1/s])``): with an
    offset the drive rate is ``speed + L (omega + turn / dt) / r``."""
    x, y = wanted
    limit, lever, spin = drive
    fraction = 1.0
    while True:
        delta = fraction * turn
        angle = here + delta
        speed = x * math.cos(angle) + y * math.sin(angle)
        low, high = -math.inf, math.inf
        if previous is not None and accel != math.inf:
            # |speed e - previous e0| <= accel: speed within along +- sqrt(accel^2 - across^2)
            along, across = previous * math.cos(delta), previous * math.sin(delta)
            half = math.sqrt(max(accel * accel - across * across, 0.0))
            low, high = (along - half, along + half) if abs(across) <= accel else (1.0, -1.0)
        if lever:  # the axle offset's drive rate: speed + L (omega + turn rate) / r
            correction = lever * (spin[0] + delta * spin[1])
            low, high = max(low, -limit - correction), min(high, limit - correction)
        if low <= high:
            return angle, min(max(speed, low), high)
        if fraction < 1e-3:  # rounding at f ~ 0: keep the heading, the speed clipped
            speed = x * math.cos(here) + y * math.sin(here)
            bound = limit - (lever * spin[0] if lever else 0.0)
            return here, min(max(speed, -abs(bound)), abs(bound))
        fraction *= 0.5


def settled_angles(robot: SwerveModules, last: FloatArray, steer_angles: FloatArray,
                   dt: float) -> FloatArray:
    """The steer angles the clamp checks turns from: a module still turning to another
    branch (its last command's direction beyond one tick's turn from it, modulo a half
    turn) counts as pointing along that direction; the wheel commands finish its turn."""
    velocities = robot.wheel_blocks @ last
    reach = robot.max_steer_rate * dt
    settled = np.array(steer_angles, dtype=float)
    for i, ((x, y), angle) in enumerate(zip(velocities.tolist(), settled.tolist(),
                                            strict=True)):
        if (math.hypot(x, y) * robot.wheel_radius > MOVING_MODULE_SPEED
                and abs(flip_turn(x, y, angle)) > reach):
            settled[i] = math.atan2(y, x)
    return settled


