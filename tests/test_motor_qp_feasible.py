"""The motor-aware QP stays feasible where the plan it starts from is out of reach.

On the swerve preset's 1 m figure-eight at 1.3x the geared free speed, the clamp cut the
command far short of the plan (its modules at their steering rate), the next plan's
first stage was linearised around a point the last command could not reach, and its
rows (the voltage under the bus sag of that plan's power against the current and
traction rows) excluded every first command: tick 57 (seed 0) was infeasible. The first
stage's motor rows now always hold the last command (:func:`_reach_last`)."""

from __future__ import annotations

import numpy as np

from benchmarks.motors import free_speed_reference
from mpc import Controller
from mpc.robots import motor_preset
from mpc.robots.drive.motor_limits import MotorStageLimits, update_stage_limits
from mpc.sim import simulate
from mpc.solvers.dense import DenseSolver


def test_recorded_infeasible_tick_now_solves() -> None:
    robot = motor_preset("swerve")
    reference = free_speed_reference("figure8", robot, 1.3, 1.0)
    control = Controller(robot, reference, 20, 0.05, command_ramp=True)
    result = simulate(control, 3.0, plant="motor", robot=robot, seed=0)
    assert len(result.status) >= 58
    assert [s for s in result.status if s != "solved"] == []


def test_first_stage_rows_hold_the_last_command() -> None:
    robot = motor_preset("swerve")
    reference = free_speed_reference("figure8", robot, 1.0, 2.0)
    control = Controller(robot, reference, 20, 0.05, command_ramp=True)
    simulate(control, 0.5, plant="motor", robot=robot, seed=0)
    solver = control.solver
    assert isinstance(solver, DenseSolver)
    limits = solver.limits
    assert isinstance(limits, MotorStageLimits) and limits.kinematic is not None
    m = limits.kinematic.rows
    last = np.array([2.0, -1.0, 0.5])  # far from the plan the rows were linearised on
    guess = np.tile([-2.0, 1.5, -0.5], (limits.horizon, 1))
    update_stage_limits(robot, limits, guess, last, None)
    held = limits.now[0, m:] @ last + limits.before[0, m:] @ last
    assert np.all(limits.lower[0, m:] <= held + 1e-12)
    assert np.all(held <= limits.upper[0, m:] + 1e-12)

