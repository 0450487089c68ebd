"""A motor swerve's steering rate along each command's ramp: the plant slides where a
module must turn faster than its rate inside a tick (though its whole turn fits), the
clamp's fraction by hand, and the QP's steering rows against finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from mpc import Command, Status
from mpc.control.clamp import clamp_command
from mpc.robots import Robot, motor_preset
from mpc.robots.wheels.swerve.steer_rows import ROWS_PER_MODULE
from mpc.sim import MotorPlant, MotorPlantConfig

DT = 0.05
RATE = 12.0  # [rad/s] the swerve preset's steering rate


def command(robot: Robot, twist: np.ndarray, angles: np.ndarray | None) -> Command:
    speeds, steer = robot.wheel_commands(twist, angles)
    return Command(wheel_speeds=speeds, twist=twist, steer_angles=steer,
                   predicted_poses=np.zeros((1, 3)), status=Status.SOLVED, solver_status="",
                   solve_time=0.0, tick_time=0.0, iterations=0, consecutive_failures=0,
                   clamped=False, reference_time=0.0)


def peak_rate(b: np.ndarray, e: np.ndarray, dt: float) -> float:
    """The fastest turn [rad/s] of the direction of ``b + s (e - b)``, ``s`` in [0, 1], over
    ``dt``, by sampling the line (no closed form)."""
    s = np.linspace(0.0, 1.0, 20001)
    v = b[None, :] + s[:, None] * (e - b)[None, :]
    angle = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    return float(np.abs(np.diff(angle)).max() / (dt * (s[1] - s[0])))


def turning(plant_options: dict[str, bool], clamp: bool = False) -> dict[str, np.ndarray]:
    """Five ticks on the motor plant of a body yawing at -0.3 rad/s whose velocity (0.9
    m/s) turns 0.5 rad a tick, the last tick slowing to 0.63 m/s as it turns: its events,
    and ``fractions``, each step's :meth:`Robot.ramp_turn_fraction` and the whole turn's
    (the clamp's turn check before the ramp's) of the last step."""
    robot = motor_preset("swerve")
    plant = MotorPlant(robot, DT, np.zeros(3), MotorPlantConfig(**plant_options),
                       np.random.default_rng(0))
    last = np.array([0.9, 0.0, -0.3])
    plant.set_motion(last)
    ramps, whole = [], 1.0
    for k in range(1, 6):
        speed = 0.9 if k < 5 else 0.63
        twist = np.array([speed * math.cos(0.5 * k), speed * math.sin(0.5 * k), -0.3])
        ramps.append(robot.ramp_turn_fraction(last, twist, DT))
        whole = robot.steering_fraction(last, twist, plant.steer_angles, DT)
        if clamp:
            twist, _ = clamp_command(robot, twist, last, DT, plant.steer_angles)
        plant.apply(command(robot, twist, plant.steer_angles))
        last = twist
    events = plant.events()
    events["fractions"] = np.array([*ramps, whole])
    return events


def test_a_module_turning_past_its_rate_inside_a_tick_slides() -> None:
    """A module slowing while it turns must turn faster than 12 rad/s near the tick's end,
    though its whole turn fits in the tick. The body yawing, the modules turn at different
    rates: the fastest lags, points off the way the other three carry it, and its tread
    scrubs past ``mu N`` with the step needing about 0.85 of it. With instant steering the
    same commands do not slide; cut to the clamp's step, they do not either."""
    events = turning({})
    fractions = events["fractions"]
    assert np.all(fractions[:4] == 1.0) and fractions[4] < 0.9  # the last ramp too fast
    assert fractions[5] == 1.0  # ... though its whole turn fits
    assert np.all(events["planned_traction_ratio"] < 0.9)
    np.testing.assert_array_equal(events["slip"], [0, 0, 0, 0, 1])
    assert events["steer_saturated"][4] == 1.0
    assert not turning({"steer_rate_limited": False})["slip"].any()
    clamped = turning({}, clamp=True)
    assert not clamped["slip"].any() and not clamped["steer_saturated"].any()


def test_the_ramp_fraction_by_hand() -> None:
    """From (1, 0) towards (0.6, 0.3) m/s the line is closest to rest at its end all the
    way, so the fraction f solves 0.3 f = 12 * 0.05 ((1 - 0.4 f)^2 + 0.09 f^2):
    0.15 f^2 - 0.78 f + 0.6 = 0."""
    robot = motor_preset("swerve")
    np.testing.assert_array_equal(robot.max_steer_rates, RATE)
    last, target = np.array([1.0, 0.0, 0.0]), np.array([0.6, 0.3, 0.0])
    by_hand = (0.78 - math.sqrt(0.78**2 - 4 * 0.15 * 0.6)) / (2 * 0.15)
    fraction = robot.ramp_turn_fraction(last, target, DT)
    assert fraction == pytest.approx(by_hand, abs=1e-6)
    assert peak_rate(last[:2], (last + fraction * (target - last))[:2], DT) == pytest.approx(
        12.0, rel=1e-3)
    # a module whose speed holds turns at the mean rate: the whole turn within the rate fits
    turn = 0.55
    assert robot.ramp_turn_fraction(last, np.array([math.cos(turn), math.sin(turn), 0.0]),
                              DT) == 1.0


def condition(robot: Robot, b_twist: np.ndarray, e_twist: np.ndarray, h: float,
              sign: float) -> np.ndarray:
    """Each module's ``sign (b x e) - rate h min |v(s)|^2`` [(rad/s)^2], the closest point
    found by a bounded scalar search along the line."""
    blocks = robot.wheel_blocks
    b, e = blocks @ b_twist, blocks @ e_twist  # (n, 2)
    closest = np.array([
        minimize_scalar(lambda s, i=i: float(np.sum((b[i] + s * (e[i] - b[i])) ** 2)),
                        bounds=(0.0, 1.0), method="bounded",
                        options={"xatol": 1e-12}).fun for i in range(len(b))])
    cross = b[:, 0] * e[:, 1] - b[:, 1] * e[:, 0]
    return sign * cross - RATE * h * closest


def test_the_steering_rows_linearise_the_ramp_condition() -> None:
    """At the plan they are linearised around, each row's value less its bound is the
    condition over ``|b|`` (the closest point found by a search, not the rows' closed
    form); its coefficients are the condition's slope (central differences), with the
    line closest to rest inside it, at its end and at its start."""
    robot = motor_preset("swerve")
    times = np.full(4, DT)
    limits = robot.stage_limits(times, None)
    first = int(limits.memory["steer_first"][0])
    last = np.array([1.0, 0.0, 0.5])
    # stage 0 turns at about its speed (closest point inside the line for three modules),
    # stage 1 slows (closest at its end), stage 2 speeds up (closest at its start)
    guess = np.array([[0.95, 0.35, 0.5], [0.5, 0.4, 0.3], [1.2, 0.6, 0.2], [1.3, 0.5, 0.0]])
    robot.update_stage_limits(limits, guess, last, None)
    n = robot.n_wheels
    previous = np.vstack([last, guess[:-1]])
    for k in (0, 1, 2):
        rows = slice(first, first + ROWS_PER_MODULE * n)
        now = limits.now[k, rows].reshape(n, ROWS_PER_MODULE, 3)
        before = limits.before[k, rows].reshape(n, ROWS_PER_MODULE, 3)
        upper = limits.upper[k, rows].reshape(n, ROWS_PER_MODULE)
        beta = np.linalg.norm(robot.wheel_blocks @ previous[k], axis=1)
        for r, sign in enumerate((1.0, -1.0)):
            exact = condition(robot, previous[k], guess[k], DT, sign) / beta
            value = now[:, r] @ guess[k] + before[:, r] @ previous[k] - upper[:, r]
            # a row widened to hold the last command has its bound there instead
            held = now[:, r] @ last + before[:, r] @ last
            kept = np.abs(upper[:, r] - held) > 1e-9
            assert kept.sum() >= 2
            np.testing.assert_allclose(value[kept], exact[kept], rtol=1e-4, atol=1e-6)
            step = 1e-5
            for j in range(3):
                d = np.zeros(3)
                d[j] = step
                slope_e = (condition(robot, previous[k], guess[k] + d, DT, sign)
                           - condition(robot, previous[k], guess[k] - d, DT, sign)) / (2 * step)
                slope_b = (condition(robot, previous[k] + d, guess[k], DT, sign)
                           - condition(robot, previous[k] - d, guess[k], DT, sign)) / (2 * step)
                np.testing.assert_allclose(now[:, r, j], slope_e / beta, rtol=1e-3, atol=1e-3)
                np.testing.assert_allclose(before[:, r, j], slope_b / beta, rtol=1e-3, atol=1e-3)
