"""Each wheel's planned contact force vector (``Command.contact_forces``, the plan's
stages): with their moments they sum to the plan's ``M a``, computed here from the plan's
poses alone (SE(2) logarithm), the wheel positions and the mass, not from the wheel maps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpc import Controller
from mpc.robots import Robot, motor_preset, preset
from mpc.robots.drive.force_map import force_map, split_forces
from trajectories import FigureEight

DT = 0.05
TICKS = 12


def se2_twists(poses: np.ndarray, durations: np.ndarray) -> np.ndarray:
    """The constant body twist of each stage (N, 3) that carries pose k to pose k+1 in
    ``durations[k]`` seconds (the SE(2) logarithm, by hand)."""
    out = np.zeros((len(durations), 3))
    for k, h in enumerate(durations):
        x0, y0, t0 = poses[k]
        x1, y1, t1 = poses[k + 1]
        c, s = math.cos(t0), math.sin(t0)
        dx, dy = c * (x1 - x0) + s * (y1 - y0), -s * (x1 - x0) + c * (y1 - y0)
        dt = math.atan2(math.sin(t1 - t0), math.cos(t1 - t0))
        if abs(dt) < 1e-9:
            a, b = 1.0, 0.0
        else:
            a, b = math.sin(dt) / dt, (1.0 - math.cos(dt)) / dt
        vx, vy = np.linalg.solve([[a, -b], [b, a]], [dx, dy])  # V^-1 (dx, dy)
        out[k] = (vx / h, vy / h, dt / h)
    return out


def newton_euler(mass: float, inertia: float, last: np.ndarray, twists: np.ndarray,
                 durations: np.ndarray) -> np.ndarray:
    """(N, 3): ``m a_x, m a_y, I alpha`` of each stage, ``a = du/dt + (-w vy, w vx)`` at the
    stage's middle twist."""
    before = np.vstack([last[None, :], twists[:-1]])
    rate = (twists - before) / durations[:, None]
    middle = 0.5 * (twists + before)
    accel = rate + np.stack([-middle[:, 2] * middle[:, 1], middle[:, 2] * middle[:, 0],
                             np.zeros(len(middle))], axis=1)
    return accel * [mass, mass, inertia]


def resultant(robot: Robot, vectors: np.ndarray) -> np.ndarray:
    """(..., 3): the vectors' sum and their moment about the body origin."""
    p = robot.wheel_positions
    moment = (p[:, 0] * vectors[..., 1] - p[:, 1] * vectors[..., 0]).sum(axis=-1)
    return np.concatenate([vectors.sum(axis=-2), moment[..., None]], axis=-1)


def assert_relative(got: np.ndarray, want: np.ndarray) -> None:
    scale = np.maximum(np.abs(want).max(axis=-1, keepdims=True), 1e-9)
    assert np.abs(got - want).max() / scale.min() < 1e-6 or np.all(
        np.abs(got - want) <= 1e-6 * scale), (got, want)


def drive(controller: Controller, reference: FigureEight, steer: bool = False):
    """Step the controller along the reference's own poses (a perfect plant), yielding
    (the command before, the command)."""
    last = np.zeros(3)
    angles = np.zeros(controller.robot.n_wheels) if steer else None
    for k in range(TICKS):
        t = k * DT
        pose = reference.sample(np.array([t])).pose[0]
        if steer:
            command = controller.step(pose, t, steer_angles=angles)
            angles = command.predicted_steer_angles[1]
        else:
            command = controller.step(pose, t)
        yield last, command
        last = np.asarray(command.twist, dtype=float)


@pytest.mark.parametrize("name", ["swerve", "mecanum", "omni4", "omni3"])
def test_command_and_plan_forces_sum_to_m_a(name: str) -> None:
    robot = motor_preset(name)
    dyn = robot.dynamics
    assert dyn is not None
    forces = force_map(robot)
    size = 1.5
    reference = FigureEight(size, 6.0, heading=0.0)
    controller = Controller(robot, reference, 12, DT)
    durations = controller.model.durations
    seen = 0.0
    for last, command in drive(controller, reference):
        vectors = command.contact_forces
        assert vectors is not None and vectors.shape == (robot.n_wheels, 2)
        # the command's own first step
        want = newton_euler(dyn.mass, dyn.yaw_inertia, last,
                            np.asarray(command.twist)[None, :], np.array([DT]))[0]
        assert_relative(resultant(robot, vectors), want)
        # every stage of the plan, its twists read off its poses
        twists = se2_twists(command.predicted_poses, durations)
        stages = forces.plan_forces(np.asarray(command.twist), twists[1:], durations[1:])
        want = newton_euler(dyn.mass, dyn.yaw_inertia, np.asarray(command.twist),
                            twists[1:], durations[1:])
        assert_relative(resultant(robot, stages), want)
        seen = max(seen, float(np.abs(want).max()))
    assert seen > 1.0  # the plan did accelerate: the check is not on zeros


def test_swerve_lateral_force_is_carried() -> None:
    """On a cornering swerve the command's vectors carry the lateral force the drive
    components (``wheel_forces``) leave out: the drive components alone do not sum to
    ``m a``, the vectors do."""
    robot = motor_preset("swerve")
    dyn = robot.dynamics
    reference = FigureEight(1.5, 6.0, heading=0.0)
    controller = Controller(robot, reference, 12, DT)
    gaps = []
    for last, command in drive(controller, reference):
        want = newton_euler(dyn.mass, dyn.yaw_inertia, last,
                            np.asarray(command.twist)[None, :], np.array([DT]))[0]
        vectors = command.contact_forces
        angles = command.steer_angles
        along = np.sum(vectors * np.stack([np.cos(angles), np.sin(angles)], axis=1), axis=1)
        np.testing.assert_allclose(along, command.wheel_forces, rtol=1e-9, atol=1e-9)
        drive_only = resultant(robot, along[:, None] * np.stack(
            [np.cos(angles), np.sin(angles)], axis=1))
        gaps.append(np.linalg.norm(drive_only[:2] - want[:2]) / max(np.linalg.norm(want[:2]),
                                                                   1e-9))
    assert max(gaps) > 0.05  # the lateral part matters on this path


def test_caster_preset_split() -> None:
    """Casters (kinematic, no motor model): the same rigid-body split at the steer axes
    on every stage of the caster MPC's plan, for a given mass and inertia."""
    robot = preset("caster4")
    mass, inertia = 40.0, 2.5
    maps = split_forces(robot.wheel_blocks, np.diag([mass, mass, inertia]))
    reference = FigureEight(1.0, 12.0, heading=0.0)
    controller = Controller(robot, reference, 12, DT)
    durations = controller.model.durations
    seen = 0.0
    for _, command in drive(controller, reference, steer=True):
        twists = se2_twists(command.predicted_poses, durations)
        want = newton_euler(mass, inertia, np.asarray(command.twist), twists[1:],
                            durations[1:])
        before = np.vstack([np.asarray(command.twist)[None, :], twists[1:-1]])
        middle = 0.5 * (twists[1:] + before)
        accel = (twists[1:] - before) / durations[1:, None] + np.stack(
            [-middle[:, 2] * middle[:, 1], middle[:, 2] * middle[:, 0],
             np.zeros(len(middle))], axis=1)
        vectors = np.einsum("nkj,sj->snk", maps, accel)
        assert_relative(resultant(robot, vectors), want)
        seen = max(seen, float(np.abs(want).max()))
    assert seen > 0.1
