"""The safety clamp (:mod:`mpc.control.clamp`).

``clamp_command`` first scales the target uniformly into the speed limits
(``robot.desaturate``), then steps from the last command towards it only as
far as every wheel's acceleration limit allows. So the result lies on the
segment from ``last`` to the desaturated target, which is the segment from
``last`` to ``target`` itself whenever the target is within the speed limits.
"""

from __future__ import annotations

import numpy as np
import pytest
from closed_loop import ACCEL_PRESETS

from mpc.control.clamp import clamp_command
from mpc.robots import PRESETS, Robot, SwedishRobot, SwedishWheel, preset

DT = 0.05


def accel_ratio(robot: Robot, change: np.ndarray, dt: float = DT) -> float:
    """Peak ||W_i change|| / (accel_i dt) over the wheels."""
    if robot.max_wheel_accel is None:
        raise AssertionError("the robot has no acceleration limits")
    size = np.linalg.norm(robot.wheel_velocities(change), axis=-1)
    return float((size / (robot.max_wheel_accel * dt)).max())


def random_feasible(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    """A twist inside the speed limits, anywhere from rest to the boundary."""
    direction = rng.normal(size=3) * np.array([1.0, 1.0, 3.0])
    return robot.desaturate(direction * 100.0) * rng.uniform(0.0, 1.0)


def random_target(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    """A twist from tiny changes near anything to three times beyond the limits."""
    scale = rng.choice([0.01, 0.3, 1.0, 3.0])
    return robot.desaturate(rng.normal(size=3) * np.array([1, 1, 3]) * 100.0) * scale * (
        rng.uniform(0.0, 1.0))


def segment_fraction(start: np.ndarray, end: np.ndarray, point: np.ndarray) -> tuple[float, float]:
    """(fraction f, distance off the line) for point ~ start + f (end - start)."""
    direction = end - start
    length2 = float(direction @ direction)
    if length2 == 0.0:
        return 0.0, float(np.linalg.norm(point - start))
    fraction = float((point - start) @ direction / length2)
    return fraction, float(np.linalg.norm(start + fraction * direction - point))


@pytest.mark.parametrize("robot_name", ACCEL_PRESETS)
def test_clamp_respects_speed_and_acceleration_and_moves_along_the_segment(
    robot_name: str,
) -> None:
    robot = preset(robot_name)
    rng = np.random.default_rng(2024)
    for _ in range(300):
        last, target = random_feasible(robot, rng), random_target(robot, rng)
        if rng.uniform() < 0.3:  # a target close to the last command (often feasible)
            target = last + rng.normal(size=3) * 0.01
        result, changed = clamp_command(robot, target, last, DT)

        assert robot.is_feasible(result)
        assert accel_ratio(robot, result - last) <= 1.0 + 1e-9
        goal = robot.desaturate(target)
        fraction, off_line = segment_fraction(last, goal, result)
        assert -1e-9 <= fraction <= 1.0 + 1e-9
        assert off_line <= 1e-9 * (1.0 + np.linalg.norm(goal))
        if robot.is_feasible(target, rtol=0.0):
            _, off_target_line = segment_fraction(last, target, result)
            assert off_target_line <= 1e-9 * (1.0 + np.linalg.norm(target))
        if fraction < 1.0 - 1e-9:  # stopped short: some wheel is at its acceleration limit
            # (less what a command as sent may sit off W u at each end: command_snap)
            assert robot.max_wheel_accel is not None
            at_limit = 1.0 - 2.0 * robot.command_snap / float(np.max(robot.max_wheel_accel) * DT)
            assert accel_ratio(robot, result - last) == pytest.approx(at_limit, abs=1e-9)
        assert changed == (not np.array_equal(result, target))


@pytest.mark.parametrize("robot_name", ACCEL_PRESETS)
def test_clamp_returns_a_feasible_target_unchanged(robot_name: str) -> None:
    robot = preset(robot_name)
    rng = np.random.default_rng(7)
    for _ in range(100):
        last = random_feasible(robot, rng)
        # A target within the speed limits and within half of every acceleration limit.
        step = rng.normal(size=3)
        step *= 0.5 / accel_ratio(robot, step)
        target = robot.desaturate(last + step)
        if accel_ratio(robot, target - last) > 1.0:
            continue
        result, changed = clamp_command(robot, target, last, DT)
        np.testing.assert_array_equal(result, target)
        assert not changed


def test_clamp_without_acceleration_limits_only_desaturates() -> None:
    robot = preset("omni4")
    assert isinstance(robot, SwedishRobot)
    unlimited = SwedishRobot(name="omni4-free", wheels=tuple(
        SwedishWheel(alpha=w.alpha, beta=w.beta, gamma=w.gamma, l=w.l, radius=w.radius,
                     max_speed=w.max_speed) for w in robot.wheels))
    assert unlimited.max_wheel_accel is None
    target = np.array([3.0, -1.0, 2.0])
    result, changed = clamp_command(unlimited, target, np.zeros(3), DT)
    assert changed
    np.testing.assert_allclose(result, unlimited.desaturate(target), rtol=1e-11)
    assert unlimited.speed_ratio(result) == pytest.approx(1.0, abs=1e-11)


def rest_projector(robot: Robot, wheel: int) -> np.ndarray:
    """Orthogonal projector onto the twists that keep ``wheel`` at rest (null space of W_i)."""
    block = robot.wheel_blocks[wheel]
    return np.eye(3) - block.T @ np.linalg.solve(block @ block.T, block)


@pytest.mark.parametrize("robot_name", PRESETS)
def test_clamp_on_derated_robot_when_last_breaks_the_new_limit(robot_name: str) -> None:
    """Wheel 0 failed (limit 0) while the robot was moving it: the speed limits win. The
    command is the target with wheel 0's motion projected out, scaled into the limits,
    even though that is a bigger step than the acceleration limit allows."""
    robot = preset(robot_name)
    derated = robot.derated({0: 0.0})
    projector = rest_projector(robot, 0)
    last = robot.desaturate(np.array([1.0, 0.5, 0.5])) * 0.9  # fast: wheel 0 moving
    assert np.linalg.norm(robot.wheel_velocities(last)[0]) > 1.0
    assert not derated.is_feasible(last)
    rng = np.random.default_rng(5)
    for target in [last, np.zeros(3), *rng.normal(size=(20, 3))]:
        result, changed = clamp_command(derated, target, last, DT)
        assert derated.is_feasible(result)
        np.testing.assert_allclose(derated.wheel_velocities(result)[0], 0.0, atol=1e-12)
        expected = derated.desaturate(projector @ target)
        np.testing.assert_allclose(result, expected, rtol=1e-9, atol=1e-14)
        if not np.allclose(target, 0.0):
            assert changed


def test_clamp_on_derated_robot_keeps_the_failed_wheel_at_rest_within_acceleration() -> None:
    """From a last command that already holds the failed wheel at rest, every limit holds."""
    robot = preset("mecanum")
    derated = robot.derated({1: 0.0})
    projector = rest_projector(robot, 1)
    rng = np.random.default_rng(6)
    for _ in range(100):
        last = derated.desaturate(projector @ random_feasible(robot, rng))
        target = random_target(robot, rng)
        result, _ = clamp_command(derated, target, last, DT)
        assert derated.is_feasible(result)
        assert abs(derated.wheel_speeds(result)[1]) <= 1e-12
        assert accel_ratio(derated, result - last) <= 1.0 + 1e-9


def test_clamp_on_derated_robot_from_a_feasible_last_keeps_acceleration() -> None:
    robot = preset("mecanum").derated({2: 0.5})
    rng = np.random.default_rng(8)
    for _ in range(100):
        last, target = random_feasible(robot, rng), random_target(preset("mecanum"), rng)
        result, _ = clamp_command(robot, target, last, DT)
        assert robot.is_feasible(result)
        assert accel_ratio(robot, result - last) <= 1.0 + 1e-9


def test_commands_as_sent_keep_the_acceleration_limit_when_a_module_stops() -> None:
    """A swerve module slower than STOPPED_MODULE_SPEED is sent at rest, a hair off
    ``W_i u``; the next command's change, as sent, must still be within the limit. Found by
    ``mpc-bench sweep`` (case 18 of seed 0): the change measured from the module sent at
    rest exceeded the limit by 6e-6 relative on the fourth tick."""
    from benchmarks.executor import RunSpec, execute

    robot = {"type": "swerve", "name": "random-swerve", "wheel_radius": 0.05141369571718998,
             "module_positions": [[0.2234810639936394, 0.34191306749586836],
                                  [0.2234810639936394, -0.34191306749586836],
                                  [-0.2234810639936394, 0.34191306749586836],
                                  [-0.2234810639936394, -0.34191306749586836]],
             "max_wheel_speed": 21.876903068666124, "max_steer_rate": 11.131043410437314,
             "max_wheel_accel": 36.84841710872171}
    spec = RunSpec(robot=robot, controller="mpc-daqp", duration=10.0, seed=1468987151,
                   trajectory={"shape": "circle", "heading": "fixed",
                               "ratio": 0.8856856473286314},
                   plant={"motor_lag": 0.04668844549784214, "delay_ticks": 0,
                          "position_noise": 0.002471344075178315,
                          "heading_noise": 0.008968012322637598,
                          "slip": 0.029166002346173798},
                   initial_offset=(-0.10888623753072177, -0.0656017921109265,
                                   -0.37730933982392656))
    result, _ = execute(spec)
    metrics = result["metrics"]
    assert metrics["accel_violations"] == 0
    assert metrics["limit_violations"] == 0 and metrics["steer_violations"] == 0


@pytest.mark.parametrize("name", ["swerve", "mpo700", "mecanum"])
def test_a_last_command_beyond_the_speed_limits_gives_way_to_them(name: str) -> None:
    """The limits just derated below the last command: the clamp cannot step from it within
    the acceleration or steering limits as well, and keeps every wheel within its speed
    limit (the speed limits win)."""
    robot = preset(name)
    last = np.array([1.0, 0.3, 0.5])
    last *= 3.0 * float((robot.max_wheel_speed / robot.wheel_magnitudes(last)).min())
    steer = robot.initial_steer_angles()
    if steer is not None:  # modules aligned with the last command; the target turns them
        steer = robot.wheel_commands(last, steer)[1]
    target = np.array([0.0, 0.2, -0.3])
    safe, _ = clamp_command(robot, target, last, 0.05, steer)
    assert np.all(robot.wheel_magnitudes(safe) <= robot.max_wheel_speed * (1 + 1e-9))


@pytest.mark.parametrize(("limit", "factor"), [(1e-6, 1.0), (1e-3, 1.0), (30.0, 1e-6)])
def test_tiny_limits_hold_to_rounding_relative_to_themselves(limit: float,
                                                             factor: float) -> None:
    """The clamp's rounding slack is relative to each wheel's limit: a limit of 1e-6 rad/s
    (the smallest a robot takes) or a wheel derated to 1e-6 of the others holds to 1e-9
    of itself, not to an absolute 1e-12 rad/s (which let a 1e-13 limit read 8x)."""
    from mpc.robots import mecanum

    robot = mecanum(wheelbase=0.3, track=0.25, wheel_radius=0.05, max_wheel_speed=limit,
                    max_wheel_accel=40.0).derated({0: factor})
    rng = np.random.default_rng(11)
    scale = limit * 0.1  # twists at this robot's scale
    last = np.zeros(3)
    for _ in range(200):
        target = rng.normal(size=3) * scale * rng.choice([0.5, 3.0])
        safe, _ = clamp_command(robot, target, last, DT)
        speeds = robot.wheel_magnitudes(safe)
        assert (speeds <= robot.max_wheel_speed * (1.0 + 1e-9)).all()
        last = safe


@pytest.mark.parametrize("name", ["omni3", "omni4", "mecanum", "ball3"])
def test_the_scalar_wheel_clamp_agrees_with_the_array_clamp(name: str) -> None:
    """Robots whose wheels have scalar speeds clamp in plain Python floats
    (``Robot.scalar_wheels``): the same twists as the NumPy clamp every robot can take (to
    rounding of the wheel products' summation order), the same verdict on whether the
    target changed, and the target itself returned when it is within every limit."""
    from mpc.control.clamp import _clamp_arrays, _clamp_scalar

    robot = preset(name)
    wheels = robot.scalar_wheels
    assert wheels is not None
    for twist in np.random.default_rng(5).normal(size=(20, 3)):  # the rows are W's, as floats
        np.testing.assert_array_equal(np.array(wheels.rows) @ twist,
                                      robot.wheel_blocks[:, 0, :] @ twist)
        np.testing.assert_allclose(np.abs(np.array(wheels.rows) @ twist),
                                   robot.wheel_magnitudes(twist), rtol=1e-15, atol=0.0)
    rng = np.random.default_rng(2026)
    changed = 0
    for _ in range(500):
        last, target = random_feasible(robot, rng), random_target(robot, rng)
        for dt in (DT, 1e-3):
            mine, moved = _clamp_scalar(wheels, target, last, dt)
            theirs, moved_too = _clamp_arrays(robot, target, last, dt, None)
            np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12)
            assert moved == moved_too
            assert (mine is target) == (not moved)
            changed += moved
    assert changed > 100  # both sides of the limits were tried


def test_robots_the_scalar_clamp_does_not_fit_take_the_array_clamp() -> None:
    """Steered wheels, a failed wheel (its rest projector) and a motor model each need what
    only the array clamp does: they have no ``scalar_wheels``."""
    from mpc.robots import motor_preset

    assert preset("swerve").scalar_wheels is None
    assert preset("caster4").scalar_wheels is None
    assert preset("mecanum").derated({1: 0.0}).scalar_wheels is None
    assert preset("mecanum").derated({1: 0.5}).scalar_wheels is not None
    assert motor_preset("mecanum").scalar_wheels is None


def test_the_planar_module_clamp_agrees_with_the_array_clamp() -> None:
    """Swerve modules without an axle offset clamp in Python floats
    (``Robot.planar_modules``): the same twists as the NumPy clamp (to rounding of the
    module products' summation order) and the same verdict, on random last commands,
    targets and steer angles (modules aligned with the last command and turned by up to
    three ticks of their steering rate), so that the speed, acceleration and steering
    steps each bind, alone and together."""
    from mpc.control.clamp import _clamp_arrays, _clamp_planar

    robot = preset("swerve")
    modules = robot.planar_modules
    assert modules is not None
    rng = np.random.default_rng(2027)
    bound = {"speed": 0, "turn": 0, "unchanged": 0}
    for _ in range(400):
        last = random_feasible(robot, rng)
        near = last + rng.normal(size=3) * rng.choice([1e-3, 3e-2])  # within reach, or not
        faster = last * rng.uniform(1.2, 4.0)  # the same directions: speed and acceleration
        target = (near, faster, random_target(robot, rng))[rng.integers(3)]
        for dt in (DT, 1e-3):
            aligned = robot.wheel_commands(last, robot.initial_steer_angles())[1]
            assert aligned is not None
            turned = rng.choice([0.0, 0.5, 3.0]) * modules.steer_rate * dt
            steer = aligned + rng.uniform(-1.0, 1.0, robot.n_wheels) * turned
            mine, moved = _clamp_planar(robot, modules, target, last, dt, steer)
            theirs, moved_too = _clamp_arrays(robot, target, last, dt, steer)
            np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12)
            assert moved == moved_too
            assert (mine is target) == (not moved)
            if not moved:
                bound["unchanged"] += 1
            elif robot.steering_fraction(last, target, steer, dt) < 1.0:
                bound["turn"] += 1
            else:
                bound["speed"] += 1
    assert min(bound.values()) > 100, bound


def test_modules_the_planar_clamp_does_not_fit_take_the_array_clamp() -> None:
    """An axle offset (its drive limit moves with the steering), a failed module and a
    motor model each need the array clamp: no ``planar_modules`` for them."""
    from mpc.robots import motor_preset

    assert preset("swerve").planar_modules is not None
    assert preset("mpo700").planar_modules is None
    assert preset("swerve").derated({0: 0.0}).planar_modules is None
    assert motor_preset("swerve").planar_modules is None
    assert preset("mecanum").planar_modules is None and preset("swerve").scalar_wheels is None
