"""The rigid-body force map: Newton-Euler from the contacts' own geometry, minimum norm,
finite differences of the Coriolis linearisation, and the motor plant's own acceleration."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from mpc import Command, Status
from mpc.robots import MOTOR_ROBOT_PRESETS, Robot, motor_preset, omni
from mpc.robots.drive.dynamics import GRAVITY, dynamics
from mpc.robots.drive.force_map import coriolis, force_map
from mpc.robots.drive.motor_step import first_step_feedforward
from mpc.sim.motor_plant import MotorPlant, MotorPlantConfig

RNG_SEED = 7


def contact_points(robot: Robot) -> np.ndarray:
    """Each contact's point in the body frame (the wheel centres it gathers)."""
    forces = force_map(robot)
    points = np.zeros((forces.n_contacts, 2))
    points[forces.contact_of] = robot.wheel_positions
    return points


@pytest.mark.parametrize("name", MOTOR_ROBOT_PRESETS)
def test_contact_forces_obey_newton_euler(name: str) -> None:
    """Sum of the contact forces = m a, their moment about the origin = I alpha: computed
    from the contact points and forces alone, not from the wheel maps."""
    robot = motor_preset(name)
    forces = force_map(robot)
    dyn = robot.dynamics
    assert dyn is not None
    rng = np.random.default_rng(RNG_SEED)
    points = contact_points(robot)
    for _ in range(20):
        accel = rng.normal(size=3) * [2.0, 2.0, 5.0]
        contact = forces.contact_forces(accel)  # (c, 2) [N]
        np.testing.assert_allclose(contact.sum(axis=0), dyn.mass * accel[:2], atol=1e-9)
        moment = float(np.sum(points[:, 0] * contact[:, 1] - points[:, 1] * contact[:, 0]))
        assert moment == pytest.approx(dyn.yaw_inertia * accel[2], abs=1e-9)
        # and the wheel efforts give the same wrench through the virtual work map
        np.testing.assert_allclose(forces.wrench(forces.efforts(accel)),
                                   forces.mass_matrix @ accel, atol=1e-9)


@pytest.mark.parametrize("name", MOTOR_ROBOT_PRESETS)
def test_efforts_are_the_minimum_norm_split(name: str) -> None:
    robot = motor_preset(name)
    forces = force_map(robot)
    flat = robot.flat_wheel_blocks  # (n d, 3): wrench = flat^T tau
    rng = np.random.default_rng(RNG_SEED)
    accel = rng.normal(size=3)
    efforts = forces.efforts(accel).reshape(-1)
    wrench = forces.mass_matrix @ accel
    least, *_ = np.linalg.lstsq(flat.T, wrench, rcond=None)  # numpy's minimum-norm solution
    np.testing.assert_allclose(efforts, least, atol=1e-10)
    # no internal force: orthogonal to every effort that moves nothing
    null = np.linalg.svd(flat.T)[2][3:]
    np.testing.assert_allclose(null @ efforts, 0.0, atol=1e-9)


def test_swedish_contact_force_by_hand() -> None:
    """A Mecanum wheel pushes along its rollers' axis with |tau| / (r cos 45 deg)."""
    robot = motor_preset("mecanum")
    forces = force_map(robot)
    accel = np.array([1.0, 0.0, 0.0])  # straight ahead: every wheel the same effort
    efforts = forces.efforts(accel)[:, 0]
    dyn = robot.dynamics
    assert dyn is not None
    np.testing.assert_allclose(np.abs(efforts), dyn.mass * 1.0 * 0.05 / 4, rtol=1e-12)
    contact = np.linalg.norm(forces.contact_forces(accel), axis=1)
    np.testing.assert_allclose(contact, np.abs(efforts) / (0.05 * math.cos(math.pi / 4)))
    # static loads: a quarter of the weight each
    np.testing.assert_allclose(forces.normal_loads, dyn.mass * GRAVITY / 4)


def test_coriolis_linearisation_against_finite_differences() -> None:
    """The QP's motor rows carry ``g . coriolis(u)`` linearised around the guess: their
    coefficients are the Jacobian of the exact term (central differences)."""
    from mpc.robots.drive.motor_limits import MotorStageLimits, stage_limits, update_stage_limits

    robot = motor_preset("mecanum")
    assert robot.dynamics is not None  # without sag: its rows move with the power too
    robot = robot.with_dynamics(replace(robot.dynamics, battery_resistance=0.0))
    times = np.full(4, 0.1)
    limits = stage_limits(robot, times, 16)
    rng = np.random.default_rng(RNG_SEED)
    guess = rng.normal(size=(4, 3))
    last = rng.normal(size=3)
    update_stage_limits(robot, limits, guess, last, None)
    assert isinstance(limits, MotorStageLimits)
    m = robot.n_wheels  # the kinematic speed rows come first
    g = limits.g  # (N, rows, 3): each row's coefficient on the body acceleration
    rows = limits.motor
    assert rows is not None
    h = 1e-6
    for k in range(4):
        twist = guess[k]
        for j in range(3):
            step = np.zeros(3)
            step[j] = h
            derivative = (coriolis(twist + step) - coriolis(twist - step)) / (2 * h)
            expected = g[k] @ derivative
            coefficient = limits.now[k, m:, j] - limits.base_now[k, :, j]
            np.testing.assert_allclose(np.where(rows.end, coefficient, 0.0),
                                       np.where(rows.end, expected, 0.0), atol=1e-6)
    # at the guess the row is exact: its Coriolis coefficients times ubar_k, less the
    # bound's shift, give g . coriolis(ubar_k) (end rows)
    coefficient = limits.now[:, m:] - limits.base_now
    value = np.einsum("kmj,kj->km", coefficient, guess)
    shift = limits.upper[:, m:] - limits.motor_bound
    exact = np.einsum("kmj,kj->km", g, coriolis(guess))
    np.testing.assert_allclose(np.where(rows.end, value - shift, 0.0),
                               np.where(rows.end, exact, 0.0), atol=1e-9)


@pytest.mark.parametrize("name", ["omni4", "mecanum", "ball3", "swerve"])
def test_plant_acceleration_matches_the_feedforward(name: str) -> None:
    """Finite differences of the motor plant's own twist: driven by the feedforward torques
    of a step, the robot accelerates as the force map says (Coriolis term included)."""
    robot = motor_preset(name)
    config = MotorPlantConfig(substeps=40, velocity_gain=0.0, battery_resistance=0.0,
                              slip_ratio=0.0)  # a rigid tread: the physics, not the tyre
    start = np.array([0.6, -0.3, 0.8])  # moving and turning: the Coriolis term matters
    target = start + np.array([0.02, 0.015, 0.03])
    dt = 0.02
    plant = MotorPlant(robot, dt, np.zeros(3), config, np.random.default_rng(0))
    plant.set_motion(start)
    speeds, angles = robot.wheel_commands(target, plant.steer_angles)
    feed = first_step_feedforward(robot, start, target, dt, angles)
    assert feed is not None
    command = Command(wheel_speeds=speeds, twist=target, steer_angles=angles,
                      predicted_poses=np.zeros((1, 3)), status=Status.SOLVED,
                      solver_status="", solve_time=0.0, tick_time=0.0, iterations=0,
                      consecutive_failures=0, clamped=False, reference_time=0.0,
                      motor_torques=feed[1])
    plant.apply(command)
    assert not plant.events()["slip"].any()
    # the open-loop torques alone (no wheel feedback) reach the target twist: the force
    # map's accelerations, Coriolis term included, are the plant's (sub-step Euler error)
    np.testing.assert_allclose(plant.twist, target, atol=0.02 * np.abs(target - start).max())


def test_a_wheel_on_the_axis_carries_no_yaw_effort() -> None:
    """Hand check on a symmetric omni robot: pure rotation splits the yaw moment evenly."""
    robot = omni(n_wheels=4, base_radius=0.2, wheel_radius=0.05, max_wheel_speed=50.0)
    robot = robot.with_dynamics(dynamics(mass=10.0, yaw_inertia=0.5, motor="neo",
                                         gearing=10.0))
    forces = force_map(robot)
    efforts = forces.efforts(np.array([0.0, 0.0, 2.0]))[:, 0]
    # each wheel's rim force f at lever 0.2 m: 4 f 0.2 = I alpha = 1 N m -> f = 1.25 N
    np.testing.assert_allclose(efforts, 1.25 * 0.05, rtol=1e-12)
