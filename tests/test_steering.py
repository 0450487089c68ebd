"""Swerve steering rate in the final clamp: the closed-form steering fraction against a brute
force search, and commands that never turn a module faster than its steering motor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpc import Controller, Status
from mpc.control.clamp import clamp_command
from mpc.model import integrate
from mpc.robots import SwerveRobot, preset
from mpc.robots.wheels.swerve.limits import steering_fraction, turns
from trajectories import Waypoints

DT = 0.05


def swerve_robot() -> SwerveRobot:
    robot = preset("swerve")
    assert isinstance(robot, SwerveRobot)
    return robot


def brute_force(robot: SwerveRobot, last: np.ndarray, target: np.ndarray,
                angles: np.ndarray) -> float:
    """1 if the target fits, else the end of the first run of fitting points from 0 on a
    grid of 20001 fractions (only the command sent must fit, not the way to it)."""
    reach = robot.max_steer_rate * DT
    if np.all(turns(robot, robot.wheel_blocks @ target, angles) <= reach):
        return 1.0
    grid = np.linspace(0.0, 1.0, 20001)
    # every grid point's module velocities at once, (points, modules, 2), as one (n, 2) batch
    twists = last + grid[:, np.newaxis] * (target - last)
    velocities = np.einsum("ndj,mj->mnd", robot.wheel_blocks, twists)
    turned = turns(robot, velocities.reshape(-1, 2), np.tile(angles, grid.size))
    off = np.any(turned.reshape(grid.size, -1) > reach, axis=1)
    if not off.any():
        return 1.0
    k = int(np.argmax(off))  # the first point where a module would turn too far
    return float(grid[k - 1]) if k else 0.0


@pytest.mark.parametrize("seed", range(40))
def test_fraction_is_where_the_first_module_reaches_its_steering_limit(seed: int) -> None:
    robot = swerve_robot()
    rng = np.random.default_rng(seed)
    last = rng.uniform(-1.5, 1.5, 3) * [1.0, 1.0, 2.0]
    target = rng.uniform(-1.5, 1.5, 3) * [1.0, 1.0, 2.0]
    if seed % 4 == 0:
        last[:] = 0.0  # from rest: every module may point anywhere
    velocities = robot.wheel_blocks @ last
    angles = np.arctan2(velocities[:, 1], velocities[:, 0]) + rng.uniform(-0.2, 0.2, 4)
    fraction = steering_fraction(robot, last, target, angles, DT)
    expected = brute_force(robot, last, target, angles)
    assert 0.0 <= fraction <= 1.0
    assert fraction == pytest.approx(expected, abs=1e-4)
    # and it is safe: the module turns at that fraction are within one tick's steering
    reach = robot.max_steer_rate * DT
    chosen = robot.wheel_blocks @ (last + fraction * (target - last))
    assert np.all(turns(robot, chosen, angles) <= reach * (1 + 1e-9))


def test_clamped_commands_never_turn_a_module_too_fast() -> None:
    """Random targets fed tick after tick: every command's modules turn at most
    max_steer_rate * dt from the angles they were commanded before (flip rule)."""
    robot = swerve_robot()
    rng = np.random.default_rng(3)
    last = np.zeros(3)
    angles = robot.initial_steer_angles()
    assert angles is not None
    reach = robot.max_steer_rate * DT
    for _ in range(300):
        target = rng.uniform(-2.0, 2.0, 3) * [1.0, 1.0, 3.0]
        twist, _ = clamp_command(robot, target, last, DT, angles)
        speeds, new_angles = robot.wheel_commands(twist, angles, target, DT)
        assert new_angles is not None
        turn = np.abs(np.mod(new_angles - angles + math.pi / 2, math.pi) - math.pi / 2)
        assert np.all(turn <= reach * (1 + 1e-6))
        assert np.all(np.abs(speeds) <= robot.max_wheel_speed * (1 + 1e-9))
        last = robot.forward_kinematics(speeds, new_angles)
        angles = new_angles


def test_exact_path_solves_through_the_end_of_a_reference_that_ends_at_speed() -> None:
    """Waypoints that end while moving: the horizon reaches past the end, where the plan
    must stop every module. The exact steering rows were a cone with no gradient at rest
    and IPOPT stalled there (a fallback on most ticks after the end); with the rows
    loosened below a tenth of the speed limit it solves every tick, and the robot comes
    to rest on the last pose."""
    robot = preset("swerve")
    reference = Waypoints([0.0, 1.0, 2.0], [[0.0, 0.0, 0.0], [0.5, 0.2, 0.5], [1.0, 0.0, 0.5]])
    control = Controller(robot, reference, dt=0.02, solver="ipopt")
    pose = reference.sample(1.2).pose
    statuses = []
    for k in range(60, 120):
        command = control.step(pose, k * 0.02)
        statuses.append(command.status)
        pose = integrate(pose, command.twist, 0.02)
    assert statuses == [Status.SOLVED] * 60
    assert np.allclose(pose, [1.0, 0.0, 0.5], atol=2e-3)


def test_the_axle_offset_search_checks_twists_as_the_wheel_commands_drive_them() -> None:
    """The vectorised check behind the axle-offset clamp's search agrees with
    ``wheel_commands`` (flip rule, steering correction) twist by twist, limits included."""
    from mpc.robots.wheels.swerve.limits import _drives_within

    robot = preset("mpo700")
    assert isinstance(robot, SwerveRobot) and robot.axle_offset > 0.0
    rng = np.random.default_rng(11)
    dt = 0.05
    outcomes = set()
    for _ in range(200):
        twists = rng.normal(0.0, 1.0, (4, 3))
        # one module at rest: the body turning about it (its angle kept, its drive only the
        # axle offset's L omega / r)
        positions = np.asarray(robot.module_positions)
        (x, y), omega = positions[rng.integers(robot.n_wheels)], twists[0, 2]
        twists[0, :2] = omega * y, -omega * x
        steer = rng.uniform(-math.pi, math.pi, robot.n_wheels)
        within = _drives_within(robot, twists, steer, dt)
        for twist, ok in zip(twists, within, strict=True):
            speeds, _ = robot.wheel_commands(twist, steer, None, dt)
            assert bool(ok) == bool(np.all(np.abs(speeds)
                                           <= robot.max_wheel_speed * (1.0 + 1e-12)))
            outcomes.add(bool(ok))
    assert outcomes == {True, False}  # both sides of the limits were tried


def test_the_one_twist_check_in_python_floats_agrees_with_the_vectorised_one() -> None:
    """The clamp checks the fraction's own point in Python floats before it scans the way
    in NumPy: the two agree twist by twist, drives and turns, on both sides of the limits
    (modules at rest among them)."""
    from mpc.robots.wheels.swerve.limits import _drives_fit, _drives_within

    robot = preset("mpo700")
    assert isinstance(robot, SwerveRobot)
    rng = np.random.default_rng(14)
    dt, reach = 0.05, robot.max_steer_rate * 0.05 * (1.0 - 1e-9)
    outcomes = set()
    for _ in range(100):
        twists = rng.normal(0.0, 0.6, (8, 3))
        positions = np.asarray(robot.module_positions)
        (x, y), omega = positions[rng.integers(robot.n_wheels)], twists[0, 2]
        twists[0, :2] = omega * y, -omega * x  # one module at rest
        last = rng.normal(0.0, 0.6, 3)
        _, aligned = robot.wheel_commands(last, None)
        assert aligned is not None
        steer = aligned + rng.uniform(-0.3, 0.3, robot.n_wheels)
        for limit in (reach, None):
            within = _drives_within(robot, twists, steer, dt, limit)
            for twist, ok in zip(twists, within, strict=True):
                assert _drives_fit(robot, twist, steer, dt,
                                   math.inf if limit is None else limit) == bool(ok)
                outcomes.add(bool(ok))
    assert outcomes == {True, False}


def test_the_axle_offset_clamp_keeps_every_drive_within_its_limit() -> None:
    robot = preset("mpo700")
    assert isinstance(robot, SwerveRobot)
    rng = np.random.default_rng(12)
    dt = 0.05
    for _ in range(40):
        steer = rng.uniform(-math.pi, math.pi, robot.n_wheels)
        last = np.zeros(3)
        target = rng.normal(0.0, 2.0, 3)
        fraction = steering_fraction(robot, last, target, steer, dt)
        assert 0.0 <= fraction <= 1.0
        speeds, _ = robot.wheel_commands(last + fraction * (target - last), steer, None, dt)
        assert np.all(np.abs(speeds) <= robot.max_wheel_speed * (1.0 + 1e-12))


def test_the_axle_offset_clamp_goes_as_far_as_a_brute_force_scan_of_the_way() -> None:
    """From a moving start, the clamp's fraction keeps every drive and every moving
    module's turn within its limit, and reaches within 1e-3 of the longest stretch of the
    way that a scan of 2,001 points finds within them all (an independent answer)."""
    robot = preset("mpo700")
    assert isinstance(robot, SwerveRobot)
    rng = np.random.default_rng(13)
    dt = 0.05
    scan = np.linspace(0.0, 1.0, 2001)
    searched = 0
    for _ in range(60):
        last = rng.normal(0.0, 0.3, 3)
        _, aligned = robot.wheel_commands(last, None)
        assert aligned is not None
        steer = aligned + rng.uniform(-0.3, 0.3, robot.n_wheels) * robot.max_steer_rate * dt
        target = last + rng.normal(0.0, 1.5, 3)
        if not _within_on_the_way(robot, last, target, steer, dt, 0.0):
            continue
        fraction = steering_fraction(robot, last, target, steer, dt)
        assert _within_on_the_way(robot, last, target, steer, dt, fraction)
        if fraction < 1.0:
            searched += 1
            # the scan's first point off limits ends the stretch: nothing after it counts
            first_off = next((i for i, g in enumerate(scan)
                              if not _within_on_the_way(robot, last, target, steer, dt, g)),
                             None)
            longest = 1.0 if first_off is None else scan[first_off - 1]
            assert longest - 1e-3 <= fraction <= longest + 1e-3
    assert searched >= 10


def _within_on_the_way(robot: SwerveRobot, last: np.ndarray, target: np.ndarray,
                       steer: np.ndarray, dt: float, g: float) -> bool:
    """Whether the wheel commands of ``last + g (target - last)`` keep every drive and every
    moving module's turn from ``steer`` within its limit."""
    twist = last + g * (target - last)
    speeds, angles = robot.wheel_commands(twist, steer, None, dt)
    velocity = robot.wheel_blocks @ twist
    moving = np.hypot(velocity[:, 0], velocity[:, 1]) * robot.wheel_radius > 1e-6
    turned = np.abs(np.mod(angles - steer + math.pi, 2.0 * math.pi) - math.pi)
    return bool(np.all(np.abs(speeds) <= robot.max_wheel_speed * (1.0 + 1e-12))
                and np.all(~moving | (turned <= robot.max_steer_rate * dt * (1.0 + 1e-9))))
